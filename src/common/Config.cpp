#include "common/Config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>

namespace vln::common {
namespace {

std::string joinPath(const std::vector<std::string>& path,
                     std::string_view key) {
  std::string out;
  for (const auto& part : path) out += part + ".";
  out += key;
  return out;
}

// Levenshtein distance, for "did you mean" hints on unknown keys.
size_t editDistance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1,
                         diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string boundsText(Bounds b) {
  std::ostringstream out;
  out << "[" << b.min << ", " << b.max << "]";
  return out.str();
}

// ---------------------------------------------------------------------------
// reading

// One `--set` applied to the tree: the key path it set and the assignment
// as given, which errors about that key name as their origin.
struct Override {
  std::string keyPath;
  std::string assignment;
};

// Assigns values from a YAML tree; tracks which keys each mapping consumed so
// that anything left over is reported as unknown.
class YamlReader final : public ConfigVisitor {
 public:
  YamlReader(YAML::Node root, std::string source,
             std::vector<Override> overrides = {})
      : source_(std::move(source)), overrides_(std::move(overrides)) {
    frames_.push_back({root, {}, true});
  }

  void field(std::string_view key, bool& value, std::string_view) override {
    if (auto found = take(key)) {
      const YAML::Node& node = *found;
      try {
        value = node.as<bool>();
      } catch (const YAML::Exception&) {
        fail(node, key, "expected true or false, got '" + text(node) + "'");
      }
    }
  }
  void field(std::string_view key, int& value, std::string_view,
             Bounds bounds) override {
    if (auto found = take(key)) {
      const YAML::Node& node = *found;
      int64_t wide = readInteger(node, key);
      checkBounds(node, key, static_cast<double>(wide), bounds);
      VLN_CHECK_ARG(wide >= std::numeric_limits<int>::min() &&
                        wide <= std::numeric_limits<int>::max(),
                    where(node, joinPath(path_, key)), "key '",
                    joinPath(path_, key), "': value out of int range");
      value = static_cast<int>(wide);
    }
  }
  void field(std::string_view key, int64_t& value, std::string_view,
             Bounds bounds) override {
    if (auto found = take(key)) {
      const YAML::Node& node = *found;
      value = readInteger(node, key);
      checkBounds(node, key, static_cast<double>(value), bounds);
    }
  }
  void field(std::string_view key, double& value, std::string_view,
             Bounds bounds) override {
    if (auto found = take(key)) {
      const YAML::Node& node = *found;
      value = readReal(node, key);
      checkBounds(node, key, value, bounds);
    }
  }
  void field(std::string_view key, float& value, std::string_view,
             Bounds bounds) override {
    if (auto found = take(key)) {
      const YAML::Node& node = *found;
      double wide = readReal(node, key);
      checkBounds(node, key, wide, bounds);
      value = static_cast<float>(wide);
    }
  }
  void field(std::string_view key, std::string& value,
             std::string_view) override {
    if (auto found = take(key)) value = readString(*found, key);
  }
  void field(std::string_view key, std::vector<std::string>& value,
             std::string_view) override {
    if (auto found = take(key)) {
      const YAML::Node& node = *found;
      value.clear();
      for (const auto& item : sequence(node, key))
        value.push_back(readString(item, key));
    }
  }
  void field(std::string_view key, std::vector<int>& value, std::string_view,
             Bounds bounds) override {
    if (auto found = take(key)) {
      const YAML::Node& node = *found;
      value.clear();
      for (const auto& item : sequence(node, key)) {
        int64_t wide = readInteger(item, key);
        checkBounds(item, key, static_cast<double>(wide), bounds);
        value.push_back(static_cast<int>(wide));
      }
    }
  }
  void field(std::string_view key, std::vector<double>& value,
             std::string_view, Bounds bounds) override {
    if (auto found = take(key)) {
      const YAML::Node& node = *found;
      value.clear();
      for (const auto& item : sequence(node, key)) {
        double real = readReal(item, key);
        checkBounds(item, key, real, bounds);
        value.push_back(real);
      }
    }
  }
  void choice(std::string_view key, std::string& value,
              const std::vector<std::string>& allowed,
              std::string_view) override {
    if (auto found = take(key)) {
      const YAML::Node& node = *found;
      std::string candidate = readString(node, key);
      if (std::find(allowed.begin(), allowed.end(), candidate) ==
          allowed.end()) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(node, key, "expected one of {" + list + "}, got '" + candidate +
                            "'");
      }
      value = candidate;
    }
  }
  void beginSection(std::string_view key, std::string_view) override {
    auto found = take(key);
    if (found && !found->IsMap())
      fail(*found, key, "expected a mapping (section), got '" + text(*found) + "'");
    path_.emplace_back(key);
    frames_.push_back({found ? *found : YAML::Node(), {}, found.has_value()});
  }
  void endSection() override {
    finishFrame();
    frames_.pop_back();
    path_.pop_back();
  }

  /// Reports keys of the root mapping that no field consumed.
  void finish() { finishFrame(); }

 private:
  struct Frame {
    YAML::Node node;
    std::vector<std::string> consumed;
    bool present;
  };

  // returns the child `key` of the current mapping (null node if absent)
  std::optional<YAML::Node> take(std::string_view key) {
    Frame& frame = frames_.back();
    if (!frame.present || !frame.node.IsMap()) return std::nullopt;
    frame.consumed.emplace_back(key);
    // lookup through a const node: yaml-cpp's non-const operator[] inserts
    const YAML::Node& map = frame.node;
    YAML::Node child = map[std::string(key)];
    if (!child) return std::nullopt;
    if (child.IsNull()) {
      fail(child, key, "value is empty (null); remove the key to keep the "
                       "default");
    }
    return child;
  }

  void finishFrame() {
    const Frame& frame = frames_.back();
    if (!frame.present || !frame.node.IsMap()) return;
    for (const auto& entry : frame.node) {
      auto name = entry.first.as<std::string>();
      if (std::find(frame.consumed.begin(), frame.consumed.end(), name) !=
          frame.consumed.end())
        continue;
      std::string hint;
      size_t best = 3;
      for (const auto& known : frame.consumed) {
        size_t d = editDistance(name, known);
        if (d < best) {
          best = d;
          hint = " (did you mean '" + joinPath(path_, known) + "'?)";
        }
      }
      throw std::invalid_argument(where(entry.first, joinPath(path_, name)) +
                                  "unknown key '" + joinPath(path_, name) +
                                  "'" + hint);
    }
  }

  // "<file>:<line>: ", or "--set a.b=v: " for a value that an override
  // put at `keyPath`, above it or below it (its marks are those of the
  // override's own text, not the file's)
  std::string where(const YAML::Node& node, const std::string& keyPath) const {
    const auto within = [](const std::string& inner, const std::string& outer) {
      return inner == outer || (inner.size() > outer.size() &&
                                inner.compare(0, outer.size(), outer) == 0 &&
                                inner[outer.size()] == '.');
    };
    for (auto it = overrides_.rbegin(); it != overrides_.rend(); ++it)
      if (within(keyPath, it->keyPath) || within(it->keyPath, keyPath))
        return "--set " + it->assignment + ": ";
    auto mark = node.Mark();
    if (mark.line >= 0)
      return source_ + ":" + std::to_string(mark.line + 1) + ": ";
    return source_ + ": ";
  }

  [[noreturn]] void fail(const YAML::Node& node, std::string_view key,
                         const std::string& what) const {
    const std::string keyPath = joinPath(path_, key);
    throw std::invalid_argument(where(node, keyPath) + "key '" + keyPath +
                                "': " + what);
  }

  static std::string text(const YAML::Node& node) {
    if (node.IsScalar()) return node.Scalar();
    std::ostringstream out;
    out << node;
    std::string s = out.str();
    std::replace(s.begin(), s.end(), '\n', ' ');
    return s;
  }

  int64_t readInteger(const YAML::Node& node, std::string_view key) const {
    if (!node.IsScalar()) fail(node, key, "expected an integer, got '" + text(node) + "'");
    try {
      return node.as<int64_t>();
    } catch (const YAML::Exception&) {
      fail(node, key, "expected an integer, got '" + text(node) + "'");
    }
  }
  double readReal(const YAML::Node& node, std::string_view key) const {
    if (!node.IsScalar()) fail(node, key, "expected a number, got '" + text(node) + "'");
    double value = 0;
    try {
      value = node.as<double>();
    } catch (const YAML::Exception&) {
      fail(node, key, "expected a number, got '" + text(node) + "'");
    }
    if (!std::isfinite(value))
      fail(node, key, "expected a finite number, got '" + text(node) + "'");
    return value;
  }
  std::string readString(const YAML::Node& node, std::string_view key) const {
    if (!node.IsScalar())
      fail(node, key, "expected a string, got '" + text(node) + "'");
    return node.Scalar();
  }
  YAML::Node sequence(const YAML::Node& node, std::string_view key) const {
    if (!node.IsSequence())
      fail(node, key, "expected a list, got '" + text(node) + "'");
    return node;
  }
  void checkBounds(const YAML::Node& node, std::string_view key, double value,
                   Bounds bounds) const {
    if (value < bounds.min || value > bounds.max)
      fail(node, key, "value " + text(node) + " is outside " + boundsText(bounds));
  }

  std::string source_;
  std::vector<Override> overrides_;
  std::vector<std::string> path_;
  std::vector<Frame> frames_;
};

// merges `overlay` into `base` recursively (overlay wins on scalars/lists)
YAML::Node mergeNodes(YAML::Node base, const YAML::Node& overlay) {
  if (!overlay.IsMap() || !base.IsMap()) return YAML::Clone(overlay);
  YAML::Node merged = YAML::Clone(base);
  for (const auto& entry : overlay) {
    auto key = entry.first.as<std::string>();
    const YAML::Node& constMerged = merged;
    if (constMerged[key])
      merged[key] = mergeNodes(constMerged[key], entry.second);
    else
      merged[key] = YAML::Clone(entry.second);
  }
  return merged;
}

YAML::Node parseYaml(std::string_view text, std::string_view source) {
  try {
    YAML::Node node = YAML::Load(std::string(text));
    if (node.IsNull()) return YAML::Node(YAML::NodeType::Map);
    VLN_CHECK_ARG(node.IsMap(), source,
                  ": config must be a YAML mapping of sections");
    return node;
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument(std::string(source) + ":" +
                                std::to_string(e.mark.line + 1) +
                                ": malformed YAML: " + e.msg);
  }
}

std::string readTextFile(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  VLN_CHECK_IO(in.good(), "readConfigFile(): cannot open config file '",
               file.string(), "'");
  std::ostringstream contents;
  contents << in.rdbuf();
  return contents.str();
}

// resolves `_base_` includes depth-first, relative to the including file
YAML::Node resolveBases(YAML::Node node, const std::filesystem::path& baseDir,
                        std::string_view source, int depth) {
  VLN_CHECK_ARG(depth < 16, source, ": _base_ includes nest too deep (cycle?)");
  const YAML::Node& constNode = node;
  YAML::Node bases = constNode["_base_"];
  if (!bases) return node;
  std::vector<std::string> files;
  if (bases.IsScalar()) {
    files.push_back(bases.Scalar());
  } else if (bases.IsSequence()) {
    for (const auto& item : bases) files.push_back(item.as<std::string>());
  } else {
    throw std::invalid_argument(std::string(source) +
                                ": key '_base_': expected a path or a list of paths");
  }
  node.remove("_base_");
  YAML::Node merged(YAML::NodeType::Map);
  for (const auto& file : files) {
    std::filesystem::path path = baseDir / file;
    std::string baseSource = path.string();
    YAML::Node base = parseYaml(readTextFile(path), baseSource);
    base = resolveBases(base, path.parent_path(), baseSource, depth + 1);
    merged = mergeNodes(merged, base);
  }
  return mergeNodes(merged, node);
}

// sets root[parts[0]][parts[1]]... = value, creating mappings on the way
void setPath(YAML::Node node, const std::vector<std::string>& parts, size_t i,
             const YAML::Node& value) {
  if (i + 1 == parts.size()) {
    node[parts[i]] = value;
    return;
  }
  const YAML::Node& lookup = node;
  YAML::Node existing = lookup[parts[i]];
  if (!existing || !existing.IsMap())
    node[parts[i]] = YAML::Node(YAML::NodeType::Map);
  setPath(node[parts[i]], parts, i + 1, value);
}

Override applyOverride(YAML::Node& root, const std::string& assignment) {
  auto eq = assignment.find('=');
  VLN_CHECK_ARG(eq != std::string::npos && eq > 0,
                "--set: expected section.key=value, got '", assignment, "'");
  std::string keyPath = assignment.substr(0, eq);
  std::string valueText = assignment.substr(eq + 1);
  YAML::Node value;
  try {
    value = YAML::Load(valueText);
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument("--set " + keyPath + ": malformed value '" +
                                valueText + "': " + e.msg);
  }
  if (value.IsNull() && valueText.empty()) value = YAML::Node(std::string());
  std::vector<std::string> parts;
  std::stringstream stream(keyPath);
  for (std::string part; std::getline(stream, part, '.');) {
    VLN_CHECK_ARG(!part.empty(), "--set: empty key component in '", keyPath, "'");
    parts.push_back(part);
  }
  setPath(root, parts, 0, value);
  return {keyPath, assignment};
}

// applyOverride() for each of `assignments`, in order
std::vector<Override> applyOverrides(
    YAML::Node& root, const std::vector<std::string>& assignments) {
  std::vector<Override> applied;
  for (const auto& assignment : assignments)
    applied.push_back(applyOverride(root, assignment));
  return applied;
}

// ---------------------------------------------------------------------------
// writing

std::string quoted(const std::string& s) {
  YAML::Emitter out;
  out << s;
  return out.c_str();
}

template <class T>
std::string scalarText(const T& v) {
  if constexpr (std::is_same_v<T, bool>) {
    return v ? "true" : "false";
  } else if constexpr (std::is_floating_point_v<T>) {
    std::ostringstream out;
    out.precision(std::numeric_limits<T>::max_digits10);
    out << v;
    std::string s = out.str();
    // keep it a float in YAML terms
    if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
    return s;
  } else if constexpr (std::is_same_v<T, std::string>) {
    return quoted(v);
  } else {
    return std::to_string(v);
  }
}

class YamlWriter final : public ConfigVisitor {
 public:
  void field(std::string_view key, bool& v, std::string_view doc) override {
    line(key, scalarText(v), doc);
  }
  void field(std::string_view key, int& v, std::string_view doc, Bounds) override {
    line(key, scalarText(v), doc);
  }
  void field(std::string_view key, int64_t& v, std::string_view doc, Bounds) override {
    line(key, scalarText(v), doc);
  }
  void field(std::string_view key, double& v, std::string_view doc, Bounds) override {
    line(key, scalarText(v), doc);
  }
  void field(std::string_view key, float& v, std::string_view doc, Bounds) override {
    line(key, scalarText(v), doc);
  }
  void field(std::string_view key, std::string& v, std::string_view doc) override {
    line(key, scalarText(v), doc);
  }
  void field(std::string_view key, std::vector<std::string>& v,
             std::string_view doc) override {
    line(key, list(v), doc);
  }
  void field(std::string_view key, std::vector<int>& v, std::string_view doc,
             Bounds) override {
    line(key, list(v), doc);
  }
  void field(std::string_view key, std::vector<double>& v,
             std::string_view doc, Bounds) override {
    line(key, list(v), doc);
  }
  void choice(std::string_view key, std::string& v,
              const std::vector<std::string>& allowed,
              std::string_view doc) override {
    std::string options;
    for (const auto& a : allowed) options += (options.empty() ? "" : "|") + a;
    line(key, scalarText(v), std::string(doc) + " [" + options + "]");
  }
  void beginSection(std::string_view key, std::string_view doc) override {
    if (!doc.empty()) out_ << indent() << "# " << doc << "\n";
    out_ << indent() << key << ":\n";
    ++depth_;
  }
  void endSection() override { --depth_; }

  std::string str() const { return out_.str(); }

 private:
  template <class T>
  std::string list(const std::vector<T>& items) {
    std::string s = "[";
    for (size_t i = 0; i < items.size(); ++i)
      s += (i ? ", " : "") + scalarText(items[i]);
    return s + "]";
  }
  std::string indent() const { return std::string(2 * depth_, ' '); }
  void line(std::string_view key, const std::string& value,
            std::string_view doc) {
    if (!doc.empty()) out_ << indent() << "# " << doc << "\n";
    out_ << indent() << key << ": " << value << "\n";
  }

  std::ostringstream out_;
  int depth_ = 0;
};

// ---------------------------------------------------------------------------
// checking values set in code

class BoundsChecker final : public ConfigVisitor {
 public:
  explicit BoundsChecker(std::string source) : source_(std::move(source)) {}
  void field(std::string_view, bool&, std::string_view) override {}
  void field(std::string_view key, int& v, std::string_view, Bounds b) override {
    check(key, v, b);
  }
  void field(std::string_view key, int64_t& v, std::string_view, Bounds b) override {
    check(key, static_cast<double>(v), b);
  }
  void field(std::string_view key, double& v, std::string_view, Bounds b) override {
    check(key, v, b);
  }
  void field(std::string_view key, float& v, std::string_view, Bounds b) override {
    // a float holding a bound like 0.02 is slightly below the double 0.02:
    // compare in float precision, as the value was stored
    const float lo = static_cast<float>(b.min);
    const float hi = static_cast<float>(b.max);
    VLN_CHECK_ARG(std::isfinite(v) && v >= lo && v <= hi, source_, ": key '",
                  joinPath(path_, key), "': value ", v, " is outside ",
                  boundsText(b));
  }
  void field(std::string_view, std::string&, std::string_view) override {}
  void field(std::string_view, std::vector<std::string>&, std::string_view) override {}
  void field(std::string_view key, std::vector<int>& v, std::string_view,
             Bounds b) override {
    for (int x : v) check(key, x, b);
  }
  void field(std::string_view key, std::vector<double>& v, std::string_view,
             Bounds b) override {
    for (double x : v) check(key, x, b);
  }
  void choice(std::string_view key, std::string& v,
              const std::vector<std::string>& allowed, std::string_view) override {
    VLN_CHECK_ARG(std::find(allowed.begin(), allowed.end(), v) != allowed.end(),
                  source_, ": key '", joinPath(path_, key), "': '", v,
                  "' is not an allowed value");
  }
  void beginSection(std::string_view key, std::string_view) override {
    path_.emplace_back(key);
  }
  void endSection() override { path_.pop_back(); }

 private:
  void check(std::string_view key, double v, Bounds b) {
    VLN_CHECK_ARG(std::isfinite(v) && v >= b.min && v <= b.max, source_,
                  ": key '", joinPath(path_, key), "': value ", v,
                  " is outside ", boundsText(b));
  }
  std::string source_;
  std::vector<std::string> path_;
};

// every key path with its doc, in visit order
class KeyLister final : public ConfigVisitor {
 public:
  std::vector<std::string> keys;
  std::vector<std::string> docs;
  void field(std::string_view k, bool&, std::string_view d) override { add(k, d); }
  void field(std::string_view k, int&, std::string_view d, Bounds) override { add(k, d); }
  void field(std::string_view k, int64_t&, std::string_view d, Bounds) override { add(k, d); }
  void field(std::string_view k, double&, std::string_view d, Bounds) override { add(k, d); }
  void field(std::string_view k, float&, std::string_view d, Bounds) override { add(k, d); }
  void field(std::string_view k, std::string&, std::string_view d) override { add(k, d); }
  void field(std::string_view k, std::vector<std::string>&, std::string_view d) override {
    add(k, d);
  }
  void field(std::string_view k, std::vector<int>&, std::string_view d, Bounds) override {
    add(k, d);
  }
  void field(std::string_view k, std::vector<double>&, std::string_view d, Bounds) override {
    add(k, d);
  }
  void choice(std::string_view k, std::string&, const std::vector<std::string>&,
              std::string_view d) override { add(k, d); }
  void beginSection(std::string_view k, std::string_view) override { path_.emplace_back(k); }
  void endSection() override { path_.pop_back(); }

 private:
  void add(std::string_view k, std::string_view d) {
    keys.push_back(joinPath(path_, k));
    docs.emplace_back(d);
  }
  std::vector<std::string> path_;
};

}  // namespace

void readConfig(std::string_view text, std::string_view source,
                const std::filesystem::path& baseDir,
                const std::vector<std::string>& overrides,
                const ConfigVisitFn& visit) {
  YAML::Node root = parseYaml(text, source);
  root = resolveBases(root, baseDir, source, 0);
  std::vector<Override> applied = applyOverrides(root, overrides);
  YamlReader reader(root, std::string(source), std::move(applied));
  visit(reader);
  reader.finish();
}

void readConfigFile(const std::filesystem::path& file,
                    const std::vector<std::string>& overrides,
                    const ConfigVisitFn& visit) {
  readConfig(readTextFile(file), file.string(), file.parent_path(), overrides,
             visit);
}

void readConfigFileSection(const std::filesystem::path& file,
                           std::string_view section,
                           const std::vector<std::string>& overrides,
                           const ConfigVisitFn& visit) {
  const std::string source = file.string();
  YAML::Node root = parseYaml(readTextFile(file), source);
  root = resolveBases(root, file.parent_path(), source, 0);
  std::vector<Override> applied = applyOverrides(root, overrides);
  // the one section, with its marks (lines) kept
  YAML::Node only(YAML::NodeType::Map);
  const YAML::Node& constRoot = root;
  if (YAML::Node found = constRoot[std::string(section)])
    only[std::string(section)] = found;
  YamlReader reader(only, source, std::move(applied));
  visit(reader);
  reader.finish();
}

std::string writeConfig(const ConfigVisitFn& visit) {
  YamlWriter writer;
  visit(writer);
  return writer.str();
}

void checkConfig(const ConfigVisitFn& visit, std::string_view source) {
  BoundsChecker checker{std::string(source)};
  visit(checker);
}

std::vector<std::string> configKeys(const ConfigVisitFn& visit) {
  KeyLister lister;
  visit(lister);
  return lister.keys;
}

std::string configDoc(const ConfigVisitFn& visit, std::string_view keyPath) {
  KeyLister lister;
  visit(lister);
  for (size_t i = 0; i < lister.keys.size(); ++i)
    if (lister.keys[i] == keyPath) return lister.docs[i];
  VLN_ASSERT(false);  // callers name keys of their own config
  return "";
}

}  // namespace vln::common

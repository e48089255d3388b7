#pragma once
// Configuration structs are plain aggregates with in-class defaults. Each one
// lists its fields once, in `void visit(ConfigVisitor&)`, with the YAML key
// (identical to the member name), its one-line doc and numeric bounds. That
// doc is the field's documentation (units, where a default comes from, what
// special values mean): the written config shows it beside the key, so the
// member declarations do not repeat it. Every
// generic operation is a visitor over that list: strict YAML reading (unknown
// keys, wrong types and out-of-range values are errors naming the file and
// the key path), `--set a.b=value` overrides, writing the resolved config with
// its docs, and bounds checks on values set in code. yaml-cpp stays in
// Config.cpp.

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <initializer_list>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "common/Check.h"

namespace vln::common {

/// Inclusive numeric bounds of a config field.
struct Bounds {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
};

/// Bounds [lo, +inf).
inline Bounds atLeast(double lo) {
  return {lo, std::numeric_limits<double>::infinity()};
}
/// Bounds [lo, hi].
inline Bounds inRange(double lo, double hi) { return {lo, hi}; }

/// The YAML names of an enum's values, for ConfigVisitor::enumeration() and
/// enumName().
template <class E, size_t N>
using EnumNames = std::array<std::pair<const char*, E>, N>;

/// The name of `value` in `names`; a value without one is a bug.
template <class E, size_t N>
const char* enumName(const EnumNames<E, N>& names, E value) {
  for (const auto& [name, enumValue] : names)
    if (enumValue == value) return name;
  VLN_ASSERT(false);
  return "";
}

/// Visits every field of a config struct. Implementations read, write or
/// check the values; config structs only enumerate their fields.
class ConfigVisitor {
 public:
  virtual ~ConfigVisitor() = default;

  virtual void field(std::string_view key, bool& value,
                     std::string_view doc) = 0;
  virtual void field(std::string_view key, int& value, std::string_view doc,
                     Bounds bounds = {}) = 0;
  virtual void field(std::string_view key, int64_t& value,
                     std::string_view doc, Bounds bounds = {}) = 0;
  virtual void field(std::string_view key, double& value,
                     std::string_view doc, Bounds bounds = {}) = 0;
  virtual void field(std::string_view key, float& value, std::string_view doc,
                     Bounds bounds = {}) = 0;
  virtual void field(std::string_view key, std::string& value,
                     std::string_view doc) = 0;
  virtual void field(std::string_view key, std::vector<std::string>& value,
                     std::string_view doc) = 0;
  virtual void field(std::string_view key, std::vector<int>& value,
                     std::string_view doc, Bounds bounds = {}) = 0;
  virtual void field(std::string_view key, std::vector<double>& value,
                     std::string_view doc, Bounds bounds = {}) = 0;
  /// A string field restricted to one of `allowed`.
  virtual void choice(std::string_view key, std::string& value,
                      const std::vector<std::string>& allowed,
                      std::string_view doc) = 0;
  /// Opens a nested mapping named `key`; paired with endSection().
  virtual void beginSection(std::string_view key, std::string_view doc) = 0;
  virtual void endSection() = 0;

  /// Visits `sub` (anything with visit(ConfigVisitor&)) as section `key`.
  template <class T>
  void section(std::string_view key, T& sub, std::string_view doc) {
    beginSection(key, doc);
    sub.visit(*this);
    endSection();
  }

  /// An enum field spelled in YAML by the names given in `names`.
  template <class E>
  void enumeration(std::string_view key, E& value,
                   std::initializer_list<std::pair<const char*, E>> names,
                   std::string_view doc) {
    enumerationOf<E>(key, value, {names.begin(), names.size()}, doc);
  }
  /// The same with a names table shared with enumName().
  template <class E, size_t N>
  void enumeration(std::string_view key, E& value, const EnumNames<E, N>& names,
                   std::string_view doc) {
    enumerationOf<E>(key, value, names, doc);
  }

 private:
  template <class E>
  void enumerationOf(std::string_view key, E& value,
                     std::span<const std::pair<const char*, E>> names,
                     std::string_view doc) {
    std::vector<std::string> allowed;
    std::string current;
    for (const auto& [name, enumValue] : names) {
      allowed.emplace_back(name);
      if (enumValue == value) current = name;
    }
    VLN_ASSERT(!current.empty());
    choice(key, current, allowed, doc);
    for (const auto& [name, enumValue] : names)
      if (current == name) value = enumValue;
  }
};

/// A function that visits the root of a config (`[&](ConfigVisitor& v) {
/// config.visit(v); }`).
using ConfigVisitFn = std::function<void(ConfigVisitor&)>;

/// Parses YAML `text` (called `source` in errors), applies `overrides` of the
/// form "section.key=value" (value in YAML syntax), and assigns every present
/// key through `visit`. A top-level `_base_: path` (or list of paths, relative
/// to `baseDir`) is merged underneath first. Throws std::invalid_argument
/// naming `source`, the line and the key path on unknown keys, wrong types and
/// out-of-range values.
void readConfig(std::string_view text, std::string_view source,
                const std::filesystem::path& baseDir,
                const std::vector<std::string>& overrides,
                const ConfigVisitFn& visit);

/// readConfig() on the contents of `file`; a missing or unreadable file throws
/// std::runtime_error naming it.
void readConfigFile(const std::filesystem::path& file,
                    const std::vector<std::string>& overrides,
                    const ConfigVisitFn& visit);

/// readConfigFile() for one top-level section of a larger config (e.g. the
/// `sim` section of a run config, for a tool that knows only that one):
/// `_base_` includes and `overrides` are resolved as there, then only the
/// key `section` is read through `visit`, which visits it as that section;
/// the file's other top-level keys are ignored. Errors name the file, the
/// line and the key path as readConfigFile()'s do.
void readConfigFileSection(const std::filesystem::path& file,
                           std::string_view section,
                           const std::vector<std::string>& overrides,
                           const ConfigVisitFn& visit);

/// The resolved config as YAML, every key with its doc line as a comment.
std::string writeConfig(const ConfigVisitFn& visit);

/// Throws std::invalid_argument naming `source` and the key path for the first
/// value outside its bounds or choices (for values set in code).
void checkConfig(const ConfigVisitFn& visit, std::string_view source);

/// Every key path of the config in visit order ("trainer.lr", ...).
std::vector<std::string> configKeys(const ConfigVisitFn& visit);

/// The doc of key path `keyPath` of the config (for command-line help that
/// exposes config fields); an unknown key is a bug.
std::string configDoc(const ConfigVisitFn& visit, std::string_view keyPath);

/// Loads a config struct T from a YAML file, applies overrides, checks bounds
/// and calls T::validate() if it has one.
template <class T>
T loadConfigFile(const std::filesystem::path& file,
                 const std::vector<std::string>& overrides = {}) {
  T config;
  ConfigVisitFn visit = [&](ConfigVisitor& v) { config.visit(v); };
  readConfigFile(file, overrides, visit);
  if constexpr (requires { config.validate(); }) config.validate();
  return config;
}

/// Same as loadConfigFile() for YAML text held in memory.
template <class T>
T loadConfigText(std::string_view text, std::string_view source = "<string>",
                 const std::vector<std::string>& overrides = {}) {
  T config;
  ConfigVisitFn visit = [&](ConfigVisitor& v) { config.visit(v); };
  readConfig(text, source, std::filesystem::current_path(), overrides, visit);
  if constexpr (requires { config.validate(); }) config.validate();
  return config;
}

/// YAML text of `config` (see writeConfig()).
template <class T>
std::string configToYaml(const T& config) {
  T copy = config;  // visit() is non-const because readers assign through it
  return writeConfig([&](ConfigVisitor& v) { copy.visit(v); });
}

}  // namespace vln::common

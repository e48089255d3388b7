#include "train/FeatureStore.h"

#include <torch/torch.h>

#include <lmdb.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/statvfs.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <random>

#include "common/Check.h"
#include "common/Json.h"
#include "train/Crc32c.h"

namespace vln::train {
namespace {

// Why a write of `needed` more bytes into `dir` failed, as far as the
// process can tell: the file size limit, a full filesystem, or neither.
std::string writeFailureCause(const std::filesystem::path& dir,
                              uint64_t needed) {
  rlimit limit{};
  if (::getrlimit(RLIMIT_FSIZE, &limit) == 0 &&
      limit.rlim_cur != RLIM_INFINITY && needed > limit.rlim_cur)
    return strCat("the file size limit, ulimit -f, is ", limit.rlim_cur,
                  " bytes");
  struct statvfs fs {};
  if (::statvfs(dir.c_str(), &fs) == 0) {
    const uint64_t free = static_cast<uint64_t>(fs.f_bavail) * fs.f_frsize;
    if (free < (uint64_t{1} << 20))
      return strCat("the disk is full: ", free, " bytes free");
    return strCat("a write error with ", free, " bytes free");
  }
  return "a write error";
}

static_assert(std::endian::native == std::endian::little,
              "the feature store format is little-endian");

constexpr char kMagic[4] = {'V', 'E', 'P', '1'};
constexpr size_t kHeaderBytes = 48;
constexpr const char* kMetaKey = "meta";
constexpr const char* kFormat = "vlnce-cpp feature store";
constexpr int kVersion = 1;
constexpr uint8_t kDtypeF16 = 1;
constexpr uint8_t kDtypeF32 = 2;

std::string episodeKey(int64_t index) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "e%012lld",
                static_cast<long long>(index));
  return buffer;
}

int64_t numel(const models::FeatureShape& shape) {
  return shape[0] * shape[1] * shape[2];
}

nlohmann::json shapeJson(const models::FeatureShape& s) {
  return nlohmann::json::array({s[0], s[1], s[2]});
}

template <class T>
void putRaw(std::string& out, const T& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

template <class T>
T getRaw(std::string_view bytes, size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof(T));
  return value;
}

// one header parse shared by the index scan and full reads
StoredEpisodeKey parseHeader(std::string_view bytes, const std::string& where) {
  VLN_CHECK_IO(
      bytes.size() >= kHeaderBytes && std::memcmp(bytes.data(), kMagic, 4) == 0,
      where, ": not an episode record (", bytes.size(), " bytes)");
  StoredEpisodeKey key;
  key.episode_id = getRaw<int64_t>(bytes, 8);
  key.iteration = getRaw<int32_t>(bytes, 16);
  key.slot = getRaw<int32_t>(bytes, 20);
  key.length = getRaw<int32_t>(bytes, 24);
  key.source = getRaw<uint8_t>(bytes, 32);
  VLN_CHECK_IO(key.length >= 1, where, ": episode record with length ",
               key.length);
  return key;
}

}  // namespace

// ---------------------------------------------------------------------------
// layout

int64_t StoreLayout::featureBytesPerStep() const {
  return (numel(rgb_shape) + numel(depth_shape)) * (fp16 ? 2 : 4);
}

nlohmann::json StoreLayout::toJson() const {
  return {{"rgb_shape", shapeJson(rgb_shape)},
          {"depth_shape", shapeJson(depth_shape)},
          {"dtype", fp16 ? "float16" : "float32"},
          {"config_hash", config_hash}};
}

StoreLayout StoreLayout::fromJson(const nlohmann::json& json,
                                  std::string_view source) {
  StoreLayout layout;
  auto rgb =
      common::requireField<std::vector<int64_t>>(json, "rgb_shape", source);
  auto depth =
      common::requireField<std::vector<int64_t>>(json, "depth_shape", source);
  VLN_CHECK_IO(rgb.size() == 3 && depth.size() == 3, source,
               ": rgb_shape and depth_shape must have 3 entries");
  layout.rgb_shape = {rgb[0], rgb[1], rgb[2]};
  layout.depth_shape = {depth[0], depth[1], depth[2]};
  auto dtype = common::requireField<std::string>(json, "dtype", source);
  VLN_CHECK_IO(dtype == "float16" || dtype == "float32", source,
               ": unknown dtype '", dtype, "'");
  layout.fp16 = dtype == "float16";
  layout.config_hash =
      common::requireField<std::string>(json, "config_hash", source);
  return layout;
}

// ---------------------------------------------------------------------------
// LMDB handles

struct FeatureStore::Lmdb {
  MDB_env* env = nullptr;
  MDB_dbi dbi = 0;
  ~Lmdb() {
    if (env) mdb_env_close(env);
  }
};

namespace {

// an aborting guard for transactions that are not committed
struct Txn {
  MDB_txn* txn = nullptr;
  ~Txn() {
    if (txn) mdb_txn_abort(txn);
  }
};

}  // namespace

FeatureStore::FeatureStore(const std::filesystem::path& dir, double maxGib,
                           bool readOnly)
    : dir_(dir), lmdb_(std::make_unique<Lmdb>()), readOnly_(readOnly) {
  openEnv(maxGib);
}

FeatureStore::FeatureStore(const std::filesystem::path& dir,
                           const StoreLayout& layout, double maxGib)
    : FeatureStore(dir, maxGib, /*readOnly=*/false) {
  std::string meta = readValue(kMetaKey);
  if (meta.empty()) {
    // a new store: an empty episode table and the layout, in one commit
    VLN_CHECK_IO(readValue(episodeKey(0)).empty(), "FeatureStore: '",
                 dir_.string(),
                 "' holds episodes but no meta record: corrupt store");
    layout_ = layout;
    Txn txn;
    int rc = mdb_txn_begin(lmdb_->env, nullptr, 0, &txn.txn);
    VLN_CHECK_IO(rc == 0, "FeatureStore: cannot begin a transaction in '",
                 dir_.string(), "': ", mdb_strerror(rc));
    nlohmann::json metaJson = {{"format", kFormat},
                               {"version", kVersion},
                               {"layout", layout_.toJson()},
                               {"episodes", 0},
                               {"steps", 0},
                               {"bytes", 0}};
    std::string text = metaJson.dump();
    MDB_val k{std::strlen(kMetaKey), const_cast<char*>(kMetaKey)};
    MDB_val v{text.size(), text.data()};
    rc = mdb_put(txn.txn, lmdb_->dbi, &k, &v, 0);
    if (rc == 0) rc = mdb_txn_commit(txn.txn);
    txn.txn = nullptr;
    VLN_CHECK_IO(rc == 0, "FeatureStore: cannot initialise '", dir_.string(),
                 "': ", mdb_strerror(rc));
  }
  loadIndex();
  VLN_CHECK_IO(layout_ == layout, "FeatureStore: '", dir_.string(),
               "' was written with a different layout or config: stored ",
               layout_.toJson().dump(), ", expected ", layout.toJson().dump(),
               " (use a new run directory)");
}

std::unique_ptr<FeatureStore> FeatureStore::openExisting(
    const std::filesystem::path& dir) {
  VLN_CHECK_IO(std::filesystem::exists(dir / "data.mdb"),
               "FeatureStore: no store in '", dir.string(),
               "' (data.mdb is missing)");
  std::unique_ptr<FeatureStore> store(
      new FeatureStore(dir, 0.0, /*readOnly=*/true));
  store->loadIndex();
  return store;
}

FeatureStore::~FeatureStore() = default;

void FeatureStore::openEnv(double maxGib) {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  VLN_CHECK_IO(!ec, "FeatureStore: cannot create '", dir_.string(),
               "': ", ec.message());
  int rc = mdb_env_create(&lmdb_->env);
  VLN_CHECK_IO(rc == 0,
               "FeatureStore: mdb_env_create failed: ", mdb_strerror(rc));
  // a read-only opener keeps the writer's map size: a write transaction
  // here would persist another size and break a concurrent writer
  if (!readOnly_) {
    const auto mapBytes =
        static_cast<size_t>(maxGib * 1024.0 * 1024.0 * 1024.0);
    rc = mdb_env_set_mapsize(lmdb_->env, mapBytes);
    VLN_CHECK_IO(rc == 0, "FeatureStore: cannot set the map size of '",
                 dir_.string(), "' to ", maxGib,
                 " GiB (trainer.store_max_gib): ", mdb_strerror(rc));
  }
  // MDB_NOTLS: read transactions are not tied to threads (prefetching)
  rc = mdb_env_open(lmdb_->env, dir_.c_str(),
                    MDB_NOTLS | (readOnly_ ? MDB_RDONLY : 0), 0664);
  if (rc != 0) {
    mdb_env_close(lmdb_->env);
    lmdb_->env = nullptr;
    throw std::runtime_error(
        strCat("FeatureStore: cannot open the store '", dir_.string(),
               "': ", mdb_strerror(rc),
               rc == MDB_INVALID ? " (corrupt or not an LMDB store)" : ""));
  }
  Txn txn;
  rc = mdb_txn_begin(lmdb_->env, nullptr, readOnly_ ? MDB_RDONLY : 0, &txn.txn);
  if (rc == 0) rc = mdb_dbi_open(txn.txn, nullptr, 0, &lmdb_->dbi);
  if (rc == 0) rc = mdb_txn_commit(txn.txn);
  txn.txn = nullptr;
  VLN_CHECK_IO(rc == 0, "FeatureStore: cannot open the database of '",
               dir_.string(), "': ", mdb_strerror(rc));
}

std::string FeatureStore::readValue(const std::string& key) const {
  Txn txn;
  int rc = mdb_txn_begin(lmdb_->env, nullptr, MDB_RDONLY, &txn.txn);
  VLN_CHECK_IO(rc == 0, "FeatureStore: cannot read '", dir_.string(),
               "': ", mdb_strerror(rc));
  MDB_val k{key.size(), const_cast<char*>(key.data())};
  MDB_val v{};
  rc = mdb_get(txn.txn, lmdb_->dbi, &k, &v);
  if (rc == MDB_NOTFOUND) return {};
  VLN_CHECK_IO(rc == 0, "FeatureStore: cannot read key '", key, "' of '",
               dir_.string(), "': ", mdb_strerror(rc));
  return std::string(static_cast<const char*>(v.mv_data), v.mv_size);
}

void FeatureStore::loadIndex() {
  const std::string where = "FeatureStore: '" + dir_.string() + "'";
  std::string metaText = readValue(kMetaKey);
  VLN_CHECK_IO(!metaText.empty(), where,
               " has no meta record: not a feature store");
  nlohmann::json meta;
  try {
    meta = nlohmann::json::parse(metaText);
  } catch (const std::exception& error) {
    throw std::runtime_error(where + ": corrupt meta record: " + error.what());
  }
  try {
    VLN_CHECK_IO(meta.value("format", "") == kFormat &&
                     meta.value("version", 0) == kVersion,
                 where, ": meta record is not a version ", kVersion,
                 " feature store");
    layout_ = StoreLayout::fromJson(
        common::requireField<nlohmann::json>(meta, "layout", where),
        where + " meta.layout");
    const auto episodes =
        common::requireField<int64_t>(meta, "episodes", where);
    // scan the record headers once: keys, lengths and slots stay in memory
    keys_.clear();
    totalSteps_ = 0;
    totalBytes_ = 0;
    Txn txn;
    int rc = mdb_txn_begin(lmdb_->env, nullptr, MDB_RDONLY, &txn.txn);
    VLN_CHECK_IO(rc == 0, where, ": ", mdb_strerror(rc));
    MDB_cursor* cursor = nullptr;
    rc = mdb_cursor_open(txn.txn, lmdb_->dbi, &cursor);
    VLN_CHECK_IO(rc == 0, where, ": ", mdb_strerror(rc));
    MDB_val k{}, v{};
    int64_t records = 0;
    for (rc = mdb_cursor_get(cursor, &k, &v, MDB_FIRST); rc == 0;
         rc = mdb_cursor_get(cursor, &k, &v, MDB_NEXT)) {
      std::string_view name(static_cast<const char*>(k.mv_data), k.mv_size);
      if (name == kMetaKey) continue;
      const std::string expected = episodeKey(records);
      if (name != expected) {
        mdb_cursor_close(cursor);
        throw std::runtime_error(strCat(where, ": unexpected key '", name,
                                        "' (expected '", expected,
                                        "'): corrupt store"));
      }
      std::string_view bytes(static_cast<const char*>(v.mv_data), v.mv_size);
      keys_.push_back(
          parseHeader(bytes, where + " episode " + std::to_string(records)));
      totalSteps_ += keys_.back().length;
      totalBytes_ += static_cast<int64_t>(bytes.size());
      ++records;
    }
    mdb_cursor_close(cursor);
    VLN_CHECK_IO(rc == MDB_NOTFOUND, where, ": ", mdb_strerror(rc));
    VLN_CHECK_IO(records == episodes, where, ": meta counts ", episodes,
                 " episodes but the store holds ", records, ": corrupt store");
  } catch (const std::invalid_argument& error) {
    throw std::runtime_error(std::string("corrupt meta record: ") +
                             error.what());
  }
}

// ---------------------------------------------------------------------------
// records

std::string FeatureStore::encode(const StoredEpisode& e) const {
  const int64_t T = e.length();
  VLN_CHECK_ARG(T >= 1, "FeatureStore::append(): episode ", e.key.episode_id,
                " has no steps");
  VLN_CHECK_ARG(
      static_cast<int64_t>(e.prev_actions.size()) == T &&
          static_cast<int64_t>(e.progress.size()) == T,
      "FeatureStore::append(): episode ", e.key.episode_id,
      ": prev_actions, oracle_actions and progress must have one entry per "
      "step, got ",
      e.prev_actions.size(), ", ", T, ", ", e.progress.size());
  auto features = [&](const torch::Tensor& t, const models::FeatureShape& shape,
                      const char* name) {
    if (shape[0] == 0) {
      VLN_CHECK_ARG(!t.defined(), "FeatureStore::append(): episode ",
                    e.key.episode_id, " has ", name,
                    " features but the store has none");
      return torch::Tensor();
    }
    VLN_CHECK_ARG(t.defined() && t.dim() == 4 && t.size(0) == T &&
                      t.size(1) == shape[0] && t.size(2) == shape[1] &&
                      t.size(3) == shape[2],
                  "FeatureStore::append(): episode ", e.key.episode_id,
                  ": expected ", name, " features [", T, ", ", shape[0], ", ",
                  shape[1], ", ", shape[2], "], got ",
                  t.defined() ? t.sizes() : torch::IntArrayRef{});
    return t.to(torch::kCPU, layout_.fp16 ? torch::kHalf : torch::kFloat32)
        .contiguous();
  };
  const torch::Tensor rgb = features(e.rgb, layout_.rgb_shape, "RGB");
  const torch::Tensor depth = features(e.depth, layout_.depth_shape, "depth");

  std::string out;
  out.reserve(kHeaderBytes + e.tokens.size() * 4 + static_cast<size_t>(T) * 6 +
              static_cast<size_t>(T * layout_.featureBytesPerStep()));
  out.append(kMagic, 4);
  putRaw<uint32_t>(out, 0);  // CRC, filled in below
  putRaw<int64_t>(out, e.key.episode_id);
  putRaw<int32_t>(out, e.key.iteration);
  putRaw<int32_t>(out, e.key.slot);
  putRaw<int32_t>(out, static_cast<int32_t>(T));
  putRaw<int32_t>(out, static_cast<int32_t>(e.tokens.size()));
  putRaw<uint8_t>(out, e.key.source);
  putRaw<uint8_t>(out, layout_.fp16 ? kDtypeF16 : kDtypeF32);
  putRaw<uint16_t>(out, 0);
  putRaw<int32_t>(out, static_cast<int32_t>(numel(layout_.rgb_shape)));
  putRaw<int32_t>(out, static_cast<int32_t>(numel(layout_.depth_shape)));
  putRaw<int32_t>(out, 0);
  VLN_ASSERT(out.size() == kHeaderBytes);
  out.append(reinterpret_cast<const char*>(e.tokens.data()),
             e.tokens.size() * 4);
  out.append(reinterpret_cast<const char*>(e.prev_actions.data()),
             e.prev_actions.size());
  out.append(reinterpret_cast<const char*>(e.oracle_actions.data()),
             e.oracle_actions.size());
  out.append(reinterpret_cast<const char*>(e.progress.data()),
             e.progress.size() * 4);
  for (const torch::Tensor& t : {rgb, depth})
    if (t.defined())
      out.append(static_cast<const char*>(t.data_ptr()),
                 static_cast<size_t>(t.numel()) * t.element_size());
  const uint32_t crc = crc32c(std::string_view(out).substr(8));
  std::memcpy(out.data() + 4, &crc, 4);
  return out;
}

StoredEpisode FeatureStore::decode(std::string_view bytes,
                                   int64_t index) const {
  const std::string where =
      "FeatureStore: '" + dir_.string() + "' episode " + std::to_string(index);
  StoredEpisode e;
  e.key = parseHeader(bytes, where);
  const uint32_t crc = getRaw<uint32_t>(bytes, 4);
  VLN_CHECK_IO(crc32c(bytes.substr(8)) == crc, where,
               ": checksum mismatch: corrupt store");
  const int64_t T = e.key.length;
  const auto L = getRaw<int32_t>(bytes, 28);
  const auto dtype = getRaw<uint8_t>(bytes, 33);
  VLN_CHECK_IO(L >= 0 && dtype == (layout_.fp16 ? kDtypeF16 : kDtypeF32) &&
                   getRaw<int32_t>(bytes, 36) == numel(layout_.rgb_shape) &&
                   getRaw<int32_t>(bytes, 40) == numel(layout_.depth_shape),
               where, ": record does not match the store layout ",
               layout_.toJson().dump());
  const size_t elem = layout_.fp16 ? 2 : 4;
  const size_t expected = kHeaderBytes + static_cast<size_t>(L) * 4 +
                          static_cast<size_t>(T) * 6 +
                          static_cast<size_t>(T) * elem *
                              static_cast<size_t>(numel(layout_.rgb_shape) +
                                                  numel(layout_.depth_shape));
  VLN_CHECK_IO(bytes.size() == expected, where, ": record of ", bytes.size(),
               " bytes, expected ", expected);
  size_t at = kHeaderBytes;
  e.tokens.resize(static_cast<size_t>(L));
  std::memcpy(e.tokens.data(), bytes.data() + at, e.tokens.size() * 4);
  at += e.tokens.size() * 4;
  e.prev_actions.assign(bytes.data() + at, bytes.data() + at + T);
  at += static_cast<size_t>(T);
  e.oracle_actions.assign(bytes.data() + at, bytes.data() + at + T);
  at += static_cast<size_t>(T);
  e.progress.resize(static_cast<size_t>(T));
  std::memcpy(e.progress.data(), bytes.data() + at, static_cast<size_t>(T) * 4);
  at += static_cast<size_t>(T) * 4;
  auto features = [&](const models::FeatureShape& shape) {
    if (shape[0] == 0) return torch::Tensor();
    torch::Tensor t =
        torch::empty({T, shape[0], shape[1], shape[2]},
                     layout_.fp16 ? torch::kHalf : torch::kFloat32);
    const size_t n = static_cast<size_t>(t.numel()) * elem;
    std::memcpy(t.data_ptr(), bytes.data() + at, n);
    at += n;
    return t;
  };
  e.rgb = features(layout_.rgb_shape);
  e.depth = features(layout_.depth_shape);
  return e;
}

void FeatureStore::append(const StoredEpisode& episode) {
  VLN_CHECK_ARG(!readOnly_, "FeatureStore::append(): '", dir_.string(),
                "' was opened read-only");
  const std::string value = encode(episode);
  const int64_t index = size();
  const std::string key = episodeKey(index);
  nlohmann::json meta = {
      {"format", kFormat},
      {"version", kVersion},
      {"layout", layout_.toJson()},
      {"episodes", index + 1},
      {"steps", totalSteps_ + episode.length()},
      {"bytes", totalBytes_ + static_cast<int64_t>(value.size())}};
  const std::string metaText = meta.dump();

  // the episode and the meta record commit together or not at all
  Txn txn;
  int rc = mdb_txn_begin(lmdb_->env, nullptr, 0, &txn.txn);
  VLN_CHECK_IO(rc == 0, "FeatureStore: cannot begin a write in '",
               dir_.string(), "': ", mdb_strerror(rc));
  MDB_val k{key.size(), const_cast<char*>(key.data())};
  MDB_val v{value.size(), const_cast<char*>(value.data())};
  rc = mdb_put(txn.txn, lmdb_->dbi, &k, &v, MDB_NOOVERWRITE);
  if (rc == 0) {
    MDB_val mk{std::strlen(kMetaKey), const_cast<char*>(kMetaKey)};
    MDB_val mv{metaText.size(), const_cast<char*>(metaText.data())};
    rc = mdb_put(txn.txn, lmdb_->dbi, &mk, &mv, 0);
  }
  if (rc == 0 && beforeCommit_) beforeCommit_();
  if (rc == 0) {
    rc = mdb_txn_commit(txn.txn);
    txn.txn = nullptr;  // committed or freed by a failed commit
  }
  if (rc == MDB_MAP_FULL)
    throw std::runtime_error(
        strCat("FeatureStore: the store '", dir_.string(), "' is full (",
               fileBytes(), " bytes on disk) after ", index,
               " episodes: raise trainer.store_max_gib (LMDB map size)"));
  // LMDB reports a short page write as EIO: tell the likely cause
  if (rc == EIO || rc == ENOSPC || rc == EFBIG || rc == EDQUOT)
    throw std::runtime_error(strCat(
        "FeatureStore: cannot write episode ", episode.key.episode_id, " to '",
        dir_.string(), "': ", mdb_strerror(rc), " (",
        writeFailureCause(dir_,
                          static_cast<uint64_t>(fileBytes()) + value.size()),
        "); the ", index,
        " episodes committed before it are intact: free space or lift the "
        "limit, then train --resume"));
  VLN_CHECK_IO(rc == 0, "FeatureStore: cannot write episode ",
               episode.key.episode_id, " to '", dir_.string(),
               "': ", mdb_strerror(rc));
  keys_.push_back(episode.key);
  keys_.back().length = static_cast<int32_t>(episode.length());
  totalSteps_ += episode.length();
  totalBytes_ += static_cast<int64_t>(value.size());
}

StoredEpisode FeatureStore::read(int64_t index) const {
  VLN_CHECK_ARG(index >= 0 && index < size(), "FeatureStore::read(): index ",
                index, " outside [0, ", size(), ") in '", dir_.string(), "'");
  Txn txn;
  int rc = mdb_txn_begin(lmdb_->env, nullptr, MDB_RDONLY, &txn.txn);
  VLN_CHECK_IO(rc == 0, "FeatureStore: cannot read '", dir_.string(),
               "': ", mdb_strerror(rc));
  const std::string key = episodeKey(index);
  MDB_val k{key.size(), const_cast<char*>(key.data())};
  MDB_val v{};
  rc = mdb_get(txn.txn, lmdb_->dbi, &k, &v);
  VLN_CHECK_IO(rc == 0, "FeatureStore: '", dir_.string(), "': episode ", index,
               " cannot be read: ", mdb_strerror(rc));
  // decode copies out of the map before the transaction ends
  return decode(
      std::string_view(static_cast<const char*>(v.mv_data), v.mv_size), index);
}

const StoredEpisodeKey& FeatureStore::key(int64_t index) const {
  VLN_ASSERT(index >= 0 && index < size());
  return keys_[static_cast<size_t>(index)];
}

std::set<int32_t> FeatureStore::slots(int32_t iteration) const {
  std::set<int32_t> result;
  for (const auto& k : keys_)
    if (k.iteration == iteration) result.insert(k.slot);
  return result;
}

double FeatureStore::bytesPerStep() const {
  return totalSteps_ > 0 ? static_cast<double>(totalBytes_) /
                               static_cast<double>(totalSteps_)
                         : 0.0;
}

int64_t FeatureStore::fileBytes() const {
  struct stat st {};
  if (::stat((dir_ / "data.mdb").c_str(), &st) != 0) return 0;
  return static_cast<int64_t>(st.st_size);
}

// ---------------------------------------------------------------------------
// batches

EpisodeBatch FeatureStore::loadBatch(std::span<const int64_t> indices) const {
  VLN_CHECK_ARG(!indices.empty(), "FeatureStore::loadBatch(): empty batch");
  std::vector<StoredEpisode> episodes;
  episodes.reserve(indices.size());
  for (int64_t index : indices) episodes.push_back(read(index));
  EpisodeBatch batch = batchEpisodes(episodes, layout_);
  batch.indices.assign(indices.begin(), indices.end());
  return batch;
}

EpisodeBatch batchEpisodes(std::span<const StoredEpisode> episodes,
                           const StoreLayout& layout) {
  VLN_CHECK_ARG(!episodes.empty(), "batchEpisodes(): empty batch");
  int64_t T = 0;
  int64_t L = 1;
  for (const StoredEpisode& e : episodes) {
    T = std::max(T, e.length());
    L = std::max<int64_t>(L, static_cast<int64_t>(e.tokens.size()));
  }
  const auto B = static_cast<int64_t>(episodes.size());
  EpisodeBatch batch;
  batch.prev_actions = torch::zeros({T, B}, torch::kInt64);
  batch.oracle_actions = torch::zeros({T, B}, torch::kInt64);
  batch.progress = torch::zeros({T, B}, torch::kFloat32);
  batch.valid = torch::zeros({T, B}, torch::kBool);
  batch.not_done = torch::ones({T, B}, torch::kFloat32);
  batch.not_done[0].fill_(0.0f);
  batch.tokens = torch::zeros({B, L}, torch::kInt64);
  auto feature = [&](const models::FeatureShape& s) {
    return s[0] == 0 ? torch::Tensor()
                     : torch::zeros({T, B, s[0], s[1], s[2]}, torch::kFloat32);
  };
  batch.rgb = feature(layout.rgb_shape);
  batch.depth = feature(layout.depth_shape);
  auto prev = batch.prev_actions.accessor<int64_t, 2>();
  auto oracle = batch.oracle_actions.accessor<int64_t, 2>();
  auto progress = batch.progress.accessor<float, 2>();
  auto valid = batch.valid.accessor<bool, 2>();
  auto tokens = batch.tokens.accessor<int64_t, 2>();
  for (int64_t b = 0; b < B; ++b) {
    const StoredEpisode& e = episodes[static_cast<size_t>(b)];
    for (int64_t t = 0; t < e.length(); ++t) {
      prev[t][b] = e.prev_actions[static_cast<size_t>(t)];
      oracle[t][b] = e.oracle_actions[static_cast<size_t>(t)];
      progress[t][b] = e.progress[static_cast<size_t>(t)];
      valid[t][b] = true;
    }
    for (size_t i = 0; i < e.tokens.size(); ++i)
      tokens[b][static_cast<int64_t>(i)] = e.tokens[i];
    if (batch.rgb.defined())
      batch.rgb.select(1, b).slice(0, 0, e.length()).copy_(e.rgb);
    if (batch.depth.defined())
      batch.depth.select(1, b).slice(0, 0, e.length()).copy_(e.depth);
    batch.steps += e.length();
  }
  return batch;
}

std::vector<std::vector<int64_t>> epochBatches(std::span<const int32_t> lengths,
                                               int batchSize, uint64_t seed,
                                               int epoch) {
  VLN_CHECK_ARG(batchSize >= 1, "epochBatches(): batchSize must be >= 1, got ",
                batchSize);
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull +
                      static_cast<uint64_t>(epoch) + 1);
  auto shuffle = [&](auto& values) {
    for (size_t i = values.size(); i > 1; --i)
      std::swap(values[i - 1], values[static_cast<size_t>(rng() % i)]);
  };
  std::vector<int64_t> order(lengths.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int64_t>(i);
  shuffle(order);

  std::vector<std::vector<int64_t>> batches;
  const size_t chunk = static_cast<size_t>(batchSize) * 100;
  for (size_t begin = 0; begin < order.size(); begin += chunk) {
    const size_t end = std::min(order.size(), begin + chunk);
    // sort the chunk by length, ties in the shuffled order
    std::vector<std::pair<int32_t, size_t>> byLength;
    for (size_t i = begin; i < end; ++i)
      byLength.emplace_back(lengths[static_cast<size_t>(order[i])], i);
    std::sort(byLength.begin(), byLength.end());
    std::vector<std::vector<int64_t>> chunkBatches;
    for (size_t i = 0; i < byLength.size();
         i += static_cast<size_t>(batchSize)) {
      std::vector<int64_t> batch;
      for (size_t j = i;
           j < std::min(byLength.size(), i + static_cast<size_t>(batchSize));
           ++j)
        batch.push_back(order[byLength[j].second]);
      chunkBatches.push_back(std::move(batch));
    }
    shuffle(chunkBatches);
    for (auto& b : chunkBatches) batches.push_back(std::move(b));
  }
  return batches;
}

}  // namespace vln::train

#pragma once
// The on-disk store of collected episodes for imitation learning (LMDB, as
// VLN-CE's DAgger trainer): the frozen encoders run once per observation
// and what is kept per episode is
//   episode id, collection round (DAgger iteration) and slot in that
//   round's episode list, the source split (train or augmentation), the
//   instruction tokens (PAD removed), the RGB and depth feature maps per
//   step [T, C, h, w] (float16 or float32), the previous actions, the
//   oracle actions to imitate and the progress targets, T being the valid
//   length.
//
// Durability: append-only; each episode is one LMDB write transaction that
// also rewrites the meta record (episode count, total steps and bytes, the
// layout: shapes, dtype, config hash). LMDB commits are atomic and durable
// (no MDB_NOSYNC), so a kill -9 at any moment leaves the store as of the
// last committed episode: every committed episode is complete and nothing
// partial is visible. Every record carries a CRC-32C of its payload,
// checked when it is read.
//
// Layout on disk: <dir>/data.mdb and <dir>/lock.mdb (LMDB's directory
// mode). Keys: "e<12-digit index>" per episode, "meta" (JSON).

#include <ATen/core/Tensor.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <set>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "models/ModelConfig.h"

namespace vln::train {

/// What every episode of a store looks like; fixed when the store is created
/// and checked on every reopen.
struct StoreLayout {
  /// [C, h, w] of the RGB feature maps; all zero when the model has no RGB.
  models::FeatureShape rgb_shape{0, 0, 0};
  /// [C, h, w] of the depth feature maps; all zero without depth.
  models::FeatureShape depth_shape{0, 0, 0};
  /// Features stored as float16 (else float32).
  bool fp16 = true;
  /// Hash of the config that determines the stored features and episode
  /// lists (storeConfigHash() in the trainer).
  std::string config_hash;

  bool hasRgb() const { return rgb_shape[0] > 0; }
  bool hasDepth() const { return depth_shape[0] > 0; }
  /// Bytes of one step's features.
  int64_t featureBytesPerStep() const;
  nlohmann::json toJson() const;
  static StoreLayout fromJson(const nlohmann::json& json,
                              std::string_view source);
  bool operator==(const StoreLayout&) const = default;
};

/// Which collected episode an index holds (for resume bookkeeping).
struct StoredEpisodeKey {
  int64_t episode_id = 0;
  int32_t iteration = 0;  ///< collection round (DAgger iteration; 0 for TF)
  int32_t slot = 0;       ///< position in that round's episode list
  uint8_t source = 0;     ///< 0: dataset.train_split, 1: dataset.aug_split
  int32_t length = 0;     ///< steps T
};

/// One collected episode.
struct StoredEpisode {
  StoredEpisodeKey key;
  std::vector<int32_t> tokens;  ///< instruction tokens, PAD removed
  std::vector<uint8_t>
      prev_actions;  ///< [T] action taken before step t (0 at t = 0)
  std::vector<uint8_t>
      oracle_actions;           ///< [T] oracle action at step t (the label)
  std::vector<float> progress;  ///< [T] progress target at step t
  at::Tensor
      rgb;  ///< [T, C, h, w] CPU float16/float32; undefined without RGB
  at::Tensor
      depth;  ///< [T, C, h, w] CPU float16/float32; undefined without depth

  int64_t length() const { return static_cast<int64_t>(oracle_actions.size()); }
};

/// Whole episodes padded to the longest one, time-major (PolicyImpl's
/// sequence mode), on the CPU.
struct EpisodeBatch {
  at::Tensor rgb;    ///< [T, B, C, h, w] float32; undefined without RGB
  at::Tensor depth;  ///< [T, B, C, h, w] float32; undefined without depth
  at::Tensor prev_actions;    ///< [T, B] int64 (0 at padding)
  at::Tensor oracle_actions;  ///< [T, B] int64 (0 at padding)
  at::Tensor progress;        ///< [T, B] float32 (0 at padding)
  at::Tensor valid;           ///< [T, B] bool, true at real steps
  at::Tensor not_done;        ///< [T, B] float32, 0 at t = 0 else 1
  at::Tensor tokens;          ///< [B, L] int64, PAD 0 on the right (L >= 1)
  /// [B, L, D] float32, zero rows on the right: the instructions' text
  /// features for model.instruction_features: rxr_text (filled by the
  /// caller, not by the store, which keeps tokens); undefined otherwise.
  at::Tensor text_features;
  std::vector<int64_t> indices;  ///< store indices of the B episodes
  int64_t steps = 0;             ///< real (valid) steps in the batch
};

class FeatureStore {
 public:
  /// Opens the store in directory `dir`, creating it (with `layout`) when
  /// it holds none. An existing store must have been written with the same
  /// layout (shapes, dtype, config hash), else std::runtime_error names the
  /// directory and both layouts. `maxGib` is the LMDB map size. A corrupt
  /// store (unreadable LMDB file, missing or malformed meta, a record count
  /// that disagrees with the meta) is a std::runtime_error naming `dir`.
  FeatureStore(const std::filesystem::path& dir, const StoreLayout& layout,
               double maxGib);
  /// Opens an existing store read-only with whatever layout it has (tools,
  /// tests; safe while another process appends). append() is refused.
  static std::unique_ptr<FeatureStore> openExisting(
      const std::filesystem::path& dir);
  ~FeatureStore();
  FeatureStore(const FeatureStore&) = delete;
  FeatureStore& operator=(const FeatureStore&) = delete;

  /// Appends `episode` as index size() in one transaction (with the meta
  /// update). Throws std::invalid_argument when its tensors do not match
  /// the layout and std::runtime_error naming the directory on I/O errors,
  /// MDB_MAP_FULL included (raise trainer.store_max_gib); nothing is
  /// written then.
  void append(const StoredEpisode& episode);

  /// Episode `index` in [0, size()); checks its CRC (std::runtime_error
  /// naming the directory and index when corrupt).
  StoredEpisode read(int64_t index) const;

  /// The episodes `indices`, padded to the longest (see EpisodeBatch).
  EpisodeBatch loadBatch(std::span<const int64_t> indices) const;

  int64_t size() const { return static_cast<int64_t>(keys_.size()); }
  /// Key of episode `index` (kept in memory).
  const StoredEpisodeKey& key(int64_t index) const;
  /// Slots of round `iteration` already in the store.
  std::set<int32_t> slots(int32_t iteration) const;
  const StoreLayout& layout() const { return layout_; }
  const std::filesystem::path& dir() const { return dir_; }
  /// Steps over all episodes.
  int64_t totalSteps() const { return totalSteps_; }
  /// Record bytes over all episodes (values only, without LMDB overhead).
  int64_t totalBytes() const { return totalBytes_; }
  /// totalBytes() / totalSteps() (0 when empty).
  double bytesPerStep() const;
  /// Size of data.mdb on disk, bytes.
  int64_t fileBytes() const;

  /// Test hook: when set, append() calls it after writing the episode but
  /// before committing (e.g. to _exit() mid-transaction).
  void setBeforeCommitHook(std::function<void()> hook) {
    beforeCommit_ = std::move(hook);
  }

 private:
  FeatureStore(const std::filesystem::path& dir, double maxGib, bool readOnly);
  void openEnv(double maxGib);
  void loadIndex();
  std::string encode(const StoredEpisode& episode) const;
  StoredEpisode decode(std::string_view bytes, int64_t index) const;
  std::string readValue(const std::string& key) const;

  std::filesystem::path dir_;
  StoreLayout layout_;
  struct Lmdb;
  std::unique_ptr<Lmdb> lmdb_;
  std::vector<StoredEpisodeKey> keys_;
  int64_t totalSteps_ = 0;
  int64_t totalBytes_ = 0;
  std::function<void()> beforeCommit_;
  bool readOnly_ = false;
};

/// `episodes` padded to the longest into a batch of `layout`'s feature
/// shapes (their features may be float16 or float32; the batch's are
/// float32); `indices` is left empty. What loadBatch() returns for stored
/// episodes, and the recollect trainer for re-simulated ones. Throws
/// std::invalid_argument for an empty list.
EpisodeBatch batchEpisodes(std::span<const StoredEpisode> episodes,
                           const StoreLayout& layout);

/// The batches of one epoch over episodes with `lengths`: a seeded shuffle
/// (deterministic in seed and epoch), then, as VLN-CE's IWTrajectoryDataset,
/// chunks of batchSize * 100 episodes are sorted by length (ties broken at
/// random) and cut into batches of batchSize whose order is shuffled, so a
/// batch pads little. Every index appears exactly once; the last batch may
/// be smaller (VLN-CE drops it; small stores would lose data).
std::vector<std::vector<int64_t>> epochBatches(std::span<const int32_t> lengths,
                                               int batchSize, uint64_t seed,
                                               int epoch);

}  // namespace vln::train

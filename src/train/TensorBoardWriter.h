#pragma once
// TensorBoard event files without a protobuf dependency: the few protobuf
// fields TensorBoard's scalar and image plugins read are encoded by hand.
//
// File: <dir>/events.out.tfevents.<unix seconds>.<hostname>, a sequence of
// TFRecords, each
//   uint64 length (little-endian), uint32 masked CRC-32C of those 8 bytes,
//   <length> bytes of data, uint32 masked CRC-32C of the data,
// whose data is a serialised tensorflow.Event (event.proto):
//   1: wall_time (double, seconds since the epoch), 2: step (int64),
//   3: file_version (string, first record only: "brain.Event:2"),
//   5: summary (tensorflow.Summary, summary.proto): repeated 1: value
//      { 1: tag (string), 2: simple_value (float) } or
//      { 1: tag, 4: image (Summary.Image) { 1: height (int32), 2: width
//        (int32), 3: colorspace (int32: 1 grey, 3 RGB, 4 RGBA),
//        4: encoded_image_string (bytes: PNG, or an animated GIF, which
//        TensorBoard's image tab plays: tensorboardX's add_video) } }.
// Records are appended and flushed after every call, so a killed run keeps
// everything logged before the kill.

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace vln::train {

class TensorBoardWriter {
 public:
  /// Creates a new event file in `dir` (created if missing). Throws
  /// std::runtime_error naming the file when it cannot be written.
  explicit TensorBoardWriter(const std::filesystem::path& dir);
  ~TensorBoardWriter();
  TensorBoardWriter(const TensorBoardWriter&) = delete;
  TensorBoardWriter& operator=(const TensorBoardWriter&) = delete;

  /// Appends one Event holding the scalars `values` (tag, value) at `step`.
  void addScalars(int64_t step,
                  const std::vector<std::pair<std::string, double>>& values,
                  double wallTime = -1.0);
  /// One scalar.
  void addScalar(const std::string& tag, double value, int64_t step) {
    addScalars(step, {{tag, value}});
  }
  /// Appends one Event holding an image at `step`: `encoded` is the PNG
  /// (a picture) or GIF (a video) of a `width` x `height` image with
  /// `channels` 1 (grey), 3 (RGB) or 4 (RGBA); std::invalid_argument names
  /// the tag otherwise.
  void addImage(const std::string& tag, int64_t step,
                const std::string& encoded, int width, int height, int channels,
                double wallTime = -1.0);
  const std::filesystem::path& file() const { return file_; }

 private:
  void writeRecord(const std::string& data);
  std::filesystem::path file_;
  std::FILE* out_ = nullptr;
};

/// One decoded scalar event (for tests and tools).
struct TensorBoardScalar {
  double wall_time = 0.0;
  int64_t step = 0;
  std::string tag;
  float value = 0.0f;
};

/// One decoded image event.
struct TensorBoardImage {
  double wall_time = 0.0;
  int64_t step = 0;
  std::string tag;
  int height = 0;
  int width = 0;
  int colorspace = 0;
  std::string encoded;  ///< encoded_image_string (PNG, GIF)
};

/// Contents of an event file: the file_version string of the first record,
/// every scalar and every image, each in file order. Checks both CRCs of
/// every record; throws std::runtime_error naming the file and the byte
/// offset of a bad record.
struct TensorBoardFile {
  std::string file_version;
  std::vector<TensorBoardScalar> scalars;
  std::vector<TensorBoardImage> images;
};
TensorBoardFile readTensorBoardFile(const std::filesystem::path& file);

/// The serialised Event protobuf of scalars (exposed for tests).
std::string encodeScalarEvent(
    double wallTime, int64_t step,
    const std::vector<std::pair<std::string, double>>& values);

/// The serialised Event protobuf of one image (exposed for tests).
std::string encodeImageEvent(double wallTime, int64_t step,
                             const std::string& tag, const std::string& encoded,
                             int width, int height, int channels);

}  // namespace vln::train

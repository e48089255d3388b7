#pragma once
// NumPy's .npy and .npz files, read into float32 without LibTorch or numpy.
//
// A .npz (np.savez, np.savez_compressed) is a zip archive whose entries
// "<name>.npy" hold one array each, stored or deflated. A .npy is the magic
// "\x93NUMPY", a version byte pair (1.0: 2-byte header length; 2.0 and
// 3.0: 4-byte length, 3.0 with a UTF-8 header), then a Python dict literal
// {'descr': '<f4', 'fortran_order': False, 'shape': (512, 768), } padded
// with spaces to a newline, then the raw data in C (row-major) order.
//
// Read: little-endian floats '<f4', and '<f2' / '<f8' converted to float32.
// Refused, with the file and the array named: fortran_order True, big
// endian ('>f4'), object and every other dtype, a header that is not such
// a dict, data shorter or longer than the shape needs, duplicate array
// names, entries that are not .npy, and archives that fail
// common::readZipEntries() (damage, CRC mismatch, zip bombs).

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace vln::data {

/// One array: its shape and its values in C order (row-major), float32.
struct NpyArray {
  std::vector<int64_t> shape;  ///< () for a scalar
  std::vector<float> values;   ///< product(shape) values
  bool operator==(const NpyArray&) const = default;
};

/// The arrays of a .npz, by name (the entry name without ".npy").
using NpzArrays = std::map<std::string, NpyArray>;

/// Bounds on what readNpz() accepts, checked before anything is inflated.
struct NpzLimits {
  int64_t max_arrays = 256;
  /// Uncompressed bytes of all entries together.
  int64_t max_total_bytes = int64_t{1} << 30;
};

/// Reads a .npz file. Throws std::runtime_error for a missing file or a
/// damaged archive and std::invalid_argument for a bad array, naming the
/// file and the array ("readNpz(): 'x.npz': array 'features': ...").
NpzArrays readNpz(const std::filesystem::path& file,
                  const NpzLimits& limits = {});

/// Reads one array of a .npz: every entry passes the zip checks, only
/// `name` is parsed (other entries may hold any dtype). Throws
/// std::invalid_argument naming the file when there is no such array.
NpyArray readNpzArray(const std::filesystem::path& file, std::string_view name,
                      const NpzLimits& limits = {});

/// Parses the bytes of a .npz; `source` names it in errors.
NpzArrays parseNpz(std::string_view bytes, std::string_view source,
                   const NpzLimits& limits = {});

/// Parses the bytes of one .npy; `context` prefixes errors.
NpyArray parseNpy(std::string_view bytes, std::string_view context);

/// One .npy file (version 1.0, '<f4', C order) holding `array`.
std::string npyBytes(const NpyArray& array);

/// A stored (uncompressed) zip archive of (entry name, bytes) in order, as
/// np.savez lays it out; for tools and tests writing raw .npy entries.
std::string storedZipBytes(
    const std::vector<std::pair<std::string, std::string>>& entries);

/// Atomically writes `arrays` as an uncompressed .npz (as np.savez does).
/// Throws std::invalid_argument when an array's values do not match its
/// shape or a name is empty.
void writeNpz(const std::filesystem::path& file, const NpzArrays& arrays);

}  // namespace vln::data

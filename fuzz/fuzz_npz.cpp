// Fuzzes the .npz / .npy reader (data::parseNpz: zip entries through
// common::readZipEntries, then each .npy header and its data). An accepted
// archive must hold, for every array, exactly product(shape) values.
#include <cstdlib>

#include "FuzzUtil.h"
#include "data/Npz.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  vln::fuzz::expectDocumentedErrors([&] {
    // small limits: a recorded size beyond them is refused, not inflated
    const auto arrays = vln::data::parseNpz(
        bytes, "fuzz.npz", {.max_arrays = 64, .max_total_bytes = 1 << 24});
    for (const auto& [name, array] : arrays) {
      uint64_t count = 1;
      for (int64_t dim : array.shape) count *= static_cast<uint64_t>(dim);
      if (count != array.values.size()) std::abort();
    }
  });
  return 0;
}

// Fuzzes the zip integrity check (common::verifyZipIntegrity) that every
// LibTorch archive passes before LibTorch parses it. An archive it accepts
// must describe its entries consistently: at least as many bytes as its
// entries' data, stored, occupy.
#include "FuzzUtil.h"
#include "common/ZipIntegrity.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  vln::fuzz::expectDocumentedErrors([&] {
    const auto summary = vln::common::verifyZipIntegrity(bytes, "fuzz.zip");
    if (summary.entries < 0 || summary.uncompressed_bytes < 0) std::abort();
  });
  return 0;
}

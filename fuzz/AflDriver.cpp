// main() of the AFL++ builds (VLN_FUZZ_ENGINE=afl): reads one input from the
// file named by the first argument (afl-fuzz's @@) or from stdin, and hands
// it to the same libFuzzer-style harness (LLVMFuzzerInitialize, then
// LLVMFuzzerTestOneInput) the clang builds link with -fsanitize=fuzzer.
// afl-fuzz forks this process once per input; the fork server that
// afl-g++'s instrumentation starts before main() keeps LibTorch's start-up
// out of every execution, and _exit() keeps its static destructors (~150 ms
// under ASan) out too. Leaks are checked explicitly first, since exit's own
// LeakSanitizer pass no longer runs.
#include <sanitizer/lsan_interface.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);
extern "C" __attribute__((weak)) int LLVMFuzzerInitialize(int* argc,
                                                          char*** argv);

int main(int argc, char** argv) {
  if (LLVMFuzzerInitialize) LLVMFuzzerInitialize(&argc, &argv);
  std::FILE* in = argc > 1 ? std::fopen(argv[1], "rb") : stdin;
  if (in == nullptr) {
    std::perror(argv[1]);
    return 2;
  }
  std::vector<uint8_t> input;
  uint8_t chunk[65536];
  for (size_t n; (n = std::fread(chunk, 1, sizeof(chunk), in)) > 0;)
    input.insert(input.end(), chunk, chunk + n);
  if (in != stdin) std::fclose(in);
  LLVMFuzzerTestOneInput(input.data(), input.size());
  std::vector<uint8_t>().swap(input);
  if (__lsan_do_recoverable_leak_check() != 0) std::abort();
  std::fflush(nullptr);
  ::_exit(0);
}

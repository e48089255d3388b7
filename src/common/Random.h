#pragma once
// Hashes, seed derivation and portable random draws, the one copy every
// module uses.
//
// std::mt19937_64's sequence is fixed by the C++ standard, std::
// distributions are not, so everything that must come out the same on every
// platform (the world, collection coins, sampled actions) draws through
// these helpers. Changing any function here changes the default world and
// every stored result: they are frozen.

#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "common/Check.h"

namespace vln::common {

/// SplitMix64's increment (the golden ratio in 64-bit fixed point).
inline constexpr uint64_t kSplitMixGamma = 0x9E3779B97F4A7C15ull;

/// SplitMix64's output function (Steele, Lea, Flood 2014).
inline uint64_t splitMixFinalize(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

/// SplitMix64 finaliser of `x` plus the increment: a well-mixed 64-bit hash.
inline uint64_t mixBits(uint64_t x) {
  return splitMixFinalize(x + kSplitMixGamma);
}

/// A seed derived from `seed` and a stream label `stream` (e.g. a house
/// index or a purpose constant), so independent stages never share draws.
inline uint64_t deriveSeed(uint64_t seed, uint64_t stream) {
  return mixBits(mixBits(seed) ^ (stream * 0xD1B54A32D192ED03ull));
}

/// 64-bit FNV-1a of the bytes of `text`.
inline uint64_t fnv1a(std::string_view text) {
  uint64_t hash = 0xcbf29ce484222325ull;
  for (const unsigned char c : text) {
    hash ^= c;
    hash *= 0x100000001b3ull;
  }
  return hash;
}

/// fnv1a() of `text` as 16 lower-case hex digits (config hashes).
inline std::string fnv1aHex(std::string_view text) {
  char hex[17];
  std::snprintf(hex, sizeof(hex), "%016llx",
                static_cast<unsigned long long>(fnv1a(text)));
  return hex;
}

/// The seed of one episode's own generator from a run seed and the
/// episode's id, so that an episode draws the same numbers whichever
/// environment, batch or thread runs it. Nearby seeds and ids give
/// unrelated streams.
inline uint64_t episodeSeed(uint64_t seed, std::string_view episodeId) {
  return splitMixFinalize(fnv1a(episodeId) ^ (seed + kSplitMixGamma));
}

/// The SplitMix64 generator: tiny state, seedable, portable.
struct SplitMix64 {
  uint64_t state = 0;
  uint64_t next() { return splitMixFinalize(state += kSplitMixGamma); }
  /// Uniform double in [0, 1) from the top 53 bits of next().
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
};

/// Uniform double in [0, 1) from the top 53 bits of one draw.
inline double uniform01(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

/// Uniform float in [lo, hi).
inline float uniformRange(std::mt19937_64& rng, float lo, float hi) {
  return lo + static_cast<float>(uniform01(rng)) * (hi - lo);
}

/// Uniform integer in [0, n); n must be positive.
inline int uniformIndex(std::mt19937_64& rng, int n) {
  VLN_ASSERT(n > 0);
  return static_cast<int>(uniform01(rng) * n);
}

/// True with probability p.
inline bool bernoulli(std::mt19937_64& rng, double p) {
  return uniform01(rng) < p;
}

/// Fisher-Yates shuffle driven by uniformIndex().
template <class T>
void deterministicShuffle(std::vector<T>& values, std::mt19937_64& rng) {
  for (int i = static_cast<int>(values.size()) - 1; i > 0; --i)
    std::swap(values[static_cast<size_t>(i)],
              values[static_cast<size_t>(uniformIndex(rng, i + 1))]);
}

}  // namespace vln::common

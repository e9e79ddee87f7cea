/**
 * @file random.h
 * @brief One root seed for the whole stack.
 *
 * Every random stream (simulator, R-Max exploration, simulated user, OMPL) is derived from a
 * single root seed, so that a run is reproduced from the seed it logs. Streams are derived by
 * name and index with a SplitMix64 hash, which keeps them independent of the order in which
 * they are created and of how trials are distributed over workers.
 */
#pragma once

#include <cstdint>
#include <random>
#include <string>

namespace krr {

/// @brief SplitMix64 finaliser: a cheap, well-mixed 64-bit hash.
inline std::uint64_t splitMix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// @brief Derive the seed of a named sub-stream (e.g. "trial", 17) from a root seed.
inline std::uint64_t deriveSeed(std::uint64_t root, const std::string& stream,
                                std::uint64_t index = 0) {
  std::uint64_t h = splitMix64(root);
  for (unsigned char c : stream) h = splitMix64(h ^ c);
  return splitMix64(h ^ splitMix64(index));
}

/// @brief The generator type used everywhere in the core.
using Rng = std::mt19937_64;

/// @brief A generator for sub-stream (stream, index) of the root seed.
inline Rng makeRng(std::uint64_t root, const std::string& stream, std::uint64_t index = 0) {
  return Rng(deriveSeed(root, stream, index));
}

/// @brief Uniform double in [0, 1) from any 64-bit generator (53 random bits).
template <class G>
inline double uniform01(G& g) {
  return static_cast<double>(g() >> 11) * (1.0 / 9007199254740992.0);
}

}  // namespace krr

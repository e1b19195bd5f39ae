#pragma once
// The seeded random generator used everywhere (docs/conventions.md): xoshiro256** seeded through
// splitmix64, with our own uniform/normal transforms so that results are bit-identical across
// standard libraries for a given seed. Not thread-safe: give each thread or task its own stream
// with Rng::stream(k), which is deterministic in (seed, k).
#include <cstdint>

#include "autoscan/core/types.hpp"

namespace autoscan {

class Rng {
 public:
  explicit Rng(std::uint64_t seed = 42);
  /// An independent generator derived deterministically from this one's seed and `k`.
  Rng stream(std::uint64_t k) const;
  std::uint64_t next();
  /// Uniform in [0, 1).
  double uniform();
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  /// Uniform integer in [0, n). n > 0.
  std::uint64_t uniform_int(std::uint64_t n);
  /// Standard normal (Box-Muller).
  double normal();
  double normal(double mean, double stddev) { return mean + stddev * normal(); }
  /// Uniform direction on the unit sphere.
  Vec3 unit_vector();
  std::uint64_t seed() const { return seed_; }

 private:
  std::uint64_t seed_;
  std::uint64_t s_[4];
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace autoscan

// Deterministic random numbers for the simulator. std::normal_distribution and friends are
// implementation-defined (their output differs between standard libraries), so the simulator
// uses its own generator and transforms: the same seed gives the same dataset everywhere.
//
// Draw order. C++ leaves unspecified the order in which the arguments of one call (and the
// operands of most binary operators) are evaluated: `Vector3d(rng.Uniform(), rng.Uniform(),
// rng.Uniform())` fills x, y and z from different draws under GCC (last argument first) and
// clang (first argument first), and one seed made two different worlds. Each draw of the
// simulator is therefore its own statement or init-declarator (those are sequenced). Where a
// world or motion was first written with several draws in one call, the statements keep the
// order GCC used (z before y before x), so the datasets made so far, and the figures measured
// on them, stay the same (checked byte for byte on every world).
#pragma once

#include <cmath>
#include <cstdint>

namespace vilma {
namespace sim {

// SplitMix64 step: a good 64-bit mixer, used to derive independent seeds (stream ids).
inline uint64_t SplitMix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

// Seed of a named sub-stream (e.g. seed of the texture of quad 17 of the world of seed N).
inline uint64_t DeriveSeed(uint64_t seed, uint64_t stream) {
  return SplitMix64(SplitMix64(seed) ^ SplitMix64(stream * 0x2545F4914F6CDD1DULL + 1));
}

// xoshiro256** (Blackman & Vigna 2018): fast, 256-bit state, passes BigCrush.
class Rng {
 public:
  explicit Rng(uint64_t seed = 1) {
    uint64_t x = seed;
    for (uint64_t& s : s_) {
      x = SplitMix64(x);
      s = x;
    }
  }

  uint64_t Next() {
    const uint64_t result = Rotl(s_[1] * 5, 7) * 9;
    const uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = Rotl(s_[3], 45);
    return result;
  }

  // Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(Next() >> 11) * (1.0 / 9007199254740992.0); }
  double Uniform(double a, double b) { return a + (b - a) * Uniform(); }
  // Uniform integer in [0, n).
  int UniformInt(int n) { return static_cast<int>(Uniform() * n); }

  // Standard normal by the Box-Muller transform (both values used).
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u1 = Uniform();
    while (u1 <= 1e-300) u1 = Uniform();
    const double u2 = Uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    const double phi = 2.0 * M_PI * u2;
    spare_ = r * std::sin(phi);
    has_spare_ = true;
    return r * std::cos(phi);
  }
  double Normal(double mean, double sigma) { return mean + sigma * Normal(); }

 private:
  static uint64_t Rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  uint64_t s_[4];
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace sim
}  // namespace vilma

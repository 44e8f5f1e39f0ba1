#pragma once
// Deterministic random numbers. The standard library's distributions differ between
// implementations, so these are written out: the same seed gives the same numbers everywhere.

#include <cmath>
#include <cstdint>

namespace terrain {

// SplitMix64 finaliser: a well-mixed 64-bit hash of x.
inline std::uint64_t mixBits(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Hash of several 64-bit keys, for counter-based noise that does not depend on evaluation order.
inline std::uint64_t hashKeys(std::uint64_t a, std::uint64_t b, std::uint64_t c = 0, std::uint64_t d = 0) {
  return mixBits(mixBits(mixBits(mixBits(a) ^ b) ^ c) ^ d);
}

// Uniform double in [0, 1) from the top 53 bits of a 64-bit value.
inline double unitFromBits(std::uint64_t bits) { return static_cast<double>(bits >> 11) * (1.0 / 9007199254740992.0); }

// Sequential generator (SplitMix64 stream) with uniform and normal draws.
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}

  std::uint64_t nextBits() {
    state_ += 0x9E3779B97F4A7C15ull;
    return mixBits(state_ - 0x9E3779B97F4A7C15ull);
  }
  // uniform in [lo, hi)
  double uniform(double lo = 0.0, double hi = 1.0) { return lo + (hi - lo) * unitFromBits(nextBits()); }
  // uniform integer in [lo, hi]
  int uniformInt(int lo, int hi) { return lo + static_cast<int>(nextBits() % static_cast<std::uint64_t>(hi - lo + 1)); }
  // standard normal (Box-Muller)
  double normal() { return normalFromBits(nextBits(), nextBits()); }

  // standard normal from two independent 64-bit values
  static double normalFromBits(std::uint64_t a, std::uint64_t b) {
    const double u1 = 1.0 - unitFromBits(a);  // in (0, 1]
    const double u2 = unitFromBits(b);
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }

 private:
  std::uint64_t state_;
};

}  // namespace terrain

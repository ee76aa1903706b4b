// Internal: the simulator's random numbers. A fixed generator (std::mt19937_64, whose output
// sequence the C++ standard specifies) and our own transforms to uniform and normal values, so
// a seed gives the same numbers with any standard library (std::normal_distribution is not
// specified exactly).
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

namespace scancam::sim::detail {

class Random {
 public:
  explicit Random(std::uint64_t seed) : gen_(seed) {}
  /// Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(gen_() >> 11) * (1.0 / 9007199254740992.0); }
  /// Standard normal (Box-Muller; one value per call, the second is discarded so that the
  /// number of generator draws per call is fixed).
  double Normal() {
    const double u1 = 1.0 - Uniform();  // (0, 1]
    const double u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }
  /// Integer in [0, n).
  int Index(int n) { return static_cast<int>(Uniform() * n); }

 private:
  std::mt19937_64 gen_;
};

/// A seed for a named sub-stream (scan noise, image noise, picks ...), so that changing one
/// part of the simulation does not shift the random numbers of another.
inline std::uint64_t SubSeed(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ull * (stream + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

}  // namespace scancam::sim::detail

#pragma once
// Seeded random numbers with a fully specified sequence. std::mt19937_64 is defined bit-for-bit by
// the C++ standard; the distributions of <random> are not (std::normal_distribution differs between
// standard libraries), so uniform and normal deviates are made here with fixed transforms: the top
// 53 bits for uniforms and the Marsaglia polar method for normals. The same seed then gives the same
// bytes on any conforming library whose std::log/std::sqrt are correctly rounded (glibc's are).
#include <cmath>
#include <cstdint>
#include <random>

namespace pof::sim {

/// splitmix64 (Steele, Lea, Flood 2014): derives independent engine seeds from one user seed, so
/// each noise source has its own stream and switching one effect on does not change the others.
inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

class Rng {
 public:
  /// `stream` names the noise source (a small constant per effect).
  Rng(std::uint64_t seed, std::uint64_t stream) : eng_(splitmix64(seed ^ splitmix64(stream))) {}

  /// Uniform on [0, 1).
  double uniform() { return static_cast<double>(eng_() >> 11) * 0x1.0p-53; }

  /// Standard normal (Marsaglia polar method; the second deviate of each pair is kept).
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u = 0, v = 0, s = 0;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * f;
    has_spare_ = true;
    return u * f;
  }

 private:
  std::mt19937_64 eng_;
  bool has_spare_ = false;
  double spare_ = 0;
};

}  // namespace pof::sim

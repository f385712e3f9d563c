// Seeded randomness for scene generators, identical on every platform:
// std::mt19937_64 is fully specified by the standard, the distributions
// built on it here are too (std::uniform_real_distribution is not).
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

#include "soda/scene/scene.h"

namespace soda::detail {

class SceneRandom {
 public:
  explicit SceneRandom(std::uint64_t seed) : engine_(seed) {}

  /// Uniform in [0, 1), 53 random bits.
  double unit() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * unit(); }

  /// Uniformly random rotation (Shoemake's method).
  Quat rotation() {
    constexpr double kTwoPi = 6.283185307179586476925;
    const double u1 = unit(), u2 = unit(), u3 = unit();
    const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
    return Quat(b * std::cos(kTwoPi * u3),  // w
                a * std::sin(kTwoPi * u2),  // x
                a * std::cos(kTwoPi * u2),  // y
                b * std::sin(kTwoPi * u3));  // z
  }

 private:
  std::mt19937_64 engine_;
};

}  // namespace soda::detail

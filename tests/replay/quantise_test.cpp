// The quantisation of positions and orientations: the error bounds the
// format states (docs/replay-format.md) hold.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "soda/replay/quantise.h"

namespace soda::replay {
namespace {

TEST(Quantise, PositionsDecodeWithinTheStatedBound) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<float> coord(-300.f, 700.f);
  std::vector<float> p(3 * 2000);
  for (float& x : p) x = coord(rng);
  const PositionBox box = position_box(p);
  ASSERT_TRUE(box_holds(box, p));
  const double bound = position_error_bound(box);
  EXPECT_LT(bound, 0.02);  // 1 km box: 1000 * 1.25 / 131070 + float ulp
  double worst = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::size_t a = i % 3;
    const float back = dequantise_position(quantise_position(p[i], box.lo[a], box.hi[a]), box.lo[a], box.hi[a]);
    worst = std::max(worst, std::fabs(static_cast<double>(back) - p[i]));
  }
  EXPECT_LE(worst, bound);
  EXPECT_GT(worst, bound * 0.5);  // the bound is not loose by orders of magnitude
}

TEST(Quantise, BoxCornersAreCodesZeroAndMax) {
  const PositionBox box = position_box(std::vector<float>{1, 2, 3});
  for (int a = 0; a < 3; ++a) {
    EXPECT_LT(box.lo[a], box.hi[a]);
    EXPECT_EQ(quantise_position(box.lo[a], box.lo[a], box.hi[a]), 0);
    EXPECT_EQ(quantise_position(box.hi[a], box.lo[a], box.hi[a]), kPositionMaxCode);
    EXPECT_EQ(dequantise_position(0, box.lo[a], box.hi[a]), box.lo[a]);
    EXPECT_EQ(dequantise_position(kPositionMaxCode, box.lo[a], box.hi[a]), box.hi[a]);
  }
  EXPECT_FALSE(box_holds(box, std::vector<float>{1, 2, 300}));
  EXPECT_FALSE(box_holds(box, std::vector<float>{1, 2, NAN}));
}

double angle_between(const float a[4], const float b[4]) {
  double dot = 0;
  for (int i = 0; i < 4; ++i) dot += static_cast<double>(a[i]) * b[i];
  return 2 * std::acos(std::min(1.0, std::fabs(dot)));
}

TEST(Quantise, OrientationsDecodeWithinTheStatedBound) {
  std::mt19937_64 rng(2);
  std::normal_distribution<double> g;
  double worst = 0;
  for (int k = 0; k < 200000; ++k) {
    float q[4], back[4];
    double norm = 0, c[4];
    for (double& x : c) {
      x = g(rng);
      norm += x * x;
    }
    for (int i = 0; i < 4; ++i) q[i] = static_cast<float>(c[i] / std::sqrt(norm));
    unpack_orientation(pack_orientation(q), back);
    double n2 = 0;
    for (float x : back) n2 += static_cast<double>(x) * x;
    ASSERT_NEAR(n2, 1.0, 1e-6);
    worst = std::max(worst, angle_between(q, back));
  }
  EXPECT_LE(worst, kOrientationErrorBound);
  EXPECT_GT(worst, kOrientationErrorBound * 0.2);
}

TEST(Quantise, OrientationSignAndAxesSurvive) {
  const float identity[4] = {0, 0, 0, 1}, negated[4] = {0, 0, 0, -1}, about_x[4] = {1, 0, 0, 0};
  float back[4];
  unpack_orientation(pack_orientation(identity), back);
  EXPECT_NEAR(back[3], 1.f, 1e-6f);
  EXPECT_EQ(pack_orientation(identity), pack_orientation(negated));  // one rotation
  unpack_orientation(pack_orientation(about_x), back);
  EXPECT_NEAR(back[0], 1.f, 1e-6f);
  EXPECT_LE(std::fabs(back[1]) + std::fabs(back[2]) + std::fabs(back[3]), 3e-3f);
}

}  // namespace
}  // namespace soda::replay

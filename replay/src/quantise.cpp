#include "soda/replay/quantise.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace soda::replay {
namespace {

constexpr double kSmallRange = 0.70710678118654752440;  // 1/sqrt(2): |a small component| <= it

// Rounds d to a float no greater (down) or no smaller (up) than d.
float float_down(double d) {
  float f = static_cast<float>(d);
  if (static_cast<double>(f) > d) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}
float float_up(double d) {
  float f = static_cast<float>(d);
  if (static_cast<double>(f) < d) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

}  // namespace

PositionBox position_box(std::span<const float> positions) {
  PositionBox box;
  if (positions.size() < 3) return box;
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) lo[a] = hi[a] = positions[static_cast<std::size_t>(a)];
  for (std::size_t i = 0; i + 2 < positions.size(); i += 3)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], static_cast<double>(positions[i + static_cast<std::size_t>(a)]));
      hi[a] = std::max(hi[a], static_cast<double>(positions[i + static_cast<std::size_t>(a)]));
    }
  for (int a = 0; a < 3; ++a) {
    const double margin = (hi[a] - lo[a]) * kBoxMarginFraction + kBoxMarginMetres;
    box.lo[a] = float_down(lo[a] - margin);
    box.hi[a] = float_up(hi[a] + margin);
  }
  return box;
}

bool box_holds(const PositionBox& box, std::span<const float> positions) {
  for (std::size_t i = 0; i + 2 < positions.size(); i += 3)
    for (std::size_t a = 0; a < 3; ++a) {
      const float x = positions[i + a];
      if (!(x >= box.lo[a] && x <= box.hi[a])) return false;  // NaN: false
    }
  return true;
}

std::uint16_t quantise_position(float x, float lo, float hi) {
  const double t = (static_cast<double>(x) - lo) / (static_cast<double>(hi) - lo) * kPositionMaxCode;
  const double code = std::clamp(std::nearbyint(t), 0.0, static_cast<double>(kPositionMaxCode));
  return static_cast<std::uint16_t>(code);
}

float dequantise_position(std::uint16_t code, float lo, float hi) {
  const double step = (static_cast<double>(hi) - lo) / kPositionMaxCode;
  return static_cast<float>(static_cast<double>(lo) + code * step);
}

double position_error_bound(const PositionBox& box) {
  double widest = 0, largest = 0;
  for (int a = 0; a < 3; ++a) {
    widest = std::max(widest, static_cast<double>(box.hi[a]) - box.lo[a]);
    largest = std::max({largest, std::fabs(static_cast<double>(box.lo[a])), std::fabs(static_cast<double>(box.hi[a]))});
  }
  // Half a code step, the double arithmetic's rounding (far below), half a
  // float ulp of the result.
  return widest / (2.0 * kPositionMaxCode) * (1 + 1e-12) + largest * std::ldexp(1.0, -24);
}

std::uint32_t pack_orientation(const float q[4]) {
  double c[4];
  double norm2 = 0;
  for (int i = 0; i < 4; ++i) {
    c[i] = q[i];
    norm2 += c[i] * c[i];
  }
  const double inv = 1.0 / std::sqrt(norm2);
  int largest = 0;
  for (int i = 0; i < 4; ++i) {
    c[i] *= inv;
    if (std::fabs(c[i]) > std::fabs(c[largest])) largest = i;
  }
  const double sign = c[largest] < 0 ? -1.0 : 1.0;
  std::uint32_t code = static_cast<std::uint32_t>(largest) << 30;
  int shift = 20;
  for (int i = 0; i < 4; ++i) {
    if (i == largest) continue;
    const double t = (c[i] * sign + kSmallRange) / (2 * kSmallRange) * kOrientationMaxCode;
    const double v = std::clamp(std::nearbyint(t), 0.0, static_cast<double>(kOrientationMaxCode));
    code |= static_cast<std::uint32_t>(v) << shift;
    shift -= 10;
  }
  return code;
}

void unpack_orientation(std::uint32_t code, float q[4]) {
  const int largest = static_cast<int>(code >> 30);
  double c[4];
  double sum2 = 0;
  int shift = 20;
  for (int i = 0; i < 4; ++i) {
    if (i == largest) continue;
    const double v = static_cast<double>((code >> shift) & kOrientationMaxCode);
    c[i] = v / kOrientationMaxCode * (2 * kSmallRange) - kSmallRange;
    sum2 += c[i] * c[i];
    shift -= 10;
  }
  c[largest] = std::sqrt(std::max(0.0, 1.0 - sum2));
  double norm2 = sum2 + c[largest] * c[largest];
  const double inv = 1.0 / std::sqrt(norm2);
  for (int i = 0; i < 4; ++i) q[i] = static_cast<float>(c[i] * inv);
}

}  // namespace soda::replay

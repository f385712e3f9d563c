// replay/ — replay files (docs/replay-format.md). This header: how poses are
// quantised, exactly as the file stores them. Public so that tests and tools
// can compute what a file holds; the writer and reader use these functions
// and nothing else. Pure functions; thread-safe.
//
// Positions: 16 bits per axis in a box (PositionBox) chosen per keyframe:
// the frame's bodies' AABB grown by a margin; a later frame with a body
// outside it starts a new keyframe with a new box, so nothing is clamped.
// Error per axis <= position_error_bound(box).
//
// Orientations: 32-bit "smallest three": 2 bits name the largest |component|
// (made positive: q and -q are one rotation), 3 x 10 bits the other three in
// [-1/sqrt(2), 1/sqrt(2)]; the largest is sqrt(1 - the others' squares).
// Rotation error <= kOrientationErrorBound radians.
#pragma once

#include <cstdint>
#include <span>

namespace soda::replay {

/// Largest code of a quantised position axis (16 bits).
inline constexpr std::uint32_t kPositionMaxCode = 0xFFFF;
/// Largest code of one of an orientation's three small components (10 bits).
inline constexpr std::uint32_t kOrientationMaxCode = 0x3FF;
/// The box of a keyframe: its bodies' AABB grown on each side by this
/// fraction of its extent plus kBoxMarginMetres, so that bodies moving about
/// stay inside for a while (a body leaving it forces a keyframe; a wider
/// margin costs precision).
inline constexpr double kBoxMarginFraction = 0.125;
inline constexpr double kBoxMarginMetres = 0.5;
/// Bound on the rotation angle between a unit quaternion and its decoded
/// smallest-three form, radians (0.29 degrees). First order: each small
/// component is within d = sqrt(2)/(2 * 1023) = 6.9e-4, the largest (>= 1/2)
/// within 3d, so |q - q'| <= sqrt(12) d and the angle <= 2 |q - q'| = 4.8e-3.
inline constexpr double kOrientationErrorBound = 0.005;

/// Corners of the box positions are quantised in, metres (float, as stored).
struct PositionBox {
  float lo[3] = {0, 0, 0};
  float hi[3] = {1, 1, 1};
  friend bool operator==(const PositionBox&, const PositionBox&) = default;
};

/// The box for a keyframe holding `positions` (x, y, z per body): their AABB
/// grown by the margins above, corners rounded outwards to float, every
/// extent > 0. Positions must be finite (the writer checks first). An empty
/// span gives the unit box.
PositionBox position_box(std::span<const float> positions);

/// True when every position (x, y, z per body) lies inside `box`.
bool box_holds(const PositionBox& box, std::span<const float> positions);

/// Code of coordinate x on an axis [lo, hi] (x inside it): the nearest of
/// 65536 evenly spaced values, lo + code * (hi - lo) / 65535.
std::uint16_t quantise_position(float x, float lo, float hi);
/// The coordinate a code stands for, computed in double, rounded to float.
float dequantise_position(std::uint16_t code, float lo, float hi);
/// Bound on |dequantise(quantise(x)) - x| for x in the box, any axis, m:
/// half a code step of the widest axis plus half a float ulp at the box's
/// largest |corner|.
double position_error_bound(const PositionBox& box);

/// Smallest-three code of the quaternion (x, y, z, w); it need not be
/// exactly unit (it is normalised first) but must be finite and non-zero.
std::uint32_t pack_orientation(const float q[4]);
/// The unit quaternion (x, y, z, w) a code stands for.
void unpack_orientation(std::uint32_t code, float q[4]);

}  // namespace soda::replay

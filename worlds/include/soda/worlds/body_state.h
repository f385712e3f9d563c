// worlds/ — one territory's physics. This header: the value type that
// describes one body's dynamic state, in the precision Bullet was built with.
#pragma once

#include <cstdint>
#include <vector>

#include <LinearMath/btScalar.h>

#include "soda/scene/hash_text.h"  // hash_hex, the one text form of state_hash
#include "soda/scene/scene.h"

namespace soda {

/// True when this translation unit is built against Bullet's float64 libraries.
inline constexpr bool kDoublePrecision = sizeof(btScalar) == sizeof(double);
inline constexpr const char* kPrecisionName = kDoublePrecision ? "double" : "float";

/// Raw dynamic state of one body as Bullet holds it: the basis matrix (row
/// major, as btMatrix3x3 stores it), origin, velocities and activation state.
/// These raw bits are what the state hash covers.
struct BodyState {
  BodyId id = 0;
  btScalar basis[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  btScalar origin[3] = {0, 0, 0};
  btScalar linear_velocity[3] = {0, 0, 0};
  btScalar angular_velocity[3] = {0, 0, 0};
  int activation_state = 1;  // Bullet's ACTIVE_TAG, ISLAND_SLEEPING, ...
};

/// Canonical 64-bit hash (FNV-1a over raw bytes) of body states sorted by id:
/// id, basis, origin, linear and angular velocity, activation state. Input
/// order does not matter (it is sorted first); every bit of every field does.
std::uint64_t state_hash(std::vector<BodyState> states);

}  // namespace soda

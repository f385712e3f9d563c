// Internal: whether two Bullet values are the same bits (not merely equal:
// -0 and +0 differ, a NaN equals itself), for code that must tell a change
// of any bit from none.
#pragma once

#include <cstring>

#include <LinearMath/btTransform.h>
#include <LinearMath/btVector3.h>

namespace soda {

inline bool same_bits(const btVector3& a, const btVector3& b) {
  return std::memcmp(&a[0], &b[0], 3 * sizeof(btScalar)) == 0;
}

inline bool same_bits(const btTransform& a, const btTransform& b) {
  for (int r = 0; r < 3; ++r)
    if (!same_bits(a.getBasis()[r], b.getBasis()[r])) return false;
  return same_bits(a.getOrigin(), b.getOrigin());
}

}  // namespace soda

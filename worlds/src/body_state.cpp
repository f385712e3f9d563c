#include "soda/worlds/body_state.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>

#include "soda/scene/fnv1a.h"

namespace soda {
std::uint64_t state_hash(std::vector<BodyState> states) {
  std::sort(states.begin(), states.end(),
            [](const BodyState& a, const BodyState& b) { return a.id < b.id; });
  std::uint64_t h = kFnv1aOffset;
  for (const BodyState& s : states) {
    fnv1a_mix(h, &s.id, sizeof s.id);
    fnv1a_mix(h, s.basis, sizeof s.basis);
    fnv1a_mix(h, s.origin, sizeof s.origin);
    fnv1a_mix(h, s.linear_velocity, sizeof s.linear_velocity);
    fnv1a_mix(h, s.angular_velocity, sizeof s.angular_velocity);
    const std::int32_t act = s.activation_state;
    fnv1a_mix(h, &act, sizeof act);
  }
  return h;
}

}  // namespace soda

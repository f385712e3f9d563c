#include "soda/worlds/body_state.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>

namespace soda {
namespace {

constexpr std::uint64_t kFnvOffset = 1469598103934665603ull;
constexpr std::uint64_t kFnvPrime = 1099511628211ull;

void mix(std::uint64_t& h, const void* data, std::size_t size) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < size; ++i) {
    h ^= p[i];
    h *= kFnvPrime;
  }
}

}  // namespace

std::uint64_t state_hash(std::vector<BodyState> states) {
  std::sort(states.begin(), states.end(),
            [](const BodyState& a, const BodyState& b) { return a.id < b.id; });
  std::uint64_t h = kFnvOffset;
  for (const BodyState& s : states) {
    mix(h, &s.id, sizeof s.id);
    mix(h, s.basis, sizeof s.basis);
    mix(h, s.origin, sizeof s.origin);
    mix(h, s.linear_velocity, sizeof s.linear_velocity);
    mix(h, s.angular_velocity, sizeof s.angular_velocity);
    const std::int32_t act = s.activation_state;
    mix(h, &act, sizeof act);
  }
  return h;
}

}  // namespace soda

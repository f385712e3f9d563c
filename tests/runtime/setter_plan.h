// Shared by the setter suites: a plan of property inputs on a small scene —
// gravity (scene-wide, sideways so that bodies cross territory borders),
// mass, friction, restitution and user data of a quarter of the bodies
// each — and the value each input kind needs.
#pragma once

#include <cstdint>
#include <vector>

#include "soda/scene/input_file.h"
#include "soda/scene/scene.h"

namespace soda::test {

inline UserInput property_input(UserInput::Kind kind, std::int64_t step, BodyId id, double value,
                                std::uint64_t user_data = 0) {
  UserInput in;
  in.kind = kind;
  in.step = step;
  in.id = id;
  in.value = value;
  in.user_data = user_data;
  return in;
}

inline UserInput gravity_input(std::int64_t step, const Vec3& g) {
  UserInput in;
  in.kind = UserInput::Kind::SetGravity;
  in.step = step;
  in.linear = g;
  return in;
}

/// The user data the plan gives body `id`.
inline std::uint64_t plan_tag(BodyId id) { return 0xfeed000000000000ull | id; }

/// Every kind of property input, in step order (calls of one step in list
/// order), on the dynamic bodies of `s`: by the end every fourth body is
/// heavier, every fourth slippery, every fourth bouncy, every body tagged,
/// and the gravity has pulled sideways for 40 steps.
inline std::vector<UserInput> setter_plan(const Scene& s) {
  using K = UserInput::Kind;
  std::vector<BodyId> dynamic;
  for (const Body& b : s.bodies)
    if (!b.is_static) dynamic.push_back(b.id);
  std::vector<UserInput> out;
  for (BodyId id : dynamic) out.push_back(property_input(K::SetUserData, 5, id, 0, plan_tag(id)));
  for (std::size_t i = 0; i < dynamic.size(); i += 4) out.push_back(property_input(K::SetMass, 12, dynamic[i], 6.0));
  for (std::size_t i = 1; i < dynamic.size(); i += 4)
    out.push_back(property_input(K::SetFriction, 18, dynamic[i], 0.0));
  for (std::size_t i = 2; i < dynamic.size(); i += 4)
    out.push_back(property_input(K::SetRestitution, 24, dynamic[i], 0.9));
  out.push_back(gravity_input(30, Vec3(2.5, -7.0, 0.5)));
  out.push_back(property_input(K::SetMass, 45, dynamic[1], 0.25));
  out.push_back(property_input(K::SetFriction, 50, dynamic[0], 1.2));
  out.push_back(gravity_input(70, Vec3(0, -9.81, 0)));
  out.push_back(property_input(K::SetRestitution, 75, dynamic[2], 0.0));
  return out;
}

}  // namespace soda::test

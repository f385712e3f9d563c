#include "step/spawned_groups.h"

#include <algorithm>

namespace soda {

// Each such group's home cell is its anchor's, so that one world takes the
// group whole (the InputLedger took these joints: spawned whole or not at
// all).
std::map<BodyId, Vec3> spawned_group_homes(const std::vector<UserInput>& inputs) {
  std::map<BodyId, const Body*> added;
  for (const UserInput& in : inputs)
    if (in.kind == UserInput::Kind::AddBody) added.emplace(in.body.id, &in.body);
  std::map<BodyId, BodyId> parent;
  auto find = [&](BodyId x) {
    while (parent.at(x) != x) x = parent.at(x);
    return x;
  };
  for (const UserInput& in : inputs) {
    const Joint& j = in.added_joint;
    if (in.kind != UserInput::Kind::AddJoint || !added.count(j.body_a) || !added.count(j.body_b)) continue;
    parent.emplace(j.body_a, j.body_a);
    parent.emplace(j.body_b, j.body_b);
    const BodyId a = find(j.body_a), b = find(j.body_b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::map<BodyId, Vec3> homes;
  for (const auto& [body, p] : parent) homes.emplace(body, added.at(find(body))->position);
  return homes;
}

}  // namespace soda

// IslandReplay (island_replay.h): which bodies are clean, which islands the
// old run solved alike, and writing (or checking) the old run's results.
#include "island_replay.h"

#include <cstring>

#include <algorithm>
#include <stdexcept>
#include <string>

#include "body_factory.h"
#include "soda/worlds/value_codec.h"

namespace soda {
void IslandReplay::set(const StepReplay& replay) {
  if (!replay.before || !replay.after || !replay.islands)
    throw std::invalid_argument("TerritoryWorld::set_replay: before, after and islands are required");
  replay_ = replay;
  const LocalIslands& old = *replay.islands;
  index_.clear();
  for (std::uint32_t i = 0; i < old.size(); ++i) index_.emplace_back(old.ids[old.begin[i]], i);
  std::sort(index_.begin(), index_.end());
}

// A pair whose contact state differs from the old run's, or that has
// contact state in one run only, makes both its bodies dirty.
void IslandReplay::mark_clean(const std::vector<btRigidBody*>& owned, const std::vector<const Body*>& descriptions,
                              const std::vector<ManifoldState>& contacts, const std::vector<JointSnapshot>& joints,
                              const Vec3& gravity) {
  const WorldSnapshot& before = *replay_.before;
  clean_.clear();
  const Vec3& old_gravity = before.settings.gravity;
  const bool same_gravity = std::memcmp(old_gravity.data(), gravity.data(), 3 * sizeof(double)) == 0;
  auto b = before.bodies.begin();
  for (std::size_t i = 0; i < owned.size(); ++i) {
    btRigidBody* body = owned[i];
    const BodyId id = id_of(body);
    while (b != before.bodies.end() && b->description.id < id) ++b;
    clean_.emplace_back(id, same_gravity && b != before.bodies.end() && b->description.id == id &&
                                same_material(*descriptions[i], b->description) &&
                                same_bits(read_dynamic_state(*body), b->state));
  }
  std::sort(clean_.begin(), clean_.end());
  auto dirty = [&](const ManifoldState& m) {
    for (BodyId id : {m.id0, m.id1}) {
      auto it = std::lower_bound(clean_.begin(), clean_.end(), std::make_pair(id, false));
      if (it != clean_.end() && it->first == id) it->second = false;
    }
  };
  mark_joints_dirty(joints);
  auto key = [](const ManifoldState& m) { return std::make_pair(m.id0, m.id1); };
  auto x = contacts.begin();
  auto y = before.manifolds.begin();
  while (x != contacts.end() || y != before.manifolds.end()) {
    if (y == before.manifolds.end() || (x != contacts.end() && key(*x) < key(*y))) {
      dirty(*x++);
    } else if (x == contacts.end() || key(*y) < key(*x)) {
      dirty(*y++);
    } else {
      if (!same_bits(*x, *y)) dirty(*x);
      ++x, ++y;
    }
  }
}

namespace {

// A joint's whole description and broken flag as joint_codec.cpp writes
// them: every field bit for bit, the motor's included.
bool same_joint(const JointSnapshot& a, const JointSnapshot& b) {
  ByteWriter x, y;
  write_joint(x, a);
  write_joint(y, b);
  return x.bytes == y.bytes;
}

}  // namespace

// A joint held in one run only (removed by an input at this boundary), or
// whose description or broken flag differs between the runs (a motor set
// by an input), makes both its bodies dirty: an island's joints are part of
// what its step is a function of.
void IslandReplay::mark_joints_dirty(const std::vector<JointSnapshot>& joints) {
  auto dirty = [&](const Joint& j) {
    for (BodyId id : {j.body_a, j.body_b}) {
      auto it = std::lower_bound(clean_.begin(), clean_.end(), std::make_pair(id, false));
      if (it != clean_.end() && it->first == id) it->second = false;
    }
  };
  const std::vector<JointSnapshot>& old = replay_.before->joints;
  auto x = joints.begin();
  auto y = old.begin();
  while (x != joints.end() || y != old.end()) {
    if (y == old.end() || (x != joints.end() && x->description.id < y->description.id)) {
      dirty((x++)->description);
    } else if (x == joints.end() || y->description.id < x->description.id) {
      dirty((y++)->description);
    } else {
      if (!same_joint(*x, *y)) dirty(x->description);
      ++x, ++y;
    }
  }
}

bool IslandReplay::clean(BodyId id) const {
  auto it = std::lower_bound(clean_.begin(), clean_.end(), std::make_pair(id, false));
  return it != clean_.end() && it->first == id && it->second;
}

bool IslandReplay::take(btCollisionObject* const* bodies, int body_count,
                        const IslandItems<btPersistentManifold*>& held, int island) {
  for (int j = 0; j < body_count; ++j)
    if (!clean(id_of(bodies[j]))) return false;
  const BodyId first = id_of(bodies[0]);
  auto it = std::lower_bound(index_.begin(), index_.end(), std::make_pair(first, std::uint32_t{0}));
  if (it == index_.end() || it->first != first) return false;
  const LocalIslands& old = *replay_.islands;
  const std::uint32_t begin = old.begin[it->second];
  if (old.begin[it->second + 1] - begin != static_cast<std::uint32_t>(body_count)) return false;
  for (int j = 0; j < body_count; ++j)
    if (old.ids[begin + static_cast<std::uint32_t>(j)] != id_of(bodies[j])) return false;

  const WorldSnapshot& after = *replay_.after;
  const std::size_t bodies_mark = bodies_.size(), manifolds_mark = manifolds_.size();
  for (int j = 0; j < body_count; ++j) {
    const BodyId id = id_of(bodies[j]);
    auto b = std::lower_bound(after.bodies.begin(), after.bodies.end(), id,
                              [](const BodySnapshot& s, BodyId x) { return s.description.id < x; });
    if (b == after.bodies.end() || b->description.id != id) {  // it left the world
      bodies_.resize(bodies_mark);
      manifolds_.resize(manifolds_mark);
      return false;
    }
    bodies_.emplace_back(bodies[j], &b->state);
  }
  for (int j = held.begin(island); j < held.begin(island + 1); ++j) {
    const auto& h = held[static_cast<std::size_t>(j)];
    auto m = std::lower_bound(after.manifolds.begin(), after.manifolds.end(), h.key,
                              [](const ManifoldState& s, const std::pair<BodyId, BodyId>& x) {
                                return std::make_pair(s.id0, s.id1) < x;
                              });
    const bool absent = m == after.manifolds.end() || m->id0 != h.key.first || m->id1 != h.key.second;
    manifolds_.emplace_back(h.value, absent ? nullptr : &*m);  // invariant 2
  }
  return true;
}

void IslandReplay::finish(WorldId world, std::int64_t step) {
  auto mismatch = [&](const std::string& what) {
    throw std::logic_error("world " + std::to_string(world) + ", step " + std::to_string(step) +
                           ": a replayed island's " + what + " differs from the old run's");
  };
  for (const auto& [object, state] : bodies_) {
    btRigidBody& rb = *btRigidBody::upcast(object);
    if (!replay_.verify) {
      write_dynamic_state(rb, *state);
    } else if (!same_bits(read_dynamic_state(rb), *state)) {
      mismatch("body " + std::to_string(id_of(object)));
    }
  }
  for (const auto& [manifold, state] : manifolds_) {
    if (!state) {
      if (!replay_.verify) {
        manifold->clearManifold();
      } else if (manifold->getNumContacts() != 0) {
        mismatch("manifold " + std::to_string(id_of(manifold->getBody0())) + "-" +
                 std::to_string(id_of(manifold->getBody1())) + " (empty in the old run)");
      }
    } else if (!replay_.verify) {
      write_manifold_points(*state, *manifold);
    } else if (!same_bits(read_manifold_state(*manifold), *state)) {
      mismatch("manifold " + std::to_string(state->id0) + "-" + std::to_string(state->id1));
    }
  }
  bodies_.clear();
  manifolds_.clear();
}

}  // namespace soda

// Shared helpers of the Simulation suites: the one-world reference as
// frames (body_pose of every dynamic body, by id) and hashes, per step, and
// bitwise comparison of frames.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <algorithm>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "runtime/partitioned_test_util.h"
#include "soda/runtime/simulation.h"

namespace soda::test {

struct Reference {
  std::vector<std::vector<ScenePose>> frames;  // [step]: dynamic bodies, ascending id
  std::vector<std::uint64_t> hashes;           // [step]: state_hash
};

/// One CanonicalWorld on the whole scene, steps 0 .. steps.
inline Reference reference_run(const Scene& s, int steps) {
  Reference r;
  CanonicalWorld w(s);
  std::vector<char> is_static;
  for (const Body& b : s.bodies) {
    if (b.id >= is_static.size()) is_static.resize(b.id + 1, 0);
    is_static[b.id] = b.is_static;
  }
  for (int t = 0; t <= steps; ++t) {
    if (t > 0) w.step();
    std::vector<ScenePose> f;
    for (const BodyState& b : w.body_states())
      if (!is_static[b.id]) f.push_back(body_pose(b));
    r.frames.push_back(std::move(f));
    r.hashes.push_back(w.state_hash());
  }
  return r;
}

inline bool same_bits(const ScenePose& a, const ScenePose& b) {
  return a.id == b.id && std::memcmp(a.position, b.position, sizeof a.position) == 0 &&
         std::memcmp(a.orientation, b.orientation, sizeof a.orientation) == 0 &&
         std::memcmp(a.linear_velocity, b.linear_velocity, sizeof a.linear_velocity) == 0 &&
         std::memcmp(a.angular_velocity, b.angular_velocity, sizeof a.angular_velocity) == 0;
}

/// "" if `frame` holds exactly `expected`, bit for bit; else the first
/// difference.
inline std::string frame_difference(const std::vector<ScenePose>& frame, const std::vector<ScenePose>& expected) {
  if (frame.size() != expected.size())
    return std::to_string(frame.size()) + " bodies, expected " + std::to_string(expected.size());
  for (std::size_t i = 0; i < frame.size(); ++i) {
    if (i > 0 && frame[i].id <= frame[i - 1].id) return "ids not strictly increasing at " + std::to_string(i);
    if (!same_bits(frame[i], expected[i])) return "body " + std::to_string(expected[i].id) + " differs";
  }
  return "";
}

/// A unit cube (1 kg) at `at`, falling at 2 m/s: the body the input tests add.
inline Body new_cube(BodyId id, const Vec3& at) {
  Body b;
  b.id = id;
  b.shape = Shape::box(Vec3(0.5, 0.5, 0.5));
  b.mass = 1.0;
  b.position = at;
  b.linear_velocity = Vec3(0, -2, 0);
  return b;
}

inline BodyId first_dynamic(const Scene& s) {
  for (const Body& b : s.bodies)
    if (!b.is_static) return b.id;
  return 0;
}

/// One more than the largest id in the scene.
inline BodyId unused_id(const Scene& s) {
  BodyId id = 0;
  for (const Body& b : s.bodies) id = std::max(id, b.id);
  return id + 1;
}

/// Late spawn: a point 2 m above the highest dynamic body, over the dynamic
/// body furthest along +x (the far end of a strip cut along x). nullopt if
/// the scene has no dynamic body.
inline std::optional<Vec3> far_spawn_point(const Scene& s) {
  const Body* far = nullptr;
  double top = 0;
  for (const Body& b : s.bodies) {
    if (b.is_static) continue;
    if (!far || b.position.x() > far->position.x()) far = &b;
    top = std::max(top, b.position.y());
  }
  if (!far) return std::nullopt;
  return Vec3(far->position.x(), top + 2.0, far->position.z());
}

}  // namespace soda::test

// Shared helpers of the Simulation suites: the one-world reference as
// frames (body_pose of every dynamic body, by id) and hashes, per step, and
// bitwise comparison of frames.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
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

/// Late spawn: polls (every `pause`, at most `attempts` times) until the
/// world whose newest step `newest()` gives is `min_lead` or more steps past
/// the commit horizon (and the horizon past step 10), then adds `body` at
/// the horizon's step. If the horizon moved past it meanwhile the error must
/// say so, and it tries again.
struct Spawned {
  std::int64_t step = -1;  // the step the body was added at; -1: never
  std::int64_t lead = 0;   // the world's lead over the horizon then
};
inline Spawned add_at_horizon(Simulation& sim, const Body& body, const std::function<std::int64_t()>& newest,
                                std::int64_t min_lead, int attempts, std::chrono::milliseconds pause) {
  Spawned out;
  for (int attempt = 0; attempt < attempts && out.step < 0; ++attempt) {
    std::this_thread::sleep_for(pause);
    const std::int64_t gvt = sim.commit_horizon_step();
    out.lead = newest() - gvt;
    if (out.lead < min_lead || gvt < 10) continue;
    try {
      sim.add_body(sim.time_of(gvt), body);
      out.step = gvt;
    } catch (const std::invalid_argument& e) {
      const bool too_old = std::string(e.what()).find("older than the commit horizon") != std::string::npos;
      EXPECT_TRUE(too_old) << e.what();
      if (!too_old) return out;  // any other error ends the test's attempt
    }
  }
  return out;
}

/// The end of a late-spawn test: an input at step 1 is refused as older
/// than the commit horizon; the run ends at `steps` with one body more, and
/// its hash is that of a one-territory run with `body` added at `step`
/// from the start (both printed after `what`).
inline void expect_late_spawn_exact(Simulation& sim, const Scene& s, const Body& body, std::int64_t step, int steps,
                                    const std::string& what) {
  try {
    sim.set_velocity(sim.time_of(1), first_dynamic(s), Vec3(1, 0, 0));
    ADD_FAILURE() << "an input at step 1 was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("older than the commit horizon"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(sim.advance_to(sim.time_of(steps)));
  const std::uint64_t late = sim.state_hash();
  Simulation one(s, SimulationConfig{.threads = 1});
  one.add_body(one.time_of(step), body);
  EXPECT_TRUE(one.advance_to(one.time_of(steps)));
  std::printf("%s: 8 territories %s, one %s\n", what.c_str(), hash_hex(late).c_str(), hash_hex(one.state_hash()).c_str());
  EXPECT_EQ(hash_hex(late), hash_hex(one.state_hash()));
  EXPECT_EQ(sim.body_count(), s.bodies.size() + 1);
}

}  // namespace soda::test

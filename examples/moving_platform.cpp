// Moving platforms on SODA (docs/scene-format.md, "Kinematic bodies"): a
// level made in code — a ground, a freight elevator and a ferry platform,
// both kinematic — runs on 4 territories that speculate (anticipation 8).
// The application's loop drives the elevator as a game drives a lift: every
// frame it asks for the next position on the way to the floor the player
// called (set_kinematic_target), waits at each floor, and rides again. The
// ferry shuttles across the territory borders on a path from the scene (no
// calls at all). Crates ride both: carried by friction, lifted, dropped at
// the ends. At 3 s the ferry opens its hold: the application sets its
// collision filter to touch nothing at the frame on screen, its crates drop
// through to the ground, and at 5 s, past them, it closes again
// (set_collision_filter on a kinematic body, kept by every world as a
// command of its step). A render thread reads every frame while the worlds run ahead:
// the platforms from the frame's kinematic list, the crates riding the
// lift from a query at that frame. The run ends on the hash of one world
// given the same calls.
// Usage: moving_platform [SECONDS]   (default 10 s)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <optional>
#include <thread>

#include "soda/runtime/simulation.h"

namespace {

constexpr soda::BodyId kElevator = 1;
constexpr soda::BodyId kFerry = 2;
constexpr int kHoldOpens = 180, kHoldCloses = 300;  // frames (60 Hz)

soda::Body crate(soda::BodyId id, const soda::Vec3& at) {
  soda::Body b;
  b.id = id;
  b.shape = soda::Shape::box(soda::Vec3(0.3, 0.3, 0.3));
  b.mass = 10.0;
  b.friction = 0.9;
  b.position = at;
  return b;
}

soda::Body platform(soda::BodyId id, const soda::Vec3& at) {
  soda::Body b;
  b.id = id;
  b.is_static = true;  // a kinematic body is a static body that moves
  b.kinematic = true;
  b.shape = soda::Shape::box(soda::Vec3(2.0, 0.15, 1.5));
  b.friction = 0.9;
  b.position = at;
  return b;
}

soda::Scene level() {
  soda::Scene s;
  s.name = "moving-platforms";
  soda::Body ground;
  ground.id = 0;
  ground.is_static = true;
  ground.shape = soda::Shape::box(soda::Vec3(30, 0.5, 30));
  ground.position = soda::Vec3(0, -0.5, 0);
  s.bodies.push_back(ground);
  // The elevator, driven by the application; the ferry, by its path: from
  // x = -12 to 12 m and back in 16 s, looping.
  s.bodies.push_back(platform(kElevator, soda::Vec3(-6, 0.3, 6)));
  soda::Body ferry = platform(kFerry, soda::Vec3(-12, 0.3, -4));
  ferry.path.loop = true;
  ferry.path.keys = {{0.0, soda::Vec3(-12, 0.3, -4), soda::Quat::Identity()},
                     {8.0, soda::Vec3(12, 0.3, -4), soda::Quat::Identity()},
                     {16.0, soda::Vec3(-12, 0.3, -4), soda::Quat::Identity()}};
  s.bodies.push_back(ferry);
  soda::BodyId id = 3;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 2; ++j) {
      s.bodies.push_back(crate(id++, soda::Vec3(-7.2 + 1.2 * i, 0.76, 5.4 + 1.2 * j)));    // on the elevator
      s.bodies.push_back(crate(id++, soda::Vec3(-13.2 + 1.2 * i, 0.76, -4.6 + 1.2 * j)));  // on the ferry
    }
  return s;
}

// The lift's controller: floors 4 m apart, 1.5 m/s, a 2 s stop at each.
// The height the elevator should have at frame `k` (60 Hz).
double elevator_height(int k) {
  const double floors[] = {0.3, 4.3, 8.3, 4.3};
  const double ride = 4.0 / 1.5, stop = 2.0, leg = ride + stop;
  const double t = k / 60.0;
  const int n = static_cast<int>(t / leg);
  const double in_leg = t - n * leg;
  const double from = floors[n % 4], to = floors[(n + 1) % 4];
  if (in_leg >= ride) return to;
  const double u = in_leg / ride;
  return from + (to - from) * (0.5 - 0.5 * std::cos(M_PI * u));  // eased
}

// The lift's controller at the frame on screen: where the elevator should
// be at the end of the next step.
soda::Pose elevator_target(int k) {
  return soda::Pose{soda::Vec3(-6, elevator_height(k + 1), 6), soda::Quat::Identity()};
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const double seconds = argc > 1 ? std::atof(argv[1]) : 10.0;
    const soda::Scene scene = level();
    const int frames = static_cast<int>(std::lround(seconds * 60.0));
    // Free-running and speculating; inputs at the frame on screen.
    soda::SimulationConfig config{.territories = 4, .buffer_capacity = 32, .past_inputs = true};
    config.runtime.anticipation = 8;
    soda::Simulation sim(scene, config);
    soda::SceneReader reader = sim.add_reader();  // before start: it sees frame 0
    soda::SceneQuery query = sim.add_query();
    sim.start(sim.time_of(frames));

    // The render thread: draws each frame (here: prints one a second), and
    // the lift's controller gives the next target at the frame on screen.
    std::exception_ptr render_error;
    std::thread render([&] {
      try {
        soda::QueryFilter crates_only;
        crates_only.statics = false;
        for (int k = 0; k <= frames; ++k) {
          const std::optional<soda::SceneFrame> frame = reader.read_at(sim.time_of(k));
          if (!frame) break;  // the run was stopped
          if (k < frames) sim.set_kinematic_target(frame->time, kElevator, elevator_target(k));
          if (k == kHoldOpens) sim.set_collision_filter(frame->time, kFerry, soda::kDefaultCollisionGroup, 0u);
          if (k == kHoldCloses)
            sim.set_collision_filter(frame->time, kFerry, soda::kDefaultCollisionGroup, soda::kAllCollisionGroups);
          // Platforms are in the frame's kinematic list, where every world has them.
          const soda::ScenePose* lift = frame->find_kinematic(kElevator);
          const soda::ScenePose* ferry = frame->find_kinematic(kFerry);
          // What rides the lift: crates whose box touches the box over its
          // floor (asked every frame: a query, like a reader, holds the
          // frames it has not reached yet).
          const double floor = double(lift->position[1]) + 0.15;
          const auto riders = query.overlap_aabb(frame->time, soda::Vec3(-8.0, floor, 4.5),
                                                 soda::Vec3(-4.0, floor + 0.7, 7.5), crates_only);
          if (k % 60 != 0) continue;
          // Aboard the ferry: above its floor (0.45 m) and above the top of a
          // crate on the ground (0.6 m).
          const double fx = double(ferry->position[0]);
          const auto aboard = query.overlap_aabb(frame->time, soda::Vec3(fx - 2.0, 0.62, -5.5),
                                                 soda::Vec3(fx + 2.0, 1.15, -2.5), crates_only);
          const std::optional<soda::BodyAt> hold = reader.properties(frame->step, kFerry);
          std::printf("t = %4.1f s: elevator at y %5.2f m carrying %zu crates, ferry at x %6.2f m (v %5.2f m/s, hold "
                      "%s) carrying %zu\n",
                      frame->time, double(lift->position[1]), riders ? riders->items.size() : 0, fx,
                      double(ferry->linear_velocity[0]), hold && hold->collision_mask == 0u ? "open" : "closed",
                      aboard ? aboard->items.size() : 0);
        }
      } catch (...) {
        render_error = std::current_exception();
      }
    });
    render.join();
    if (render_error) std::rethrow_exception(render_error);
    sim.advance_to(sim.time_of(frames));
    double far = -1e9;
    for (const soda::BodyState& b : sim.body_states())
      if (b.id > kFerry) far = std::max(far, static_cast<double>(b.origin[0]));
    std::printf("%d frames: a crate as far as x %.2f m, %llu rollbacks\n", frames, far,
                static_cast<unsigned long long>(sim.rollbacks()));
    const std::uint64_t hash = sim.state_hash();
    sim.stop();

    // One world, the same calls given before it runs.
    soda::Simulation one(scene, {.threads = 1});
    for (int k = 0; k < frames; ++k) one.set_kinematic_target(one.time_of(k), kElevator, elevator_target(k));
    if (kHoldOpens < frames) one.set_collision_filter(one.time_of(kHoldOpens), kFerry, soda::kDefaultCollisionGroup, 0u);
    if (kHoldCloses < frames)
      one.set_collision_filter(one.time_of(kHoldCloses), kFerry, soda::kDefaultCollisionGroup, soda::kAllCollisionGroups);
    one.advance_to(one.time_of(frames));
    const std::uint64_t expected = one.state_hash();
    std::printf("state hash %016llx, one world %016llx: %s\n", static_cast<unsigned long long>(hash),
                static_cast<unsigned long long>(expected), hash == expected ? "equal" : "DIFFERENT");
    return hash == expected ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "moving_platform: %s\n", e.what());
    return 1;
  }
}

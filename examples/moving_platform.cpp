// Moving platforms on SODA (docs/scene-format.md, "Kinematic bodies"): a
// level made in code — a ground, a freight elevator and a ferry platform,
// both kinematic — runs on 4 territories that speculate (anticipation 8).
// The application's loop drives the elevator as a game drives a lift: every
// frame it asks for the next position on the way to the floor the player
// called (set_kinematic_target), waits at each floor, and rides again. The
// ferry shuttles across the territory borders on a path from the scene (no
// calls at all). Crates ride both: carried by friction, lifted, dropped at
// the ends. The run ends on the hash of one world given the same calls.
// Usage: moving_platform [SECONDS]   (default 10 s)
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>

#include "soda/runtime/simulation.h"

namespace {

constexpr soda::BodyId kElevator = 1;
constexpr soda::BodyId kFerry = 2;

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

// The application's loop: every frame, where the elevator should be at the
// end of the next step.
void drive(soda::Simulation& sim, int frames) {
  for (int k = 0; k < frames; ++k)
    sim.set_kinematic_target(sim.time_of(k), kElevator,
                             soda::Pose{soda::Vec3(-6, elevator_height(k + 1), 6), soda::Quat::Identity()});
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const double seconds = argc > 1 ? std::atof(argv[1]) : 10.0;
    const soda::Scene scene = level();
    const int frames = static_cast<int>(std::lround(seconds * 60.0));
    soda::SimulationConfig config{.territories = 4};
    config.runtime.anticipation = 8;
    soda::Simulation sim(scene, config);
    drive(sim, frames);
    sim.advance_to(sim.time_of(frames));
    double top = 0.0, far = -1e9;
    for (const soda::BodyState& b : sim.body_states()) {
      if (b.id == kElevator) top = b.origin[1];
      if (b.id > kFerry) far = std::max(far, static_cast<double>(b.origin[0]));
    }
    std::printf("%d frames: the elevator at y %.2f m, a crate as far as x %.2f m, %llu rollbacks\n", frames, top,
                far, static_cast<unsigned long long>(sim.rollbacks()));
    const std::uint64_t hash = sim.state_hash();
    sim.stop();

    soda::Simulation one(scene, {.threads = 1});
    drive(one, frames);
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

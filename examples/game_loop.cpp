// A game loop on SODA (docs/embedding.md, "The game loop"): a level made in
// code — a ground, stacks of crates, a 5 m plank — runs on 4 territories
// that speculate (anticipation 8) in the background. The render thread reads
// every frame at 60 Hz of simulated time while the worlds run ahead of it,
// and the "player" acts on the frame on screen: spawns crates (tagged with
// user data) and a 2 m box, pushes a crate, removes one, turns the gravity
// low for a second, makes a crate heavy, one icy and the plank bouncy,
// throws a crate as a ghost through the next stack (its collision filter:
// it touches only the ground until it is a crate again), and reads a crate
// back by id (body_at). Each input lands at the step the
// player saw (the worlds that had passed it roll back), frames follow the
// bodies that come and go, and the run ends on the hash of one world given
// the same inputs.
// Usage: game_loop [SECONDS] [--paced] [--stepping]
//   default 5 s; --paced: 60 frames per wall-clock second, as a real game
//   would draw them; --stepping: no start(), the render thread advances the
//   worlds to each frame itself (advance_to), so inputs are never in the
//   past: no rollback, the worlds idle while a frame is drawn.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <thread>
#include <vector>

#include "soda/runtime/simulation.h"

namespace {

using Clock = std::chrono::steady_clock;

soda::Body crate(soda::BodyId id, const soda::Vec3& at) {
  soda::Body b;
  b.id = id;
  b.shape = soda::Shape::box(soda::Vec3(0.5, 0.5, 0.5));
  b.mass = 20.0;
  b.position = at;
  return b;
}

// Collision groups: the level's geometry, everything else. A crate's mask
// takes both; a ghost's only the level.
constexpr std::uint32_t kLevelGroup = 2u, kThingGroup = 1u, kGhostGroup = 4u;

// The level: a 60 x 60 m ground, 16 stacks of 5 crates, a plank across two
// of them.
soda::Scene level() {
  soda::Scene s;
  s.name = "game-loop";
  soda::Body ground;
  ground.id = 0;
  ground.is_static = true;
  ground.shape = soda::Shape::box(soda::Vec3(30, 0.5, 30));
  ground.position = soda::Vec3(0, -0.5, 0);
  ground.collision_group = kLevelGroup;
  s.bodies.push_back(ground);
  soda::BodyId id = 1;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int level = 0; level < 5; ++level)
        s.bodies.push_back(crate(id++, soda::Vec3(-9 + 6.0 * i, 0.5 + 1.01 * level, -9 + 6.0 * j)));
  soda::Body plank;
  plank.id = id;
  plank.shape = soda::Shape::box(soda::Vec3(2.5, 0.1, 0.4));  // 5 m long
  plank.mass = 40.0;
  plank.position = soda::Vec3(-6, 5.2, -9);
  s.bodies.push_back(plank);
  return s;
}

// What the player did, in the order the calls were made.
struct Action {
  enum class Kind { Spawn, Push, Remove, Gravity, Mass, Friction, Restitution, Tag, Filter } kind;
  double time;
  soda::Body body;  // Spawn
  soda::BodyId id = 0;
  soda::Vec3 vector = soda::Vec3::Zero();  // Push: the impulse; Gravity: the gravity
  double value = 0;                        // Mass, Friction, Restitution
  std::uint64_t tag = 0;                   // Tag
  std::uint32_t group = 0, mask = 0;       // Filter
};

void give(soda::Simulation& sim, const Action& a) {
  switch (a.kind) {
    case Action::Kind::Spawn: sim.add_body(a.time, a.body); break;
    case Action::Kind::Push: sim.apply_impulse(a.time, a.id, a.vector); break;
    case Action::Kind::Remove: sim.remove_body(a.time, a.id); break;
    case Action::Kind::Gravity: sim.set_gravity(a.time, a.vector); break;
    case Action::Kind::Mass: sim.set_mass(a.time, a.id, a.value); break;
    case Action::Kind::Friction: sim.set_friction(a.time, a.id, a.value); break;
    case Action::Kind::Restitution: sim.set_restitution(a.time, a.id, a.value); break;
    case Action::Kind::Tag: sim.set_user_data(a.time, a.id, a.tag); break;
    case Action::Kind::Filter: sim.set_collision_filter(a.time, a.id, a.group, a.mask); break;
  }
}

// The crate thrown as a ghost: the top one of the stack at (-9, -3).
constexpr soda::BodyId kGhost = 10;

// The tag the player gives the crates it spawns: an entity handle of its own.
constexpr std::uint64_t kSpawnedTag = 0x5350000000000000ull;

}  // namespace

int main(int argc, char** argv) {
  try {
    double seconds = 5.0;
    bool paced = false, stepping = false;
    for (int i = 1; i < argc; ++i) {
      if (std::strcmp(argv[i], "--paced") == 0) paced = true;
      else if (std::strcmp(argv[i], "--stepping") == 0) stepping = true;
      else seconds = std::atof(argv[i]);
    }
    const soda::Scene scene = level();
    soda::SimulationConfig config{.territories = 4, .buffer_capacity = 32, .past_inputs = true};
    config.runtime.anticipation = 8;
    soda::Simulation sim(scene, config);
    soda::SceneReader reader = sim.add_reader();  // before start: it sees frame 0
    if (!stepping) sim.start(seconds);  // free-running: the worlds run ahead of the screen

    std::vector<Action> actions;
    std::vector<double> latency_ms;  // from an input to the next frame on screen
    std::exception_ptr render_error;
    std::thread render([&] {
      try {
        const int frames = static_cast<int>(std::lround(seconds * 60.0));
        soda::BodyId next_id = static_cast<soda::BodyId>(scene.bodies.size());
        const Clock::time_point t0 = Clock::now();
        Clock::time_point input_at{};
        for (int k = 0; k <= frames; ++k) {
          if (paced) std::this_thread::sleep_until(t0 + std::chrono::microseconds(k * 1000000LL / 60));
          if (stepping) sim.advance_to(k / 60.0);  // the worlds run to this frame and park
          const std::optional<soda::SceneFrame> frame = reader.read_at(k / 60.0);
          if (!frame) break;  // the run was stopped
          if (input_at != Clock::time_point{}) {
            latency_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - input_at).count());
            input_at = {};
          }
          if (k % 60 == 0) {
            double top = 0;
            for (const soda::ScenePose& p : frame->poses) top = std::max(top, double(p.position[1]));
            std::printf("t = %.2f s (step %lld): %zu bodies, the highest at %.2f m\n", frame->time,
                        static_cast<long long>(frame->step), frame->poses.size(), top);
            if (const soda::ScenePose* ghost = frame->find(kGhost))
              std::printf("  crate %u (thrown as a ghost from 1 s to 2.5 s) at (%.2f, %.2f, %.2f) m\n", kGhost,
                          double(ghost->position[0]), double(ghost->position[1]), double(ghost->position[2]));
            // Crate 3 read back by id at this frame: pose, owner, properties.
            if (const std::optional<soda::BodyAt> b = reader.body_at(frame->time, 3))
              std::printf("  crate 3 at (%.2f, %.2f, %.2f) m in world %d: %.0f kg, friction %.2f, tag %llx\n",
                          double(b->pose.position[0]), double(b->pose.position[1]), double(b->pose.position[2]),
                          b->owner, b->mass, b->friction, static_cast<unsigned long long>(b->user_data));
          }
          // The player acts on the frame on screen: its time is the input's.
          std::vector<Action> now;
          if (k == 60 || k == 90) {
            soda::Body spawned = crate(next_id, {0, 8, 0});
            spawned.user_data = kSpawnedTag | next_id++;
            now.push_back({Action::Kind::Spawn, frame->time, spawned});
          }
          if (k == 100) now.push_back({Action::Kind::Mass, frame->time, {}, 3, {}, 200.0});   // a heavy crate
          if (k == 110) now.push_back({Action::Kind::Friction, frame->time, {}, 3, {}, 0.02});  // on ice
          if (k == 115) now.push_back({Action::Kind::Tag, frame->time, {}, 3, {}, 0, 0xc0ffee});
          if (k == 120) now.push_back({Action::Kind::Push, frame->time, {}, 3, soda::Vec3(2000, 800, 0)});
          if (k == 130) now.push_back({Action::Kind::Restitution, frame->time, {}, 81, {}, 0.7});  // the plank
          if (k == 150) now.push_back({Action::Kind::Gravity, frame->time, {}, 0, soda::Vec3(0, -2.0, 0)});
          if (k == 210 + 30) now.push_back({Action::Kind::Gravity, frame->time, {}, 0, soda::Vec3(0, -9.81, 0)});
          if (k == 180) now.push_back({Action::Kind::Remove, frame->time, {}, 42});
          // A ghost touches only the level: thrown, it flies through the next
          // stack and lands on the ground beyond it; then it is a crate again.
          Action filter{Action::Kind::Filter, frame->time, {}, kGhost};
          if (k == 60) {
            filter.group = kGhostGroup, filter.mask = kLevelGroup, now.push_back(filter);
            now.push_back({Action::Kind::Push, frame->time, {}, kGhost, soda::Vec3(100, 100, 0)});
          }
          if (k == 150) filter.group = kThingGroup, filter.mask = kLevelGroup | kThingGroup, now.push_back(filter);
          if (k == 210) {
            soda::Body box = crate(next_id++, {3, 10, 3});
            box.shape = soda::Shape::box(soda::Vec3(1, 1, 1));  // 2 m across
            box.mass = 160;
            now.push_back({Action::Kind::Spawn, frame->time, box});
          }
          for (const Action& a : now) {
            give(sim, a);
            actions.push_back(a);
            input_at = Clock::now();
          }
        }
      } catch (...) {
        render_error = std::current_exception();
      }
    });
    render.join();
    if (render_error) std::rethrow_exception(render_error);
    sim.advance_to(seconds);
    const std::uint64_t hash = sim.state_hash();
    const std::uint64_t rollbacks = sim.rollbacks();
    sim.stop();

    // One world, the same inputs given before it runs.
    soda::Simulation one(scene, {.threads = 1});
    for (const Action& a : actions) give(one, a);
    one.advance_to(seconds);
    const std::uint64_t expected = one.state_hash();

    std::sort(latency_ms.begin(), latency_ms.end());
    std::printf("%s: %zu inputs at the frame on screen, %llu rollbacks; input to next frame: median %.2f ms, "
                "max %.2f ms\n",
                stepping ? "stepping" : "free-running", actions.size(), static_cast<unsigned long long>(rollbacks),
                latency_ms.empty() ? 0.0 : latency_ms[latency_ms.size() / 2],
                latency_ms.empty() ? 0.0 : latency_ms.back());
    std::printf("state hash %016llx, one world %016llx: %s\n", static_cast<unsigned long long>(hash),
                static_cast<unsigned long long>(expected), hash == expected ? "equal" : "DIFFERENT");
    return hash == expected ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "game_loop: %s\n", e.what());
    return 1;
  }
}

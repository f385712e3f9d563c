// A ragdoll pile on SODA (docs/embedding.md, "Joints"): the registry's
// ragdolls (11 capsules and 10 joints each: cone-twist neck, shoulders and
// hips, hinged waist, elbows and knees) stand in a 2 x 2 block of columns
// around the origin, one column in each of 4 territories (grid:2x1x2) that
// speculate (anticipation 8), and fall into one pile across their borders;
// a ragdoll that lands in another territory migrates to it, joints and
// all, and the frames say which world holds what. A render thread reads every
// frame while the worlds run ahead of it, and the player acts on what is on
// screen: at 1.5 s a kick sends the top ragdoll flying (an impulse on its
// pelvis), at 2.5 s a shot takes a head off (the body and its neck joint go
// together). Each input lands at the frame on screen, a step the worlds
// have already passed: they roll back and re-run with it. The run ends on
// the hash of one world given the same calls before it ran (exit 1 if not).
// Usage: ragdoll_pile [RAGDOLLS] [SECONDS]   (default 12 ragdolls, 4 s)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <optional>
#include <thread>

#include "soda/runtime/simulation.h"

namespace {

constexpr int kBodiesPerRagdoll = 11;  // pelvis first, then spine, head, legs, arms

// The player's calls: a kick on the top ragdoll's pelvis, a head shot on
// the first ragdoll. Ids follow the registry's order (ragdoll r's pelvis
// is 1 + 11 r, its head 3 + 11 r).
struct Play {
  int kick_frame = 90, shot_frame = 150;
  soda::BodyId kicked = 1, shot = 3;
  soda::Vec3 kick = soda::Vec3(60, 30, 20);  // N s at the pelvis (3 kg)
};

void give(soda::Simulation& sim, const Play& play, int frame) {
  if (frame == play.kick_frame) sim.apply_impulse(sim.time_of(frame), play.kicked, play.kick);
  if (frame == play.shot_frame) sim.remove_body(sim.time_of(frame), play.shot);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const int ragdolls = argc > 1 ? std::atoi(argv[1]) : 12;
    const double seconds = argc > 2 ? std::atof(argv[2]) : 4.0;
    if (ragdolls < 1 || !(seconds > 0)) {
      std::fprintf(stderr, "usage: ragdoll_pile [RAGDOLLS >= 1] [SECONDS > 0]\n");
      return 2;
    }
    const soda::Scene scene = soda::make_scene("ragdolls", {ragdolls, 1});
    const int frames = static_cast<int>(seconds * 60.0);
    Play play;
    play.kicked = static_cast<soda::BodyId>(1 + kBodiesPerRagdoll * (ragdolls - 1));  // the top one
    std::printf("%d ragdolls: %zu capsules, %zu joints, on 4 territories\n", ragdolls, scene.dynamic_count(),
                scene.joints.size());

    soda::SimulationConfig config{.territories = 4, .partition = "grid:2x1x2", .buffer_capacity = 32, .past_inputs = true};
    config.runtime.anticipation = 8;
    soda::Simulation sim(scene, config);
    soda::SceneReader reader = sim.add_reader();  // before start: it sees frame 0
    sim.start(sim.time_of(frames));

    // The render thread: draws each frame (here: prints the pile twice a
    // second) and gives the player's input at the frame on screen.
    std::exception_ptr render_error;
    std::thread render([&] {
      try {
        for (int k = 0; k <= frames; ++k) {
          const std::optional<soda::SceneFrame> frame = reader.read_at(sim.time_of(k));
          if (!frame) break;  // the run was stopped
          give(sim, play, k);
          if (k % 30 != 0) continue;
          double top = 0, spread = 0;
          std::size_t owners[4] = {0, 0, 0, 0};
          for (std::size_t i = 0; i < frame->poses.size(); ++i) {
            const soda::ScenePose& p = frame->poses[i];
            top = std::max(top, double(p.position[1]));
            spread = std::max({spread, std::abs(double(p.position[0])), std::abs(double(p.position[2]))});
            if (frame->owners[i] < 4) ++owners[frame->owners[i]];
          }
          std::printf("t = %4.2f s: %zu capsules, pile %5.2f m high, %5.2f m wide; worlds hold %zu/%zu/%zu/%zu\n",
                      frame->time, frame->poses.size(), top, spread, owners[0], owners[1], owners[2], owners[3]);
        }
      } catch (...) {
        render_error = std::current_exception();
      }
    });
    render.join();
    if (render_error) std::rethrow_exception(render_error);
    sim.advance_to(sim.time_of(frames));
    const std::uint64_t hash = sim.state_hash();
    std::printf("%d frames, %llu rollbacks (the inputs at the frame on screen)\n", frames,
                static_cast<unsigned long long>(sim.rollbacks()));
    sim.stop();

    // One world, the same calls given before it runs.
    soda::Simulation one(scene, {.threads = 1});
    for (int k = 0; k <= frames; ++k) give(one, play, k);
    one.advance_to(one.time_of(frames));
    const std::uint64_t expected = one.state_hash();
    std::printf("state hash %016llx, one world %016llx: %s\n", static_cast<unsigned long long>(hash),
                static_cast<unsigned long long>(expected), hash == expected ? "equal" : "DIFFERENT");
    return hash == expected ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ragdoll_pile: %s\n", e.what());
    return 1;
  }
}

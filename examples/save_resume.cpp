// Checkpoints on disk (docs/checkpoints.md): a game saves at 5 s and a
// second process resumes from the file alone.
//
// The game: a pile of boxes on 2 speculating territories; the player drops
// a crate at 1 s, kicks a box at 3 s, and has queued a shove at 6 s and the
// crate's removal at 7 s. At 5 s the game saves (sim.save) and writes its
// input log; it plays on to 8 s. Then it starts itself again as a second
// process (`save_resume --resume FILE`), which resumes the checkpoint on 4
// territories with a pool of 2 threads, runs to 8 s and prints its hash.
// The two hashes and the one-world run's (the same inputs on one territory)
// must be equal: exit 0 if they are, 1 if not.
// Usage: save_resume [N] [DIR]   (N boxes, default 300; DIR for the files, default /tmp)
//        save_resume --resume FILE   (the second process)
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include "soda/runtime/simulation.h"

namespace {

constexpr double kSaveAt = 5.0;
constexpr double kEnd = 8.0;

// The player's inputs, given up front (the game's script).
void play(soda::Simulation& sim, const soda::Scene& scene) {
  soda::BodyId crate = 0, first = 0;
  for (const soda::Body& b : scene.bodies) {
    crate = std::max(crate, b.id + 1);
    if (!b.is_static && first == 0) first = b.id;
  }
  soda::Body c;
  c.id = crate;
  c.shape = soda::Shape::box(soda::Vec3(0.6, 0.4, 0.6));
  c.mass = 3.0;
  c.position = soda::Vec3(0.3, 14, -0.2);
  sim.add_body(1.0, c);                                                  // drop a crate
  sim.set_velocity(3.0, first, soda::Vec3(4, 3, 0), soda::Vec3(0, 2, 0));  // kick a box
  sim.apply_impulse(6.0, first + 1, soda::Vec3(-5, 8, 2));               // after the save: queued in it
  sim.remove_body(7.0, crate);                                           // likewise
}

std::string hex(std::uint64_t h) {
  char s[17];
  std::snprintf(s, sizeof s, "%016llx", static_cast<unsigned long long>(h));
  return s;
}

// The second process: only the file.
int resume(const std::string& path) {
  soda::SimulationConfig config{.territories = 4, .threads = 2};
  soda::Simulation sim = soda::Simulation::resume(path, config);
  std::printf("resumed %s at step %lld on %d territories\n", path.c_str(), static_cast<long long>(sim.steps_done()),
              sim.world_count());
  sim.advance_to(kEnd);
  std::printf("hash %s\n", hex(sim.state_hash()).c_str());
  return 0;
}

// Runs `command`, returns the hash it printed on a "hash " line ("" if none).
std::string hash_printed_by(const std::string& command) {
  FILE* p = popen(command.c_str(), "r");
  if (!p) return "";
  std::string hash;
  char line[512];
  while (std::fgets(line, sizeof line, p)) {
    std::fputs(("  | " + std::string(line)).c_str(), stdout);
    if (std::strncmp(line, "hash ", 5) == 0) hash.assign(line + 5, 16);
  }
  return pclose(p) == 0 ? hash : "";
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc == 3 && std::string(argv[1]) == "--resume") return resume(argv[2]);
    const int n = argc > 1 ? std::atoi(argv[1]) : 300;
    const std::string dir = argc > 2 ? argv[2] : "/tmp";
    const std::string tag = dir + "/save_resume_" + std::to_string(::getpid());
    const std::string checkpoint = tag + ".ckpt", log = tag + "_inputs.json";
    const soda::Scene scene = soda::make_scene("cube-pile", {n, 1});

    soda::SimulationConfig game_config{.territories = 2, .buffer_capacity = 16};
    game_config.runtime.anticipation = 8;
    soda::Simulation game(scene, game_config);
    play(game, scene);
    game.advance_to(kSaveAt);
    const std::int64_t step = game.save(checkpoint);
    game.write_input_log(log);
    std::printf("saved at step %lld to %s; input log %s\n", static_cast<long long>(step), checkpoint.c_str(),
                log.c_str());
    game.advance_to(kEnd);
    const std::string played = hex(game.state_hash());
    std::printf("the game on 2 territories, uninterrupted to %.0f s: %s\n", kEnd, played.c_str());

    char self[4096];
    const ssize_t len = ::readlink("/proc/self/exe", self, sizeof self - 1);
    const std::string exe = len > 0 ? std::string(self, static_cast<std::size_t>(len)) : std::string(argv[0]);
    const std::string resumed = hash_printed_by("'" + exe + "' --resume '" + checkpoint + "'");
    std::printf("a second process, resumed from the file on 4 territories: %s\n",
                resumed.empty() ? "(no hash)" : resumed.c_str());

    soda::Simulation one(scene, {.threads = 1});
    play(one, scene);
    one.advance_to(kEnd);
    const std::string one_world = hex(one.state_hash());
    std::remove(checkpoint.c_str());
    std::remove(log.c_str());
    const bool same = played == one_world && resumed == one_world;
    std::printf("one world: %s (%s)\n", one_world.c_str(), same ? "all equal" : "DIFFERENT");
    return same ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "save_resume: %s\n", e.what());
    return 1;
  }
}

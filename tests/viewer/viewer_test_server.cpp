// The browser tests' server: a small scene recorded in memory (record.h),
// served by the FrameServer as `soda view` serves a replay file. Prints
// "serving URL" and "state_hash HEX", then serves until SIGTERM / SIGINT or
// --seconds (a test never leaves it running).
//   viewer_test_server [--scene falling-cubes] [--n 300] [--territories 4]
//                      [--steps 90] [--seconds 120]
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>

#include "record.h"
#include "soda/scene/registry.h"
#include "soda/scene/hash_text.h"
#include "soda/viewer/frame_codec.h"
#include "soda/viewer/frame_server.h"

namespace {
std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }
}  // namespace

int main(int argc, char** argv) {
  std::string scene_name = "falling-cubes";
  int n = 300, territories = 4, steps = 90;
  double seconds = 120;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    const char* value = argv[i + 1];
    if (key == "--scene") scene_name = value;
    else if (key == "--n") n = std::stoi(value);
    else if (key == "--territories") territories = std::stoi(value);
    else if (key == "--steps") steps = std::stoi(value);
    else if (key == "--seconds") seconds = std::stod(value);
    else {
      std::fprintf(stderr, "viewer_test_server: unknown option %s\n", argv[i]);
      return 2;
    }
  }
  try {
    soda::SceneParams params;
    params.n = n;
    const soda::Scene scene = soda::make_scene(scene_name, params);
    const soda::test::Recording rec = soda::test::record_frames(scene, territories, steps);
    soda::viewer::FrameServer server(rec.source);
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    server.start();
    std::printf("serving %s\nstate_hash %s\n", server.url().c_str(), soda::hash_hex(rec.state_hash).c_str());
    std::fflush(stdout);
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (!g_stop.load() && std::chrono::steady_clock::now() < until)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    server.stop();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "viewer_test_server: %s\n", e.what());
    return 1;
  }
  return 0;
}

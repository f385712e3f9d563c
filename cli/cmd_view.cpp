// `soda run --serve PORT` (a running scene in the browser viewer) and
// `soda view FILE` (a replay file in it). docs/viewer.md.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>

#include "commands.h"
#include "soda/grid/partition.h"
#include "soda/replay/replay_reader.h"
#include "soda/runtime/simulation.h"
#include "soda/viewer/frame_server.h"
#include "soda/viewer/live_frame_source.h"
#include "soda/worlds/body_state.h"


namespace soda::cli {
namespace {

// Set by SIGINT / SIGTERM: the run (or the linger) ends cleanly, the worlds
// stopped and joined, the server closed.
std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int) { g_interrupted.store(true); }

// How often the main thread looks at the run and the interrupt flag.
constexpr std::chrono::milliseconds kPollPeriod{50};
// Exit code after Ctrl-C (128 + SIGINT, the shell's convention).
constexpr int kExitInterrupted = 130;

struct InterruptGuard {
  InterruptGuard() {
    g_interrupted.store(false);
    std::signal(SIGINT, on_interrupt);
    std::signal(SIGTERM, on_interrupt);
  }
  ~InterruptGuard() {
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
  }
};

// Waits `seconds` (< 0: until interrupted) or until interrupted.
void linger(double seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds < 0 ? 1e9 : seconds);
  while (!g_interrupted.load() && std::chrono::steady_clock::now() < until) std::this_thread::sleep_for(kPollPeriod);
}

std::string seconds_text(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%g s", s);
  return text;
}

SimulationConfig serve_simulation_config(const RunConfig& c) {
  auto refuse = [](bool bad, const char* what) {
    if (bad) throw std::invalid_argument(std::string("--serve runs the scene through a Simulation, which does not "
                                                     "support ") + what);
  };
  if (const std::string why = soda::simulation_unsupported(c); !why.empty())
    throw std::invalid_argument("--serve runs the scene through a Simulation, " + why);
  refuse(c.slow_world0_ms > 0, "a slowed world 0");
  refuse(!c.sleeping, "runs with sleeping off");
  refuse(!c.record_path.empty(), "--record at the same time (record first, then 'soda view FILE')");
  SimulationConfig s = soda::simulation_config(c);
  s.runtime.anticipation = c.territories > 1 ? c.runtime.anticipation : 0;
  return s;
}

}  // namespace

int serve_run(const Scene& scene, const RunConfig& config, const ServeOptions& serve) {
  const SimulationConfig sc = serve_simulation_config(config);
  TerritoryMap map = make_partition(sc.partition, scene, sc.territories, sc.grid);
  Simulation sim(scene, map, sc);
  auto source = std::make_shared<viewer::LiveFrameSource>(sim, scene, map);
  // Inputs (--inputs, a scene's own): given before the worlds start, as
  // soda run gives them; the bodies they add described for the viewer.
  if (config.inputs) {
    for (const UserInput& in : *config.inputs)
      if (in.kind == UserInput::Kind::AddBody) source->describe(in.body);
    give_inputs(sim, *config.inputs, config.inputs_source);
  }
  viewer::FrameServer server(source, {.port = serve.port, .web_dir = "", .three_dir = ""});
  InterruptGuard guard;
  server.start();
  std::printf("soda: serving %s live (%zu dynamic bodies, %d territories, %d steps) at %s\n", scene.name.c_str(),
              scene.dynamic_count(), sc.territories, config.steps, server.url().c_str());
  std::fflush(stdout);
  if (serve.wait_for_viewer) {
    std::printf("soda: waiting for a browser to open %s\n", server.url().c_str());
    std::fflush(stdout);
    while (!g_interrupted.load() && server.frame_requests() == 0) std::this_thread::sleep_for(kPollPeriod);
  }
  source->start();
  const auto t0 = std::chrono::steady_clock::now();
  sim.start(sim.time_of(config.steps));
  while (!g_interrupted.load() && sim.published_step() < config.steps && !sim.error())
    std::this_thread::sleep_for(kPollPeriod);
  const bool interrupted = g_interrupted.load();
  if (interrupted || sim.error()) sim.stop();  // rethrows a world's failure
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::int64_t steps = sim.steps_done();
  const std::uint64_t hash = sim.state_hash();
  source->finish(steps, hash);
  std::printf("%s: %lld steps in %.3f s (served live), state_hash %s, %zu asleep%s\n", scene.name.c_str(),
              static_cast<long long>(steps), wall, hash_hex(hash).c_str(), sim.sleeping_count(),
              interrupted ? " (interrupted)" : "");
  if (!interrupted) {
    if (serve.linger_seconds != 0)
      std::printf("soda: the run is over; still serving %s %s (Ctrl-C to stop)\n", server.url().c_str(),
                  serve.linger_seconds < 0 ? "until interrupted" : ("for " + seconds_text(serve.linger_seconds)).c_str());
    std::fflush(stdout);
    linger(serve.linger_seconds);
  }
  server.stop();
  sim.stop();
  return interrupted || g_interrupted.load() ? kExitInterrupted : 0;
}

Command add_view_command(CLI::App& app) {
  auto file = std::make_shared<std::string>();
  auto options = std::make_shared<ServeOptions>(ServeOptions{.port = kDefaultViewPort, .linger_seconds = -1});
  CLI::App* view = app.add_subcommand("view", "Serve a replay file (soda run --record) to the browser viewer");
  view->add_option("file", *file, "The .replay file")->required();
  view->add_option("--port", options->port, "Port on 127.0.0.1 (0: any free port)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  view->add_option("--seconds", options->linger_seconds, "Stop serving after this many seconds (< 0: at Ctrl-C)")
      ->capture_default_str();
  return {view, [file, options]() -> int {
            return serve_source(std::make_shared<replay::ReplayReader>(*file), *options);
          }};
}

int serve_source(std::shared_ptr<replay::FrameSource> source, const ServeOptions& serve) {
  const replay::ViewHeader& h = source->header();
  const auto [first, last] = source->step_range();
  viewer::FrameServer server(source, {.port = serve.port, .web_dir = "", .three_dir = ""});
  InterruptGuard guard;
  server.start();
  std::printf("soda: serving %s (%zu dynamic bodies, %d territories, steps %lld..%lld) at %s\n", h.scene.c_str(),
              h.dynamic_count(), h.territories, static_cast<long long>(first), static_cast<long long>(last),
              server.url().c_str());
  std::printf("soda: open that address in a browser; Ctrl-C stops\n");
  std::fflush(stdout);
  linger(serve.linger_seconds);
  server.stop();
  return 0;  // Ctrl-C is how `soda view` ends: a clean exit
}

}  // namespace soda::cli

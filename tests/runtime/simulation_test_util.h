// Shared helpers of the Simulation suites: the one-world reference as
// frames (body_pose of every dynamic body, by id) and hashes, per step, and
// bitwise comparison of frames.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "driver/testing_hooks.h"
#include "runtime/partitioned_test_util.h"
#include "soda/runtime/simulation.h"
#include "soda/scene/input_file.h"
#include "soda/scene/validate.h"

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

/// The newest scene step any world has finished (re-runs included), for a
/// test's thread to wait on with a condition variable, never a clock: pass
/// hook() as SimulationConfig::after_step.
struct Progress {
  std::mutex mutex;
  std::condition_variable cv;
  std::int64_t newest = 0;
  std::function<void(WorldId, std::int64_t)> hook() {
    return [this](WorldId, std::int64_t step) {
      std::lock_guard lock(mutex);
      if (step > newest) newest = step;
      cv.notify_all();
    };
  }
  /// A failed run calls the hook no more: with `sim`, its error is looked at
  /// now and then while waiting (a wake-up, never a deadline) and thrown.
  void wait_past(std::int64_t step, const Simulation* sim = nullptr) {
    std::unique_lock lock(mutex);
    while (!cv.wait_for(lock, std::chrono::milliseconds(100), [&] { return newest > step; }))
      if (sim)
        if (std::optional<SimulationError> e = sim->error()) throw *e;
  }
  /// After an input at `step` every world goes back to it: count from there.
  void rolled_back_to(std::int64_t step) {
    std::lock_guard lock(mutex);
    newest = step;
  }
};

/// An input of a game loop (run_game_loop): given by the render thread at
/// the frame on screen (a rollback), or ahead of every world: before the
/// run (given_at -1) or once the render thread has read frame given_at.
struct PlannedInput {
  UserInput input;
  bool at_frame = false;
  int given_at = -1;
};

/// One territory on one thread with every input queued before the run: its
/// frames at steps 0 .. steps and its hash at the end.
struct QueuedRun {
  std::vector<std::vector<ScenePose>> frames;
  std::uint64_t hash = 0;
};
inline QueuedRun queued_run(const Scene& s, const std::vector<PlannedInput>& inputs, int steps) {
  QueuedRun r;
  Simulation one(s, SimulationConfig{.threads = 1});
  for (const PlannedInput& i : inputs) one.give(i.input);
  SceneReader reader = one.add_reader();
  for (int k = 0; k <= steps; ++k) {
    EXPECT_TRUE(one.advance_to(one.time_of(k)));
    std::optional<SceneFrame> f = reader.read_at(one.time_of(k));
    r.frames.push_back(f ? f->poses : std::vector<ScenePose>{});
  }
  r.hash = one.state_hash();
  one.stop();
  return r;
}

/// A game-loop suite's reference: the queued one-territory run of `inputs`,
/// and the hash of the same scene without them (the inputs must change the
/// run, or the comparisons prove nothing).
struct InputReference {
  QueuedRun run;
  std::uint64_t no_input_hash = 0;
};
inline InputReference input_reference(const Scene& s, const std::vector<PlannedInput>& inputs, int steps) {
  InputReference r{queued_run(s, inputs, steps)};
  Simulation none(s, SimulationConfig{.threads = 1});
  EXPECT_TRUE(none.advance_to(none.time_of(steps)));
  r.no_input_hash = none.state_hash();
  return r;
}

/// What a game loop's render thread saw (run_game_loop).
struct RenderedRun {
  std::vector<std::string> bad;     // frames missing or not the reference's, and the render thread's error
  std::vector<std::size_t> bodies;  // [k]: bodies in frame k
  std::size_t at_frame = 0;         // inputs given at the frame on screen
};

/// `call` must throw std::invalid_argument whose message holds every one of
/// `needles` (an input refused, naming the joint or body and the field).
inline void expect_refused(const std::function<void()>& call, const std::vector<std::string>& needles) {
  try {
    call();
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    std::printf("refused: %s\n", e.what());
    for (const std::string& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
  }
}

/// An input file holding the one entry `entry` (JSON text) must be refused:
/// SceneError whose message holds every one of `needles` (the entry, the
/// body or joint, the field).
inline void expect_input_file_refused(const std::string& entry, const std::vector<std::string>& needles) {
  const std::string text = R"({"format": "soda-inputs", "version": 1, "inputs": [)" + entry + "]}";
  try {
    parse_inputs_json(text, "bad.json");
    ADD_FAILURE() << "accepted: " << entry;
  } catch (const SceneError& e) {
    std::printf("refused: %s\n", e.what());
    for (const std::string& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
  }
}

/// The game loop: gives the inputs planned before the run, starts `sim`
/// (made with past_inputs and progress.hook() as after_step) to `steps`,
/// and on a render thread reads every frame 0 .. steps through `reader`,
/// comparing frame k with ref[k]; an at-frame input of step k is given once
/// some world has passed k (each one a rollback to k), an ahead input once
/// frame given_at is read. Then advances to `steps`.
inline RenderedRun run_game_loop(Simulation& sim, SceneReader& reader, Progress& progress,
                                 const std::vector<PlannedInput>& inputs,
                                 const std::vector<std::vector<ScenePose>>& ref, int steps) {
  RenderedRun run;
  for (const PlannedInput& i : inputs) {
    if (i.at_frame) ++run.at_frame;
    if (!i.at_frame && i.given_at < 0) sim.give(i.input);
  }
  sim.start(sim.time_of(steps));
  std::thread render([&] {
    try {
      for (int k = 0; k <= steps; ++k) {
        std::optional<SceneFrame> f = reader.read_at(sim.time_of(k));
        if (!f) {
          run.bad.push_back("frame " + std::to_string(k) + ": none");
          continue;
        }
        const std::string diff = frame_difference(f->poses, ref[static_cast<std::size_t>(k)]);
        if (f->step != k || !diff.empty()) run.bad.push_back("frame " + std::to_string(k) + ": " + diff);
        run.bodies.push_back(f->poses.size());
        for (const PlannedInput& i : inputs) {
          if (i.at_frame && i.input.step == k) {
            progress.wait_past(k + 1, &sim);  // some world has passed the frame on screen
            sim.give(i.input);
            progress.rolled_back_to(k);
          }
          if (!i.at_frame && i.given_at == k) sim.give(i.input);
        }
      }
    } catch (const std::exception& e) {
      run.bad.push_back(std::string("render thread: ") + e.what());
    }
  });
  render.join();
  EXPECT_TRUE(sim.advance_to(sim.time_of(steps)));
  return run;
}

/// A game loop as the input suites run it: `sim` on `territories`
/// territories (anticipation, a 16-frame buffer, past inputs, progress's
/// hook; with verify_replay a re-run's replayed islands are solved too and
/// compared, so an island replayed with stale contents throws) and a reader
/// from step 0. run() is run_game_loop; read sim and reader, then stop.
struct GameLoop {
  GameLoop(const Scene& s, int territories, int anticipation, bool verify_replay = false)
      : sim(s, config(territories, anticipation, verify_replay)), reader(sim.add_reader()) {}
  RenderedRun run(const std::vector<PlannedInput>& plan, const std::vector<std::vector<ScenePose>>& ref, int steps) {
    return run_game_loop(sim, reader, progress, plan, ref, steps);
  }
  Progress progress;  // before sim: its hook is sim's after_step
  Simulation sim;
  SceneReader reader;

 private:
  SimulationConfig config(int territories, int anticipation, bool verify_replay) {
    SimulationConfig c{.territories = territories, .buffer_capacity = 16, .past_inputs = true};
    c.runtime.anticipation = anticipation;
    c.after_step = progress.hook();
    detail::edit_testing_hooks(c).verify_replay = verify_replay;
    return c;
  }
};

/// Late spawn: the step the body was added at (-1: never) and the lead over
/// the commit horizon the far world had then.
struct Spawned {
  std::int64_t step = -1;
  std::int64_t lead = 0;
};

/// Late spawn without timing: hook() (SimulationConfig::after_step) keeps
/// every world's newest scene step (re-runs included) and, with `hold`
/// (lockstep only: a speculating world held in after_step could not repair
/// its lost bets, and every world would wait for it), holds world 0 after
/// each of its steps from `hold_from` on while armed, so
/// that the far end of a strip runs ahead of the commit horizon and stays
/// there: world 0 is the slowest world by construction, not by a sleep.
/// add_when_ahead() waits (woken by every world's step) until world `target`
/// is `min_lead` or more steps past the horizon and the horizon is past step
/// 10, adds the body at the horizon's step and lets world 0 go. Without
/// `hold` (one thread steps every world: holding world 0 would stop them
/// all) the round-robin order itself puts the far end a step ahead once per
/// round, and add_when_ahead() waits for such a moment; an input that the
/// horizon has passed meanwhile is refused and tried again. No sleep and no
/// count of attempts decides: the one deadline is a hang guard far above
/// any normal run (a world that never gets ahead is a failure, not a wait).
class SpawnGate {
 public:
  static constexpr std::chrono::minutes kHangGuard{5};

  SpawnGate(int worlds, bool hold, std::int64_t hold_from = 20)
      : newest_(static_cast<std::size_t>(worlds), 0), hold_(hold), hold_from_(hold_from), armed_(hold) {}

  ~SpawnGate() { release(); }

  std::int64_t newest(WorldId w) const {
    std::lock_guard lock(mutex_);
    return newest_[static_cast<std::size_t>(w)];
  }

  std::function<void(WorldId, std::int64_t)> hook() {
    return [this](WorldId w, std::int64_t step) {
      std::unique_lock lock(mutex_);
      std::int64_t& n = newest_[static_cast<std::size_t>(w)];
      n = std::max(n, step);
      changed_.notify_all();
      if (w != 0 || !armed_ || step < hold_from_) return;
      held_ = true;
      changed_.notify_all();
      const bool let_go = changed_.wait_for(lock, kHangGuard, [&] { return !armed_; });
      held_ = false;
      if (!let_go) throw std::runtime_error("SpawnGate: world 0 held for longer than the hang guard");
    };
  }

  /// Lets world 0 go for good.
  void release() {
    std::lock_guard lock(mutex_);
    armed_ = false;
    changed_.notify_all();
  }

  /// `add_while_held`: add with world 0 still held (a speculative
  /// Simulation posts the rollback and holds nobody); else let world 0 go
  /// first (a lockstep Simulation holds every world at one boundary for the
  /// input, world 0 included).
  Spawned add_when_ahead(Simulation& sim, const Body& body, WorldId target, std::int64_t min_lead,
                         bool add_while_held) {
    struct LetGo {
      SpawnGate& g;
      ~LetGo() { g.release(); }
    } let_go{*this};
    Spawned out;
    const auto deadline = std::chrono::steady_clock::now() + kHangGuard;
    std::unique_lock lock(mutex_);
    for (;;) {
      std::int64_t gvt = 0;
      const bool ready = changed_.wait_until(lock, deadline, [&] {
        gvt = sim.commit_horizon_step();
        out.lead = newest_[static_cast<std::size_t>(target)] - gvt;
        return (!hold_ || held_) && gvt >= 10 && out.lead >= min_lead;
      });
      if (!ready) {
        ADD_FAILURE() << "world " << target << " never got " << min_lead << " steps ahead of the commit horizon "
                      << "(hang guard; newest " << newest_[static_cast<std::size_t>(target)] << ", horizon " << gvt
                      << ")";
        return out;
      }
      if (!add_while_held) {
        armed_ = false;
        changed_.notify_all();
      }
      lock.unlock();
      bool added = false;
      try {
        sim.add_body(sim.time_of(gvt), body);
        added = true;
      } catch (const std::invalid_argument& e) {
        const bool too_old = std::string(e.what()).find("older than the commit horizon") != std::string::npos;
        EXPECT_TRUE(too_old) << e.what();
        if (!too_old) return out;  // any other error ends the attempt
      }
      lock.lock();
      if (added) {
        out.step = gvt;
        return out;
      }
      armed_ = hold_;  // the horizon passed the step: hold world 0 again and wait for the next chance
    }
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<std::int64_t> newest_;
  const bool hold_;
  const std::int64_t hold_from_;
  bool armed_;
  bool held_ = false;
};

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

/// A scene run on K territories with a partition, a schedule (threads: 0 a
/// thread per world, 1 one thread, more a pool) and speculation, for the
/// suites that compare a stream of a run with one territory's.
struct SpeculationCase {
  const char* scene;
  int bodies;
  int territories;
  const char* partition;
  int threads;
  int anticipation;
};

/// "scene_K4_kmeans_t0_a8": a test name.
inline std::string speculation_case_name(const ::testing::TestParamInfo<SpeculationCase>& i) {
  std::string n = std::string(i.param.scene) + "_K" + std::to_string(i.param.territories) + "_" +
                  i.param.partition + "_t" + std::to_string(i.param.threads) + "_a" +
                  std::to_string(i.param.anticipation);
  for (char& ch : n)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return n;
}

/// The case's schedule and speculation (eager bets and a kept state every
/// step when it speculates), small buffers.
inline SimulationConfig speculation_config(const SpeculationCase& c) {
  SimulationConfig config{.threads = c.threads, .buffer_capacity = 16};
  config.runtime.anticipation = c.anticipation;
  config.runtime.checkpoint_every = 1;
  config.runtime.eager_bets = c.anticipation > 0;
  return config;
}

}  // namespace soda::test

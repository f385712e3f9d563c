// Simulation under stress: readers' back-pressure with tiny buffers never
// deadlocks the neighbour protocol and never changes the result; stop()
// releases everyone, at one step boundary; a failing world reaches
// advance_to, blocked readers and stop() as a SimulationError; pinning
// changes nothing. Label "concurrency" (ThreadSanitizer in CI).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>

#include "runtime/simulation_test_util.h"

namespace soda {
namespace {

std::string name_of(int threads) {
  return threads == 0 ? "thread per world" : threads == 1 ? "one thread" : "pool of " + std::to_string(threads);
}

// Capacity 2 (the least): a fast reader, a slow one (sleeps, every third
// step) and one jumping 17 steps at a time; the worlds wait for the slowest
// cursor, the result and every frame read stay exact.
TEST(SimulationThreads, SmallBuffersBackPressureNeverDeadlocks) {
  constexpr int kSteps = 80;
  const Scene s = test::scene("cube-pile", 100);
  const test::Reference ref = test::reference_run(s, kSteps);
  for (int threads : {0, 2, 1}) {
    Simulation sim(s, SimulationConfig{.territories = 4, .threads = threads, .buffer_capacity = 2});
    std::atomic<int> bad_frames{0}, frames_read{0};
    auto reader_thread = [&](int stride, int sleep_us) {
      return std::thread([&, stride, sleep_us, reader = sim.add_reader()]() mutable {
        for (int k = 0; k <= kSteps; k += stride) {
          std::optional<SceneFrame> f = reader.read_at(sim.time_of(k));
          if (!f || f->step != k || !test::frame_difference(f->poses, ref.frames[static_cast<std::size_t>(k)]).empty())
            ++bad_frames;
          ++frames_read;
          if (sleep_us) std::this_thread::sleep_for(std::chrono::microseconds(sleep_us));
        }
      });
    };
    std::thread fast = reader_thread(1, 0);
    std::thread slow = reader_thread(3, 2000);
    std::thread jumping = reader_thread(17, 500);
    sim.start(sim.time_of(kSteps));  // free run: only the readers hold the worlds back
    EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
    fast.join();
    slow.join();
    jumping.join();
    sim.stop();
    const WorldMetrics total = test::total(sim.metrics());
    double room = 0;
    for (const WorldMetrics& m : sim.metrics()) room += m.buffer_blocked_seconds;
    std::printf("[ cube-pile 100 %s K=4 capacity 2 %s ] stopped at step %lld, %d frames read, worlds waited %.3f s "
                "for room, %.3f s for neighbours\n",
                kPrecisionName, name_of(threads).c_str(), static_cast<long long>(sim.steps_done()), frames_read.load(), room,
                total.blocked_seconds);
    EXPECT_EQ(bad_frames.load(), 0) << name_of(threads);
    EXPECT_EQ(sim.steps_done(), kSteps);
    EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(ref.hashes[kSteps]));
  }
}

// stop() before anything, twice; during a free run held back by a reader
// that never reads, with another blocked far in the future: it returns, the
// blocked reader gets nullopt, every world ends at one step boundary.
TEST(SimulationThreads, StopIsIdempotentAndReleasesEveryone) {
  const Scene s = test::scene("falling-cubes", 100);
  const test::Reference ref = test::reference_run(s, 12);
  {
    Simulation sim(s, SimulationConfig{.territories = 4});
    sim.stop();
    sim.stop();
    EXPECT_EQ(sim.steps_done(), 0);
  }
  for (int threads : {0, 2, 1}) {
    constexpr std::size_t kCapacity = 4;
    Simulation sim(s, SimulationConfig{.territories = 4, .threads = threads, .buffer_capacity = kCapacity});
    SceneReader idle = sim.add_reader();  // never reads: pins step 0 on
    std::atomic<bool> returned{false};
    std::thread blocked([&, reader = sim.add_reader()]() mutable {
      EXPECT_FALSE(reader.read_at(1000.0).has_value());
      returned = true;
    });
    sim.start();
    while (sim.published_step() < static_cast<std::int64_t>(kCapacity) - 1)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_FALSE(returned.load());
    EXPECT_THROW(sim.state_hash(), std::logic_error);  // running without limit
    sim.stop();
    blocked.join();
    EXPECT_TRUE(returned.load());
    sim.stop();
    const std::int64_t done = sim.steps_done();
    std::printf("[ falling-cubes 100 K=4 %s ] held by a reader at step 0 with capacity %zu: stopped at step %lld\n",
                name_of(threads).c_str(), kCapacity, static_cast<long long>(done));
    EXPECT_GE(done, static_cast<std::int64_t>(kCapacity) - 1);
    EXPECT_LE(done, static_cast<std::int64_t>(kCapacity) + 1);
    EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(ref.hashes[static_cast<std::size_t>(done)]));
    // The idle reader still reads what is held.
    std::optional<SceneFrame> f0 = idle.try_read_at(0.0);
    ASSERT_TRUE(f0.has_value());
    EXPECT_EQ(test::frame_difference(f0->poses, ref.frames[0]), "");
  }
  // Destroyed while running freely, with a reader blocked on another
  // thread: the destructor stops the run, the reader (which outlives it)
  // returns nullopt.
  std::thread blocked;
  {
    Simulation sim(s, SimulationConfig{.territories = 4});
    blocked = std::thread([reader = sim.add_reader()]() mutable { EXPECT_FALSE(reader.read_at(1000.0).has_value()); });
    sim.start();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  blocked.join();
}

// A world's thread throws (after_step, world 2, step 25): advance_to, a
// reader blocked far ahead, stop() (every time) and the readouts throw a
// SimulationError naming world 2 and the message; nothing hangs.
TEST(SimulationThreads, InjectedFailureReachesAdvanceToAndBlockedReader) {
  const Scene s = test::scene("falling-cubes", 100);
  for (int threads : {0, 2, 1}) {
    SimulationConfig config{.territories = 4, .threads = threads, .buffer_capacity = 8};
    config.after_step = [](WorldId w, std::int64_t step) {
      if (w == 2 && step == 25) throw std::runtime_error("injected failure");
    };
    Simulation sim(s, config);
    std::atomic<int> reader_saw{-2};
    std::thread render([&, reader = sim.add_reader()]() mutable {
      try {
        for (int k = 0; k <= 600; ++k) reader.read_at(sim.time_of(k));
        reader_saw = -1;
      } catch (const SimulationError& e) {
        reader_saw = e.world();
        EXPECT_EQ(e.message(), "injected failure");
      }
    });
    sim.start();
    try {
      sim.advance_to(10.0);
      ADD_FAILURE() << "advance_to returned with " << name_of(threads);
    } catch (const SimulationError& e) {
      std::printf("[ %s ] advance_to: %s\n", name_of(threads).c_str(), e.what());
      EXPECT_EQ(e.world(), 2);
      EXPECT_EQ(e.message(), "injected failure");
      EXPECT_THROW(std::rethrow_exception(e.cause()), std::runtime_error);
    }
    render.join();
    EXPECT_EQ(reader_saw.load(), 2) << name_of(threads);
    EXPECT_THROW(sim.stop(), SimulationError);
    EXPECT_THROW(sim.stop(), SimulationError);
    EXPECT_THROW(sim.state_hash(), SimulationError);
    ASSERT_TRUE(sim.error().has_value());
    EXPECT_EQ(sim.error()->world(), 2);
    EXPECT_THROW(sim.advance_to(0.1), SimulationError);
  }
}

// A body too fast for the run's reach (neighbourhoods sized for 3 m/s, the
// chain's push: its halo reaches a world that is not a neighbour): the
// PartitionError of its world's thread reaches
// advance_to as a SimulationError.
TEST(SimulationThreads, PartitionErrorReachesTheCaller) {
  Scene s = test::scene("chain", 16);
  for (Body& b : s.bodies)
    if (b.id == 9) b.linear_velocity = Vec3(400.0, 0.0, 0.0);  // ~6.7 m per step, cells are 2 m
  GridOptions g;
  g.cell_size = 2.0;
  g.box = CellBox{{-4, 0, -1}, {3, 0, 0}};
  for (int threads : {0, 3, 1}) {
    Simulation sim(s, make_partition("grid:8x1x1", s, 8, g), SimulationConfig{.threads = threads, .runtime = {.reach_speed = 3}});
    try {
      sim.run_for(1.0);
      ADD_FAILURE() << "no error with " << name_of(threads);
    } catch (const SimulationError& e) {
      std::printf("[ %s ] %s\n", name_of(threads).c_str(), e.what());
      EXPECT_NE(e.world(), kNoWorld);
      EXPECT_NE(e.message().find("body 9"), std::string::npos);
      EXPECT_THROW(std::rethrow_exception(e.cause()), PartitionError);
    }
    EXPECT_THROW(sim.stop(), SimulationError);
  }
}

TEST(SimulationThreads, PinningKeepsTheHash) {
  constexpr int kSteps = 60;
  const Scene s = test::scene("cube-pile", 100);
  const std::uint64_t reference = test::reference_hash(s, kSteps);
  for (int threads : {0, 2}) {
    Simulation sim(s, SimulationConfig{.territories = 4, .threads = threads, .runtime = {.pin = true}});
    ASSERT_TRUE(sim.advance_to(sim.time_of(kSteps)));
    EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(reference)) << name_of(threads);
  }
  const TerritoryMap map = make_partition("kmeans", s, 4, GridOptions{});
  for (PartitionedOptions o : {PartitionedOptions{.schedule = Schedule::ThreadPerWorld, .runtime = {.pin = true}},
                               PartitionedOptions{.schedule = Schedule::Pool, .threads = 2, .runtime = {.pin = true}}}) {
    PartitionedWorld w(s, map, o);
    w.step(kSteps);
    EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(reference)) << schedule_name(o.schedule);
  }
}

}  // namespace
}  // namespace soda

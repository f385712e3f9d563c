// The scheduler alone (runtime/src/execution/scheduler.h), on toy worlds: each world
// of a ring sends its successor one message per step and waits for its
// predecessor's. Every schedule runs every world to the end; the first error
// of any world stops every thread and reaches the caller; every schedule
// reports a deadlock naming what each world waits for. Run under
// ThreadSanitizer in CI (label "concurrency").
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <thread>

#include "execution/scheduler.h"
#include "soda/runtime/transport.h"

namespace soda {
namespace {

class RingWorld final : public WorldTask {
 public:
  RingWorld(WorldId id, int worlds, Transport& transport, int steps, int fail_at, bool mute)
      : id_(id), next_((id + 1) % worlds), transport_(transport), steps_(steps), fail_at_(fail_at), mute_(mute) {}

  Advance advance() override {
    Advance a;
    for (;;) {
      if (step_ == steps_) {
        a.done = true;
        return a;
      }
      if (!sent_) {
        if (step_ == fail_at_) throw std::runtime_error("ring world " + std::to_string(id_) + " fails");
        if (!mute_) transport_.send(next_, Message{id_, next_, step_, GlueBatch{}});
        sent_ = true;
        a.progressed = true;
      }
      while (std::optional<Message> m = transport_.try_receive(id_)) deliver(std::move(*m));
      if (received_ <= step_) return a;
      ++step_;
      sent_ = false;
      a.progressed = true;
    }
  }
  void deliver(Message m) override {
    if (m.step != received_) throw std::logic_error("ring: message out of order");
    ++received_;
  }
  bool waiting_for_room() const override { return false; }
  void publish_blocking() override {}
  std::int64_t steps_done() const override { return step_; }
  std::string waiting_for() const override {
    return "world " + std::to_string(id_) + " waits for step " + std::to_string(step_);
  }
  void add_blocked_ns(std::int64_t ns) override { blocked_ns_ += ns; }
  void add_guest_work(std::int64_t, std::int64_t) override {}

 private:
  const WorldId id_, next_;
  Transport& transport_;
  const int steps_, fail_at_;
  const bool mute_;
  int step_ = 0, received_ = 0;
  bool sent_ = false;
  std::int64_t blocked_ns_ = 0;
};

struct Ring {
  Ring(int worlds, int steps, WorldId failing = kNoWorld, WorldId mute = kNoWorld)
      : transport(make_in_memory_transport(worlds)) {
    for (WorldId w = 0; w < worlds; ++w)
      owned.push_back(std::make_unique<RingWorld>(w, worlds, *transport, steps, w == failing ? steps / 2 : -1,
                                                  w == mute));
    for (auto& t : owned) tasks.push_back(t.get());
  }
  std::unique_ptr<Transport> transport;
  std::vector<std::unique_ptr<RingWorld>> owned;
  std::vector<WorldTask*> tasks;
};

Scheduler::Options options(Schedule schedule) {
  Scheduler::Options o;
  o.schedule = schedule;
  o.threads = schedule == Schedule::Pool ? 3 : 1;
  o.name = "Ring";
  return o;
}

constexpr Schedule kSchedules[] = {Schedule::Sequential, Schedule::ThreadPerWorld, Schedule::Pool};

TEST(Scheduler, EveryScheduleRunsEveryWorldToTheEnd) {
  for (Schedule s : kSchedules) {
    Ring ring(7, 200);
    Scheduler(options(s), ring.tasks, *ring.transport, nullptr).run();
    for (const auto& w : ring.owned) EXPECT_EQ(w->steps_done(), 200) << schedule_name(s);
  }
}

TEST(Scheduler, TheFirstErrorStopsEveryScheduleAndReachesTheCaller) {
  for (Schedule s : kSchedules) {
    Ring ring(5, 100, 3);
    WorldId reported = kNoWorld;
    int hook_calls = 0;
    try {
      Scheduler(options(s), ring.tasks, *ring.transport, nullptr, [&](WorldId w, std::exception_ptr) {
        reported = w;
        ++hook_calls;
      }).run();
      ADD_FAILURE() << "no exception with " << schedule_name(s);
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()), "ring world 3 fails") << schedule_name(s);
    }
    EXPECT_EQ(reported, 3) << schedule_name(s);
    EXPECT_EQ(hook_calls, 1) << schedule_name(s);
    EXPECT_LT(ring.owned[3]->steps_done(), 100);
  }
}

// World 1 never sends: world 2 waits at step 0 for ever, and every world
// after it waits in turn. The round-robin thread sees that no world can go
// on; the pool's last worker to go idle finds no world queued; the threads
// of a thread per world have all waited deadlock_after with no message
// taken. Each reports it instead of hanging, naming what each world waits
// for, and the error reaches the caller.
TEST(Scheduler, EveryScheduleReportsADeadlock) {
  for (Schedule s : kSchedules) {
    Ring ring(3, 10, kNoWorld, 1);
    Scheduler::Options o = options(s);
    o.deadlock_after = std::chrono::milliseconds(200);
    WorldId reported = 7;
    try {
      Scheduler(o, ring.tasks, *ring.transport, nullptr, [&](WorldId w, std::exception_ptr) { reported = w; }).run();
      ADD_FAILURE() << "no deadlock reported with " << schedule_name(s);
    } catch (const std::logic_error& e) {
      const std::string what = e.what();
      std::printf("%s: %s\n", schedule_name(s), what.c_str());
      EXPECT_EQ(what.rfind("Ring: deadlock:", 0), 0u) << what;
      EXPECT_NE(what.find("[world 2 waits for step 0]"), std::string::npos) << what;
    }
    if (s != Schedule::Sequential) EXPECT_EQ(reported, kNoWorld) << schedule_name(s);  // no world failed
  }
}

// A world that is slow, not stuck, is no deadlock: one world of a ring
// computes for longer than deadlock_after at each of its first steps while
// the others wait for it.
class SlowWorld final : public WorldTask {
 public:
  SlowWorld(RingWorld& inner, std::chrono::milliseconds pause) : inner_(inner), pause_(pause) {}
  Advance advance() override {
    if (inner_.steps_done() < 3) std::this_thread::sleep_for(pause_);
    return inner_.advance();
  }
  void deliver(Message m) override { inner_.deliver(std::move(m)); }
  bool waiting_for_room() const override { return false; }
  void publish_blocking() override {}
  std::int64_t steps_done() const override { return inner_.steps_done(); }
  std::string waiting_for() const override { return inner_.waiting_for(); }
  void add_blocked_ns(std::int64_t ns) override { inner_.add_blocked_ns(ns); }
  void add_guest_work(std::int64_t, std::int64_t) override {}

 private:
  RingWorld& inner_;
  std::chrono::milliseconds pause_;
};

TEST(Scheduler, ASlowWorldIsNoDeadlock) {
  for (Schedule s : {Schedule::ThreadPerWorld, Schedule::Pool}) {
    Ring ring(3, 10);
    SlowWorld slow(*ring.owned[1], std::chrono::milliseconds(150));
    std::vector<WorldTask*> tasks = ring.tasks;
    tasks[1] = &slow;
    Scheduler::Options o = options(s);
    o.deadlock_after = std::chrono::milliseconds(50);
    Scheduler(o, tasks, *ring.transport, nullptr).run();
    for (const auto& w : ring.owned) EXPECT_EQ(w->steps_done(), 10) << schedule_name(s);
  }
}

}  // namespace
}  // namespace soda

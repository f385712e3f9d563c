// Internal: one world's per-stage costs (soda/runtime/stage.h). The world's
// thread is always in exactly one stage while it works for the world: a
// Scope puts it in a stage and, when it ends, back in the one it was in (a
// merged island's solve inside the merge, a restore inside a receive). Each
// stage change reads the thread's CPU clock once and gives the interval to
// the stage left, so the stages' CPU times sum to the world's CPU time by
// construction. A scope nested in one of the same stage changes nothing and
// reads no clock (a thread CPU clock read is a system call: an idle step's
// cost is mostly these and the messages' wake-ups, docs/skip.md). Not
// thread-safe: used by the thread running the world, one at a time;
// published() is a copy taken at a step's end for other threads.
#pragma once

#include <cstdint>
#include <thread>

#include "step/message_tally.h"
#include "soda/runtime/stage.h"

namespace soda {

class StageClock {
 public:
  /// Costs in integer units (ns), summed since the world was built.
  struct Totals {
    std::array<std::int64_t, kStageCount> cpu_ns{};
    std::array<std::int64_t, kStageCount> wait_ns{};
    std::array<std::uint64_t, kStageCount> items{};
    std::array<std::uint64_t, kStageCount> messages{};
    std::array<std::uint64_t, kStageCount> bytes{};
    std::int64_t cpu_ns_sum = 0;     // over the stages
    std::int64_t thread_cpu_ns = 0;  // the thread's own clock since the world first ran on it; 0 if shared
  };

  class Scope {
   public:
    Scope(StageClock& clock, Stage stage);
    ~Scope();
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    StageClock& clock_;
    Stage previous_;
    bool same_ = false;  // nested in a scope of the same stage: no clock read (its interval goes on)
  };

  /// Wall time waited for what `stage` needs.
  void add_wait(Stage stage, std::int64_t ns) { totals_.wait_ns[index(stage)] += ns; }
  void count(Stage stage, std::uint64_t items) { totals_.items[index(stage)] += items; }
  /// CPU time the world's thread spent for the world outside every Scope
  /// (a guest's share of another world's solve, scheduler.h), given to
  /// `stage`; no clock read here.
  void add_cpu(Stage stage, std::int64_t ns) {
    totals_.cpu_ns[index(stage)] += ns;
    totals_.cpu_ns_sum += ns;
  }
  /// A message of `kind` and `bytes` bytes sent to `to` in the current
  /// stage (also counted by destination and kind: published_traffic()).
  void sent(WorldId to, MessageKind kind, std::uint64_t bytes) {
    ++totals_.messages[index(current_)];
    totals_.bytes[index(current_)] += bytes;
    tally_.sent(to, kind, bytes);
  }
  /// A merged border island of `depth` levels below its root, this step.
  void island_depth(std::uint64_t depth) { tally_.island_depth(depth); }
  /// The stage running now, or Idle outside every Scope.
  Stage current() const { return current_; }
  /// CPU time so far, the current stage's interval included (one clock read;
  /// inside a Scope only).
  std::int64_t cpu_ns_now();
  /// CPU time given to `stage` so far (intervals closed at the last read).
  std::int64_t cpu_ns(Stage stage) const { return totals_.cpu_ns[index(stage)]; }
  /// At a step's end (inside a Scope): the totals become what published()
  /// and published_traffic() return.
  void publish();
  const Totals& published() const { return published_; }
  const MessageTraffic& published_traffic() const { return published_traffic_; }
  /// Wall time waited per stage so far (as WorldMetrics::blocked_seconds,
  /// written by the world's thread as it waits).
  const std::array<std::int64_t, kStageCount>& waits() const { return totals_.wait_ns; }

 private:
  static std::size_t index(Stage s) { return static_cast<std::size_t>(s); }
  void close_interval(std::int64_t now);

  Totals totals_;
  Totals published_;
  MessageTally tally_;
  MessageTraffic published_traffic_;
  Stage current_ = Stage::Idle;
  int depth_ = 0;
  std::int64_t mark_ = 0;              // clock read at the last stage change
  std::int64_t thread_first_ns_ = -1;  // the thread's clock when the world first ran on it
  std::thread::id thread_;
  bool shared_ = false;                // ran on several threads, or its thread ran other worlds
};

}  // namespace soda

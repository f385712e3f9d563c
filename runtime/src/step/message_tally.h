// Internal: counts one world's sent messages by destination and kind, and
// per step the rounds of each kind and the depth of the merge trees
// (soda/runtime/message_traffic.h). Not thread-safe: used by the thread
// running the world, one at a time (through its StageClock).
#pragma once

#include <cstdint>
#include <vector>

#include "soda/runtime/message_traffic.h"

namespace soda {

class MessageTally {
 public:
  /// A message of `kind` and `bytes` encoded bytes sent to `to`.
  void sent(WorldId to, MessageKind kind, std::uint64_t bytes);
  /// A merged border island whose tree has `depth` levels below its root.
  void island_depth(std::uint64_t depth);
  /// The internal step ended: its per-step counts go into rounds, steps,
  /// max_per_step and island_depth_*.
  void end_step();
  const MessageTraffic& totals() const { return totals_; }

 private:
  struct StepCount {
    WorldId to;
    MessageKind kind;
    std::uint64_t messages;
  };
  MessageFlow& flow(WorldId to, MessageKind kind);

  MessageTraffic totals_;
  std::vector<StepCount> step_;  // this step's counts, (to, kind) once each
  std::uint64_t step_depth_ = 0;
};

/// Adds `m` to `t`: flows of the same (to, kind) and rounds summed, maxima
/// kept (a world's counts carried across a rebuild; totals over worlds).
void add_traffic(MessageTraffic& t, const MessageTraffic& m);

}  // namespace soda

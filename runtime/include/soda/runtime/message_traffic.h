// runtime/ — what one world sent, by destination and kind
// (WorldMetrics::traffic): the measured input of the estimate of step time
// on N machines (docs/mpi-model.md, bench/mpi_model.py).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "soda/runtime/messages.h"

namespace soda {

/// Message kinds (MessageKind 1..7); index of a kind: static_cast<int>(kind) - 1.
inline constexpr std::size_t kMessageKindCount = 7;

/// The messages of one kind one world sent to one destination, summed over
/// its internal steps (re-sends after rollbacks included).
struct MessageFlow {
  WorldId to = kNoWorld;
  MessageKind kind = MessageKind::Ghosts;
  std::uint64_t messages = 0;
  /// Their encoded size in bytes (message_codec.h: what goes on a wire);
  /// 0 when the transport passes messages as values (no --serialise).
  std::uint64_t bytes = 0;
  std::uint64_t steps = 0;         // internal steps in which at least one was sent
  std::uint64_t max_per_step = 0;  // most sent in one internal step
};

/// One world's sent messages. Counted by the world's thread as it sends;
/// read through WorldMetrics (a copy taken at the end of each step).
struct MessageTraffic {
  /// Sorted by (to, kind); only pairs with at least one message.
  std::vector<MessageFlow> flows;
  /// Per kind (index as above): summed over internal steps, the most
  /// messages of that kind sent to one destination in the step — the
  /// rounds of that kind a step waits for, seen from this world (1 per step
  /// for Ghosts and Migrants; Fragments relay once per round of the merge).
  std::array<std::uint64_t, kMessageKindCount> rounds{};
  /// Per internal step, the depth (levels below the root) of the deepest
  /// merged border island's tree this world took part in, summed over
  /// steps, and its maximum: Gather climbs and Results descend that many
  /// hops one after the other.
  std::uint64_t island_depth_sum = 0;
  std::uint64_t island_depth_max = 0;
};

}  // namespace soda

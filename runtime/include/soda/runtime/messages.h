// runtime/ — the step, threads, messages and the public API. This header:
// the messages worlds send each other during a partitioned step
// (docs/partitioned-step.md). Plain values, no pointers: every message can
// be turned into bytes and back (message_codec.h) without losing a bit.
//
// Per world and step t, to each direct neighbour n:
//   Ghosts(t)     exactly one, possibly empty          (exchange_ghosts)
//   Glue(t)       exactly one iff n sent it ghosts at t (build_islands)
//   Fragments(t)  zero or more, to neighbours sharing a border island: fragment
//                 headers (merge_islands; with data under solve_everywhere)
//   Gather(t)     one per border island from each non-root world to its
//                 parent in the island's tree: the data of its subtree
//   Results(t)    one per border island to each child of the island's tree
//                 (the last two not with the test-only solve_everywhere hook)
//   Migrants(t)   exactly one, possibly empty          (migrate; consumed at the end of t)
// and, with speculation only (docs/rollback.md):
//   Control       Notice: the sender rolled back to step t on its own; its
//                 messages of steps >= t sent before this are void. Wake: to
//                 itself, when the commit horizon moved or every world must
//                 roll back (rollback_board.h).
// Every message carries the epoch of the rollbacks of every world its sender
// had seen, and the number of rewinds (a Simulation's lockstep rollback for
// an input at a past step: every world goes back together) its sender had
// taken: a world drops a message of a rewind it has gone past, and takes its
// own pending rewind before a message of one it has not taken yet.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/worlds/border_records.h"

namespace soda {

/// Island fragments relayed during merge_islands.
struct FragmentBatch {
  std::vector<Fragment> fragments;
};

/// Solved border islands relayed from their root down the island's tree.
/// Immutable and shared: in one process the root and every world below it
/// read the same result, none copies it (a copy per child was a fresh
/// allocation of every manifold of the island each step); across processes
/// the codec writes and reads it like any payload.
struct ResultBatch {
  std::vector<std::shared_ptr<const IslandResult>> results;
};

/// The fragments (with data) of a subtree of one border island's tree, on
/// their way to the island's root.
struct GatherBatch {
  BodyId island = 0;  // smallest body id of the island
  std::vector<Fragment> fragments;
};

/// Speculation's control messages (world_process.h).
struct Control {
  enum class Type : std::uint8_t { Notice = 1, Wake = 2 };
  Type type = Type::Wake;
  std::uint64_t seq = 0;        // Notice: its number, per (sender, receiver)
  std::int64_t rolled_to = -1;  // Notice: the step the sender rolled back to
  std::int64_t pinned = -1;     // Notice: the step it pinned in the commit horizon (the receiver unpins it)
};

enum class MessageKind : std::uint8_t {
  Ghosts = 1, Glue = 2, Fragments = 3, Migrants = 4, Results = 5, Gather = 6, Control = 7
};
const char* message_kind_name(MessageKind kind);

struct Message {
  WorldId from = kNoWorld;
  WorldId to = kNoWorld;
  std::int64_t step = 0;  // the internal step the message belongs to
  std::variant<GhostBatch, GlueBatch, FragmentBatch, MigrantBatch, ResultBatch, GatherBatch, Control> payload;
  std::uint32_t epoch = 0;  // rollbacks of every world the sender had seen (rollback_board.h)
  std::uint32_t rewinds = 0;  // rewinds the sender had taken (RunControl::rewind)

  MessageKind kind() const { return static_cast<MessageKind>(payload.index() + 1); }
};

/// "Ghosts(12) 3->5", for diagnostics.
std::string describe(const Message& message);

}  // namespace soda

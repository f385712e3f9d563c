// Internal: the transport of one PartitionedWorld over MPI ranks. A message
// to a world of this rank goes straight into the local transport (values
// or bytes, as without MPI); one to another rank's world is encoded
// (message_codec.h) by the sending world's thread and queued in the outbox.
// The communication loop (progress(), on the thread that initialised MPI:
// MPI_THREAD_FUNNELED) sends the outbox with MPI_Isend and takes arriving
// messages with MPI_Improbe/MPI_Mrecv, decodes them and hands them to the
// local transport, whose mailboxes the world threads read as before.
//
// Invariants:
//  1. Messages from one world to another arrive in the order sent: the
//     outbox is FIFO, Isends are posted in outbox order on one
//     communicator and tag, and MPI does not let them overtake.
//  2. Only progress() and the destructor call MPI (the caller's thread).
//  3. Every run's transport uses the group's one communicator for
//     traffic, never freed while the group lives (a freed context reused by
//     the next run's duplicate got an earlier run's leftover messages,
//     which stalled the next run's stream); each run has its own tags, so
//     nothing of another PartitionedWorld's traffic is taken as its own.
//  4. With speculation (share_rollbacks): every message between ranks has
//     the colour of its sender's GVT epoch in its tag (gvt_rounds.h). A
//     step pinned by a message (a rollback notice, a post of a rollback
//     of every world) stays pinned on the sending rank until the message
//     is posted and counted by the cut, and is pinned on the receiving rank
//     as it arrives, before any world can see it.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "gvt_rounds.h"
#include "mpi_handles.h"
#include "soda/rollback/commit_horizon.h"
#include "soda/rollback/rollback_board.h"
#include "soda/runtime/process_group.h"
#include "soda/runtime/transport.h"

namespace soda::mpi {

class MpiTransport final : public Transport {
 public:
  // Tags: kTagBase + kTagsPerRun * (run % kRuns) + 2 * kind + colour, and
  // + kTagFailure for a failed rank's error text. Each run (transport) has
  // its own: Open MPI reuses a freed communicator's context, so messages a
  // stopped run left on the wire could otherwise match the next run's
  // receives (seen: a GVT round counting one white message too many after
  // a failed run); a message of another run is dropped.
  static constexpr int kTagBase = 16;
  static constexpr int kTagsPerRun = 8;
  static constexpr int kTagFailure = 6;
  static constexpr int kRuns = 1024;  // kTagBase + 8 * 1024 < 32767, MPI's least tag upper bound
  enum Kind : int {
    kMessage = 0,  // a Message's bytes
    kRequest = 1,  // to rank 0: a post of a rollback of every world (step, pinned, ticket)
    kEntry = 2,    // from rank 0: a numbered rollback of every world (epoch, step, pinned, origin, ticket)
  };

  /// Over `comm` (the group's traffic communicator, outliving the
  /// transport). `rank_of_world`: by world id.
  /// `run`: how many transports the group made before this one (tags).
  MpiTransport(MPI_Comm comm, std::vector<int> rank_of_world, std::unique_ptr<Transport> local, std::uint64_t run);
  ~MpiTransport() override;

  // Transport: any thread.
  void send(WorldId to, Message message) override;
  std::optional<Message> try_receive(WorldId world) override { return local_->try_receive(world); }
  Message receive(WorldId world) override { return local_->receive(world); }
  bool park(WorldId world) override { return local_->park(world); }
  void set_wake_hook(std::function<void(WorldId)> hook) override { local_->set_wake_hook(std::move(hook)); }
  void close() override;
  // The messages this rank's worlds sent: the local transport also counts
  // those progress() hands it from other ranks (a serialising one their
  // bytes too, re-encoded to the same size), so they are taken out.
  std::uint64_t messages_sent() const override {
    return local_->messages_sent() - in_messages_.load() + out_messages_.load();
  }
  std::uint64_t bytes_sent() const override {
    const std::uint64_t local = local_->bytes_sent();
    return (local > 0 ? local - in_bytes_.load() : 0) + out_bytes_.load();
  }

  /// The communication loop's one round (MPI thread only): posts the
  /// outbox, completes finished sends, receives what has arrived. True if
  /// anything moved. A failure text from another rank closes the local
  /// transport and is kept (remote_failure()).
  bool progress();
  /// Nothing queued or being sent (MPI thread only).
  bool idle();
  /// Tells every other rank that this one failed (MPI thread only).
  void send_failure(const std::string& what);
  /// Waits up to `seconds` for the sends to complete (MPI thread only).
  void flush(double seconds);
  /// Sleeps until a send is queued or `micros` passed (MPI thread only).
  void wait_for_outbox(int micros);
  std::string remote_failure() const;
  void add_traffic(RankTraffic& t) const;

  /// Speculation over ranks (ProcessGroup::share_rollbacks): `horizon` and
  /// `board` (this rank's, outliving the transport) join the ranks' GVT
  /// rounds and rank 0's numbering of rollbacks of every world. Before any
  /// world runs; step()'s thread.
  void share_rollbacks(SharedMemoryHorizon& horizon, RollbackBoard& board);
  /// See GvtRounds::set_goal (MPI thread only).
  void set_horizon_goal(std::int64_t step) { rounds_.set_goal(step); }
  /// The GVT round's next move, a new GVT into the horizon; true if
  /// anything moved (MPI thread only). `failed`: see GvtRounds::poll.
  bool poll_horizon(bool failed);
  /// No speculation, or no GVT round under way and the goal reached.
  bool horizon_settled() const { return !horizon_ || rounds_.settled(); }
  /// GVT rounds completed.
  std::uint64_t horizon_rounds() const { return rounds_.rounds(); }

 private:
  struct Outgoing {
    int rank = 0;
    int kind = kMessage;
    std::vector<std::uint8_t> bytes;
    std::int64_t timestamp = 0;                // the step the message may change at the earliest
    std::optional<std::int64_t> pinned;        // released once posted (invariant 4)
  };

  void queue(Outgoing out);
  void arrived(int kind, int source, std::vector<std::uint8_t> bytes);
  // Rank 0: numbers a rollback of every world and sends it to every rank.
  void sequence(std::int64_t step, std::int64_t pinned, int origin, std::uint64_t ticket);

  MPI_Comm comm_;       // the group's, for every run (see the tags above)
  const int size_;
  const int tag_base_;  // this run's first tag
  const int rank_;
  const std::vector<int> rank_of_world_;
  std::unique_ptr<Transport> local_;
  mutable std::mutex mutex_;  // outbox_, failure_
  std::condition_variable queued_;
  std::deque<Outgoing> outbox_;
  std::string failure_;  // another rank's, first one
  std::deque<std::unique_ptr<PendingSend>> pending_;  // MPI thread only
  std::atomic<std::uint64_t> out_messages_{0}, out_bytes_{0}, in_messages_{0}, in_bytes_{0};
  GvtRounds rounds_;                          // MPI thread only
  SharedMemoryHorizon* horizon_ = nullptr;    // speculation only
  RollbackBoard* board_ = nullptr;            // speculation only
  std::mutex sequence_mutex_;                 // rank 0: one numbering, entries queued in epoch order
};

}  // namespace soda::mpi

// Internal: the commit horizon (GVT) over ranks, computed by Mattern's
// two-colour cut on non-blocking collectives (F. Mattern, "Efficient
// algorithms for distributed snapshots and global virtual time
// approximation", J. Parallel Distrib. Comput. 18, 1993), polled by the
// rank's communication loop; no rank ever waits for another in a barrier.
//
// Every message between ranks carries the colour of its sender's epoch
// (a bit of its tag). A round:
//  1. Cut C1 (each rank on its own): the rank's colour flips; messages sent
//     from now on have the new colour ("red"), and the minimum of their
//     timestamps is recorded. The per-destination counts of the old colour
//     ("white") are final: MPI_Ireduce_scatter_block sums them, giving each
//     rank the number of white messages sent to it.
//  2. Drain: the rank waits (polling) until it has received that many
//     white messages — every message sent before any rank's C1 is then in
//     its receiver's mailboxes and counted there (a world's mark, or a pin).
//  3. Cut C2: the rank's value is min(its local minimum now — its worlds'
//     marks and its pins —, the red messages' minimum timestamp);
//     MPI_Iallreduce MIN gives every rank the same GVT.
// Why it is a lower bound: a constraint lives in a world's mark, in a pin,
// or in a message in flight. White messages are all received by C2 (so in
// marks or pins read at C2); red ones sent before their sender's C2 are in
// the red minimum; anything sent after its sender's C2 is bounded by that
// sender's marks and pins read at C2 (a world never sends a message for a
// step below its own mark, and a notice or a rollback of every world is
// pinned before it is sent). Marks go below the horizon only to the
// checkpoint before a pinned step, as on one machine (commit_horizon.h).
// Every rank gets the same value from the same round, so every rank stops
// starting rounds after the same one (the value reached the run's goal, or
// a rank reported a failure in it): no collective is ever left pending
// (MPI_Finalize would progress it on a freed communicator).
//
// Thread safety: MPI thread only (MPI_THREAD_FUNNELED).
#pragma once

#include <mpi.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

namespace soda::mpi {

class GvtRounds {
 public:
  /// Over `comm` (the transport's communicator) of `ranks` ranks.
  GvtRounds(MPI_Comm comm, int ranks);
  GvtRounds(const GvtRounds&) = delete;
  GvtRounds& operator=(const GvtRounds&) = delete;

  /// The colour (0 or 1) of a message posted now.
  int colour() const { return colour_; }
  /// A message of colour() to `rank` was posted, for internal step
  /// `timestamp` (the step it may change at the earliest).
  void sent(int rank, std::int64_t timestamp);
  /// A message of `colour` arrived.
  void received(int colour) { ++received_[static_cast<std::size_t>(colour)]; }
  /// The run goes to internal step `goal`: rounds run until a GVT reaches it.
  void set_goal(std::int64_t goal) { goal_ = goal; }
  /// One look at the round under way (or starts one if due); the new GVT
  /// once a round ends. `local_minimum`: the rank's marks and pins, now.
  /// `failed`: this rank knows the run is stopping (its own failure or
  /// another rank's); rounds then run back to back until one carries it.
  std::optional<std::int64_t> poll(const std::function<std::int64_t()>& local_minimum, bool failed);
  /// No round under way, and the last GVT at or past the goal or a failure
  /// in the last round (every rank has seen the same: it may stop polling).
  bool settled() const { return stage_ == Stage::Idle && (gvt_ >= goal_ || failure_seen_); }
  /// Rounds completed so far.
  std::uint64_t rounds() const { return rounds_; }

 private:
  enum class Stage { Idle, Counting, Draining, Reducing };
  // The pace: a new round at most this often (each costs two collectives;
  // on 2 cores shared by 4 ranks a faster pace takes CPU from the worlds,
  // a slower one keeps speculating worlds at their anticipation longer).
  static constexpr std::chrono::microseconds kRoundInterval{300};

  bool test(MPI_Request& request);

  MPI_Comm comm_;
  int colour_ = 0;
  std::array<std::vector<int>, 2> sent_;   // per colour, per destination rank
  std::array<long long, 2> received_{};    // per colour
  std::int64_t red_min_ = INT64_MAX;       // red messages posted since C1
  Stage stage_ = Stage::Idle;
  int white_ = 0;                          // the colour being drained
  int expected_ = 0;                       // white messages sent to this rank
  std::vector<int> counts_;                // Ireduce_scatter_block's send buffer
  // Iallreduce MIN's buffers: {the rank's value, 0 or -1 if it failed}.
  std::array<std::int64_t, 2> value_{}, result_{};
  bool failure_seen_ = false;
  MPI_Request request_ = MPI_REQUEST_NULL;
  std::int64_t goal_ = INT64_MIN;
  std::int64_t gvt_ = INT64_MIN;
  std::uint64_t rounds_ = 0;
  std::chrono::steady_clock::time_point last_end_{};
};

}  // namespace soda::mpi

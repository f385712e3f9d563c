// runtime/ — the processes (ranks) one partitioned run is spread over. A
// run without a ProcessGroup is one process stepping every world; with one,
// every rank builds the same PartitionedWorld from the same scene and map,
// steps only the worlds rank_of() gives it, and the messages between worlds
// of different ranks go through the group. The MPI group is in mpi/
// (soda/mpi/mpi_group.h, docs/mpi.md); the runtime itself never links MPI.
//
// Thread safety: rank(), size(), rank_of(), report_failure() and
// remote_failure() from any thread; make_transport(), pump() and gather()
// only from the thread that runs PartitionedWorld::step() (with MPI: the
// thread that initialised MPI, MPI_THREAD_FUNNELED).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/runtime/transport.h"

namespace soda {

class SharedMemoryHorizon;
class RollbackBoard;

/// Traffic between this rank and the others, since the group was made.
struct RankTraffic {
  int rank = 0;
  int worlds = 0;                      // worlds this rank steps (last run)
  std::uint64_t messages = 0;          // every message this rank's worlds sent, same-rank ones included
  std::uint64_t bytes = 0;             // ... their bytes (same-rank ones: only when serialised)
  std::uint64_t messages_out = 0;      // messages to worlds of other ranks
  std::uint64_t bytes_out = 0;         // their encoded bytes (message_codec.h)
  std::uint64_t messages_in = 0;       // messages from worlds of other ranks
  std::uint64_t bytes_in = 0;
  double pump_seconds = 0;             // wall time in pump() (the communication loop)
  double pump_idle_seconds = 0;        // ... of which sleeping with nothing to move
  double blocked_seconds = 0;          // this rank's worlds waiting for messages (WorldMetrics::blocked_seconds)
  double cpu_seconds = 0;              // this rank's worlds' CPU time stepping
  std::uint64_t gvt_rounds = 0;        // commit-horizon rounds completed (speculation; docs/mpi.md)
  std::uint64_t bullet_objects = 0;    // Bullet objects in all the worlds this rank built, at the end
  std::uint64_t peak_rss_bytes = 0;    // this process's peak resident memory (getrusage), at the end
};

class ProcessGroup {
 public:
  virtual ~ProcessGroup() = default;
  /// This process's rank, in [0, size()).
  virtual int rank() const = 0;
  virtual int size() const = 0;
  /// The rank that steps world `world` of `worlds`; the same answer on
  /// every rank. Throws std::invalid_argument if the group's mapping does
  /// not fit `worlds` (a --ranks-worlds list of another length, a rank out
  /// of range).
  virtual int rank_of(WorldId world, int worlds) const = 0;
  /// The transport of one PartitionedWorld of `worlds` worlds: a message to
  /// a world of this rank goes into `local`; to another rank's world, over
  /// the group (encoded, message_codec.h). Replaces the transport of any
  /// earlier call (one PartitionedWorld per group at a time).
  virtual std::unique_ptr<Transport> make_transport(int worlds, std::unique_ptr<Transport> local) = 0;
  /// Speculation over ranks (docs/mpi.md): the group computes the commit
  /// horizon across ranks into `horizon` (SharedMemoryHorizon::set_global,
  /// polled by pump()), carries the pins of rollback notices with them and
  /// spreads `board` over the ranks (RollbackBoard::distribute). For the
  /// PartitionedWorld of the last make_transport(); both outlive its
  /// transport. Before any world runs.
  virtual void share_rollbacks(SharedMemoryHorizon& horizon, RollbackBoard& board) = 0;
  /// Speculation over ranks: the internal step the next pump() runs to;
  /// pump() returns only once the ranks' horizon has reached it (every
  /// rank stops computing it after the same round).
  virtual void set_horizon_goal(std::int64_t step) = 0;
  /// Moves messages between this rank and the others, on the calling
  /// thread, while this rank's worlds run on threads of their own; returns
  /// once `done()` is true (this rank's worlds have finished) and every
  /// message they sent has been handed to the group, or at once when
  /// another rank has failed (then the local transport is closed, so this
  /// rank's worlds stop too).
  virtual void pump(const std::function<bool()>& done) = 0;
  /// A world of this rank failed: the next pump() tells every other rank
  /// (their worlds stop, and remote_failure() names this rank and `what`).
  virtual void report_failure(const std::string& what) = 0;
  /// "rank R failed: ..." for the first failure reported by another rank;
  /// empty if none.
  virtual std::string remote_failure() const = 0;
  /// Collective (every rank calls it, in the same order): rank 0 gets every
  /// rank's bytes, by rank; the other ranks get an empty vector.
  virtual std::vector<std::vector<std::uint8_t>> gather(const std::vector<std::uint8_t>& mine) = 0;
  /// Collective: every rank gets every rank's bytes, by rank.
  virtual std::vector<std::vector<std::uint8_t>> all_gather(const std::vector<std::uint8_t>& mine) = 0;
  /// Messages and bytes this rank exchanged with the others, and pump time.
  virtual RankTraffic traffic() const = 0;
};

}  // namespace soda

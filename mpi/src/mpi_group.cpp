// The ranks of MPI_COMM_WORLD as a ProcessGroup: the world -> rank mapping,
// the transport of each PartitionedWorld (mpi_transport.h), the
// communication loop and the gathers to rank 0.
#include "soda/mpi/mpi_group.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <thread>
#include <mutex>
#include <stdexcept>

#include "mpi_handles.h"
#include "mpi_transport.h"

namespace soda {
namespace {

// The loop's pace when nothing moves: yield this many rounds (a reply is
// often microseconds away), then sleep on the outbox up to kIdleMicros
// (what an arriving message may wait; on 2 cores shared by 4 ranks a
// spinning loop would take the CPU from the worlds it waits for).
constexpr int kYieldRounds = 64;
constexpr int kIdleMicros = 100;
// A failed rank waits this long for its failure text to leave.
constexpr double kFailureFlushSeconds = 2.0;

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// The receive side of a gather: each rank's bytes at its offset in `all`.
struct Layout {
  std::vector<int> offsets;
  std::vector<std::uint8_t> all;
  explicit Layout(const std::vector<int>& counts) : offsets(counts.size()) {
    long long total = 0;
    for (std::size_t r = 0; r < counts.size(); ++r) {
      offsets[r] = static_cast<int>(total);
      total += counts[r];
    }
    if (total > INT_MAX) throw std::length_error("MpiGroup: more than 2 GiB to gather");
    all.resize(static_cast<std::size_t>(total));
  }
  std::vector<std::vector<std::uint8_t>> split(const std::vector<int>& counts) const {
    std::vector<std::vector<std::uint8_t>> out;
    for (std::size_t r = 0; r < counts.size(); ++r)
      out.emplace_back(all.begin() + offsets[r], all.begin() + offsets[r] + counts[r]);
    return out;
  }
};

class MpiGroup final : public ProcessGroup {
 public:
  explicit MpiGroup(std::vector<int> rank_of_world)
      : comm_(MPI_COMM_WORLD), traffic_(MPI_COMM_WORLD), explicit_(std::move(rank_of_world)) {
    rank_ = comm_.rank();
    size_ = comm_.size();
  }

  int rank() const override { return rank_; }
  int size() const override { return size_; }

  int rank_of(WorldId world, int worlds) const override {
    if (world < 0 || world >= worlds) throw std::out_of_range("MpiGroup: no world " + std::to_string(world));
    if (explicit_.empty()) return world % size_;
    if (static_cast<int>(explicit_.size()) != worlds)
      throw std::invalid_argument("--ranks-worlds names the rank of " + std::to_string(explicit_.size()) +
                                  " worlds; the run has " + std::to_string(worlds) + " territories");
    const int r = explicit_[static_cast<std::size_t>(world)];
    if (r < 0 || r >= size_)
      throw std::invalid_argument("--ranks-worlds: world " + std::to_string(world) + " on rank " +
                                  std::to_string(r) + ", but the job has ranks 0.." + std::to_string(size_ - 1));
    return r;
  }

  std::unique_ptr<Transport> make_transport(int worlds, std::unique_ptr<Transport> local) override {
    std::vector<int> ranks;
    for (WorldId w = 0; w < worlds; ++w) ranks.push_back(rank_of(w, worlds));
    // Collective, as the communicator duplicate it replaces: no rank sends
    // this run's messages while another still pumps the last run's (whose
    // transport would drop them as another run's).
    mpi::check(MPI_Barrier(traffic_.get()), "MPI_Barrier");
    auto t = std::make_unique<mpi::MpiTransport>(traffic_.get(), std::move(ranks), std::move(local), runs_++);
    transport_ = t.get();
    {
      std::lock_guard lock(mutex_);
      failure_.clear();  // an earlier run's (its worlds stopped): this run starts clean
    }
    return t;
  }

  void share_rollbacks(SharedMemoryHorizon& horizon, RollbackBoard& board) override {
    if (!transport_) throw std::logic_error("MpiGroup::share_rollbacks before make_transport");
    transport_->share_rollbacks(horizon, board);
  }

  void set_horizon_goal(std::int64_t step) override {
    if (!transport_) throw std::logic_error("MpiGroup::set_horizon_goal before make_transport");
    transport_->set_horizon_goal(step);
  }

  void pump(const std::function<bool()>& done) override {
    if (!transport_) throw std::logic_error("MpiGroup::pump before make_transport");
    const auto start = std::chrono::steady_clock::now();
    int quiet = 0;
    bool told = false;
    for (;;) {
      const bool moved = transport_->progress();
      std::string mine;
      {
        std::lock_guard lock(mutex_);
        mine = failure_;
      }
      const bool remote = !transport_->remote_failure().empty();
      // With speculation a stopping run still ends its GVT rounds together
      // (gvt_rounds.h): no rank leaves a collective pending.
      // (A round's progress does not count as moved: the loop may still
      // sleep its kIdleMicros between polls, well under a round's pace.)
      transport_->poll_horizon(remote || !mine.empty());
      if (remote && transport_->horizon_settled()) break;
      if (!mine.empty() && !told && !remote) {  // (after another rank's, only its echo: not sent)
        transport_->send_failure(mine);
        transport_->flush(kFailureFlushSeconds);
        told = true;
      }
      if (done() && transport_->horizon_settled() && (told || transport_->idle())) break;
      if (moved) {
        quiet = 0;
        continue;
      }
      if (++quiet < kYieldRounds) {
        std::this_thread::yield();
        continue;
      }
      const auto idle = std::chrono::steady_clock::now();
      transport_->wait_for_outbox(kIdleMicros);
      idle_seconds_ += seconds_since(idle);
    }
    pump_seconds_ += seconds_since(start);
  }

  void report_failure(const std::string& what) override {
    std::lock_guard lock(mutex_);
    if (failure_.empty()) failure_ = what;
  }

  std::string remote_failure() const override { return transport_ ? transport_->remote_failure() : std::string(); }

  std::vector<std::vector<std::uint8_t>> gather(const std::vector<std::uint8_t>& mine) override {
    if (mine.size() > static_cast<std::size_t>(INT_MAX)) throw std::length_error("MpiGroup::gather: too many bytes");
    const int count = static_cast<int>(mine.size());
    std::vector<int> counts(rank_ == 0 ? static_cast<std::size_t>(size_) : 0);
    mpi::check(MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm_.get()), "MPI_Gather");
    Layout l(counts);
    mpi::check(MPI_Gatherv(mine.data(), count, MPI_BYTE, l.all.data(), counts.data(), l.offsets.data(), MPI_BYTE, 0,
                           comm_.get()),
               "MPI_Gatherv");
    return l.split(counts);
  }

  std::vector<std::vector<std::uint8_t>> all_gather(const std::vector<std::uint8_t>& mine) override {
    if (mine.size() > static_cast<std::size_t>(INT_MAX)) throw std::length_error("MpiGroup::all_gather: too many bytes");
    const int count = static_cast<int>(mine.size());
    std::vector<int> counts(static_cast<std::size_t>(size_));
    mpi::check(MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, comm_.get()), "MPI_Allgather");
    Layout l(counts);
    mpi::check(MPI_Allgatherv(mine.data(), count, MPI_BYTE, l.all.data(), counts.data(), l.offsets.data(), MPI_BYTE,
                              comm_.get()),
               "MPI_Allgatherv");
    return l.split(counts);
  }

  RankTraffic traffic() const override {
    RankTraffic t;
    t.rank = rank_;
    if (transport_) transport_->add_traffic(t);
    t.pump_seconds = pump_seconds_;
    t.pump_idle_seconds = idle_seconds_;
    return t;
  }

 private:
  mpi::Communicator comm_;     // gathers
  mpi::Communicator traffic_;  // every run's messages and GVT rounds (mpi_transport.h, invariant 3)
  int rank_ = 0;
  int size_ = 1;
  const std::vector<int> explicit_;
  std::uint64_t runs_ = 0;                  // transports made (each run's tags: mpi_transport.h)
  mpi::MpiTransport* transport_ = nullptr;  // owned by the PartitionedWorld's internals
  mutable std::mutex mutex_;
  std::string failure_;  // this rank's first failure
  double pump_seconds_ = 0, idle_seconds_ = 0;
};

}  // namespace

std::shared_ptr<ProcessGroup> make_mpi_group(std::vector<int> rank_of_world) {
  int initialised = 0;
  MPI_Initialized(&initialised);
  if (!initialised) throw std::logic_error("make_mpi_group: MPI is not initialised (make a soda::MpiSession first)");
  return std::make_shared<MpiGroup>(std::move(rank_of_world));
}

std::vector<int> parse_ranks_worlds(const std::string& list) {
  std::vector<int> out;
  std::size_t at = 0;
  while (at <= list.size()) {
    const std::size_t comma = std::min(list.find(',', at), list.size());
    const std::string item = list.substr(at, comma - at);
    std::size_t used = 0;
    int v = -1;
    try {
      v = std::stoi(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (item.empty() || used != item.size() || v < 0)
      throw std::invalid_argument("--ranks-worlds: item " + std::to_string(out.size()) + " ('" + item +
                                  "') is not a rank (a list like 0,1,1,0: the rank of each world, by world id)");
    out.push_back(v);
    at = comma + 1;
  }
  return out;
}

}  // namespace soda

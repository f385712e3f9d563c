#include "gvt_rounds.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "mpi_handles.h"

namespace soda::mpi {

GvtRounds::GvtRounds(MPI_Comm comm, int ranks) : comm_(comm) {
  for (auto& s : sent_) s.assign(static_cast<std::size_t>(ranks), 0);
}

void GvtRounds::sent(int rank, std::int64_t timestamp) {
  ++sent_[static_cast<std::size_t>(colour_)][static_cast<std::size_t>(rank)];
  if (stage_ != Stage::Idle) red_min_ = std::min(red_min_, timestamp);
}

bool GvtRounds::test(MPI_Request& request) {
  int flag = 0;
  check(MPI_Test(&request, &flag, MPI_STATUS_IGNORE), "MPI_Test (GVT round)");
  return flag != 0;
}

std::optional<std::int64_t> GvtRounds::poll(const std::function<std::int64_t()>& local_minimum, bool failed) {
  switch (stage_) {
    case Stage::Idle: {
      if (settled()) return std::nullopt;
      if (!failed && std::chrono::steady_clock::now() - last_end_ < kRoundInterval) return std::nullopt;
      // C1: from now on this rank's messages are red.
      white_ = colour_;
      colour_ ^= 1;
      red_min_ = INT64_MAX;
      counts_ = sent_[static_cast<std::size_t>(white_)];
      check(MPI_Ireduce_scatter_block(counts_.data(), &expected_, 1, MPI_INT, MPI_SUM, comm_, &request_),
            "MPI_Ireduce_scatter_block");
      stage_ = Stage::Counting;
      return std::nullopt;
    }
    case Stage::Counting:
      if (!test(request_)) return std::nullopt;
      stage_ = Stage::Draining;
      [[fallthrough]];
    case Stage::Draining: {
      const long long got = received_[static_cast<std::size_t>(white_)];
      if (got < expected_) return std::nullopt;
      if (got > expected_)
        throw std::logic_error("GVT round: " + std::to_string(got) + " white messages arrived, " +
                               std::to_string(expected_) + " were sent");
      // C2. No rank can send a message of the white colour again before
      // this round has ended everywhere (the next C1 follows the Iallreduce,
      // which needs this rank's value): its counts start again from zero.
      received_[static_cast<std::size_t>(white_)] = 0;
      std::fill(sent_[static_cast<std::size_t>(white_)].begin(), sent_[static_cast<std::size_t>(white_)].end(), 0);
      value_ = {std::min(local_minimum(), red_min_), failed ? -1 : 0};
      check(MPI_Iallreduce(value_.data(), result_.data(), 2, MPI_INT64_T, MPI_MIN, comm_, &request_),
            "MPI_Iallreduce");
      stage_ = Stage::Reducing;
      return std::nullopt;
    }
    case Stage::Reducing:
      if (!test(request_)) return std::nullopt;
      stage_ = Stage::Idle;
      last_end_ = std::chrono::steady_clock::now();
      gvt_ = result_[0];
      failure_seen_ = result_[1] < 0;
      ++rounds_;
      return gvt_;
  }
  return std::nullopt;
}

}  // namespace soda::mpi

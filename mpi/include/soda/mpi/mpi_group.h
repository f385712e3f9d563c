// mpi/ — the ranks of an MPI job as a soda::ProcessGroup
// (soda/runtime/process_group.h; docs/mpi.md): put it in
// PartitionedOptions::group or RunConfig::group and every rank, running
// the same program with the same scene and options, steps its share of the
// worlds. Messages between ranks: the message codec's bytes through
// MPI_Isend and MPI_Improbe/MPI_Mrecv, on the thread that runs step().
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "soda/runtime/process_group.h"

namespace soda {

/// The ranks of MPI_COMM_WORLD (an MpiSession must be alive, and outlive
/// the group). `rank_of_world`: the rank stepping each world, by world id
/// (`--ranks-worlds`); empty: round-robin, world w on rank w mod size. A
/// list of the wrong length or with a rank outside [0, size) is refused
/// (std::invalid_argument) when a PartitionedWorld is built with it.
/// Collective: every rank makes its group at the same point.
std::shared_ptr<ProcessGroup> make_mpi_group(std::vector<int> rank_of_world = {});

/// "0,1,1,0" -> {0, 1, 1, 0}; throws std::invalid_argument naming the bad
/// item (`--ranks-worlds`).
std::vector<int> parse_ranks_worlds(const std::string& list);

}  // namespace soda

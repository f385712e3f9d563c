// worlds/ — one world's part of a snapshot as bytes: how the worlds of
// several processes put their parts together into the whole scene's
// snapshot (PartitionedWorld::snapshot() over MPI ranks, docs/mpi.md).
#pragma once

#include <cstdint>
#include <vector>

#include "soda/worlds/world_snapshot.h"

namespace soda {

/// Inverse of serialize() for one world's part (TerritoryWorld::part_snapshot):
/// as deserialize_snapshot, except that its manifolds and joints may name
/// bodies the part does not hold (ghosts, other worlds' bodies, statics)
/// and that it may hold one pair twice (live and kept: manifolds in
/// non-decreasing (id0, id1) order). Throws SnapshotFormatError as
/// deserialize_snapshot does.
WorldSnapshot deserialize_part_snapshot(const std::vector<std::uint8_t>& bytes);

}  // namespace soda

// Internal: the per-body and per-pair stages of a canonical world's step on
// the solver pool's threads (docs/coloured-solve.md, "The rest of the step
// on the pool"). Beside the coloured sweeps (coloured_solver.h), the stages
// of Bullet's step that are loops over independent items:
//
//   predictUnconstraintMotion   per dynamic body: damping, predicted transform
//   updateAabbs                 per object: the AABB (computed in parallel;
//                               the broadphase updated on the stepping
//                               thread, in Bullet's object order)
//   dispatchAllCollisionPairs   per broadphase pair: box-box narrowphase
//                               (each pair writes only its own manifold)
//   integrateTransforms         per dynamic body
//
// Invariants (why the bits cannot change):
//  1. an item's work reads shared state that no item of the same stage
//     writes, and writes only its own item (its body, its AABB slot, its
//     pair's manifold), so the result is the same in any order, on any
//     number of threads: the serial loop is one of those orders;
//  2. everything that is not per item stays on the stepping thread, in
//     Bullet's order: broadphase updates (the dbvt), creating collision
//     algorithms and manifolds (the dispatcher's pools and manifold array),
//     pairs whose algorithm is not box-box (other algorithms may create or
//     release manifolds while they collide);
//  3. a stage runs in parallel only above a size (kParallelMinBodies,
//     kParallelMinPairs) and only on the pool's threads; below it, without
//     a pool, or when the pool is busy, the same loop runs on the stepping
//     thread.
#pragma once

#include <functional>

namespace soda {

class SolverPool;

/// Dynamic bodies (or collision objects) from which a per-body stage is
/// shared on the pool: a body's stage is ~100-300 instructions, so below
/// this a pool job (a wake-up of microseconds) costs more than it gains.
constexpr int kParallelMinBodies = 512;
/// Bodies per pool task of a per-body stage.
constexpr int kBodiesPerTask = 128;
/// Box-box pairs from which the narrowphase is shared on the pool (a pair
/// is ~2,000-6,000 instructions of btBoxBoxDetector).
constexpr int kParallelMinPairs = 128;
/// Pairs per pool task: a few microseconds of work per claim.
constexpr int kPairsPerTask = 16;
/// Small islands (Bullet's own loop, one thread each) solved side by side on
/// the pool from this many in a step, so many per task (CanonicalDynamicsWorld::
/// solve_islands). Results never depend on them.
constexpr int kParallelMinIslands = 16;
constexpr int kIslandsPerTask = 4;

/// Runs fn(begin, end) over [0, count) cut into chunks of `chunk` items: on
/// the pool's threads when pool is not null and count >= min_count, else as
/// one fn(0, count) on the calling thread. fn must give the same result in
/// any order of its chunks (invariant 1). Returns the number of threads that
/// could take chunks (1 when it ran on the calling thread alone).
int run_in_chunks(SolverPool* pool, int count, int min_count, int chunk,
                  const std::function<void(int, int)>& fn);

}  // namespace soda

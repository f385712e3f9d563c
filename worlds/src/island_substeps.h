// Internal: substeps per island (docs/stress.md "The solver defaults"). An
// island whose touching bodies move fast against their size in one step
// (IslandProfile::approach_rate), or whose joints hang a tall or
// heavy-loaded chain (IslandProfile::joint_height, joint_mass_ratio;
// island_substeps) is solved and integrated
// as `substeps` steps of h / substeps inside the solve stage, its own
// manifolds' narrowphase run again between them; every other island is
// solved once with h, as before. Shared by every world that solves an
// island (canonical_dynamics_world.cpp, territory_islands.cpp: local and
// border islands alike), so that an island is stepped the same way in any
// of them: N territories still equal one (DESIGN.md §2).
//
// The step's stages around the solve stay whole-step: damping (predict)
// was applied with h, the integrate stage integrates every body with h.
// So the island's last substep leaves each body *rewound*: at the pose it
// reached after substeps - 1 substeps moved back along its final velocity
// by h - h / substeps, so that the integrate stage's h lands it where the
// last substep ends. Its interpolation transform and velocities are given
// back as they were (the owner of a border island's body keeps its own).
//
// Thread safety: touches only the island's bodies and manifolds, and the
// dispatcher's algorithm pool (the calling world's thread). Between
// substeps, the manifolds' refresh and the bodies' integration are per item
// (a manifold's refresh reads the bodies' transforms, which no refresh
// writes, and writes only its own points; a body's integration writes only
// that body): above parallel_stages.h's sizes they are shared on the
// solver pool, in any order on any number of threads, with the same bits
// (parallel_stages.h, invariant 1).
#pragma once

#include <btBulletDynamicsCommon.h>

namespace soda {

class SolverPool;

/// Solves one awake island with `info` (its own settings, time step h =
/// info.m_timeStep). substeps == 1: one solveGroup call, as ever. Above:
/// `substeps` solveGroup calls with h / substeps; between them every body
/// is integrated by h / substeps and every manifold's points refreshed by
/// the pair's narrowphase at the new transforms (Bullet's default dispatcher
/// info, the same in every world) (a manifold's speculative
/// point, docs/ccd.md, is dropped first: it held for the first substep).
/// Manifolds of pairs the island does not hold (without points at the
/// step's start) are not looked at: no contact is created mid-step (tried
/// in the canonical world: the dense pile's figure did not change). Only
/// box-box manifolds can be refreshed (island_substeps() asks
/// IslandProfile::boxes_only): Bullet's algorithms built on a shared
/// manifold ignore it (box-box, sphere-box, sphere-sphere, convex-plane
/// make their own), so btBoxBoxDetector is run here directly. `pool`
/// (null: the calling thread alone) shares the refresh and the integration
/// between substeps; the solveGroup calls use whatever pool the solver has.
/// Returns the most threads that work between substeps could use (0: one
/// substep, nothing between). `constraints` (the island's joints, in joint
/// id order) go to every solveGroup call. Each substep solves with
/// info.m_numIterations (island_solver_info has split them); substeps
/// after the first warm-start with factor 1: their impulses come from the
/// substep before, of the same length, not from a step ago.
int solve_island(btConstraintSolver& solver, btCollisionObject** bodies, int body_count,
                 btPersistentManifold** manifolds, int manifold_count, const btContactSolverInfo& info,
                 int substeps, btDispatcher& dispatcher, SolverPool* pool = nullptr,
                 btTypedConstraint** constraints = nullptr, int constraint_count = 0);

}  // namespace soda

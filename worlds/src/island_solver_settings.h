// Internal: the solver settings of the canonical step — the defaults every
// exact world (CanonicalWorld, TerritoryWorld) starts from, and the settings
// chosen per island from the island's contents alone. One place, shared by
// every solveGroup call of an island (canonical_dynamics_world.cpp,
// territory_islands.cpp), so that an island is solved the same way whichever
// world holds it: N territories still equal one (DESIGN.md §2).
//
// Why these settings (measured, docs/stress.md "Why each case fails at the
// defaults"):
//  - two friction directions per contact point, fixed by the contact normal
//    (btPlaneSpace1) and cached in the manifold point: Bullet's default is
//    one friction row along the slip velocity, so a resting stack has no
//    friction across it and its boxes creep sideways; awake, a 10-box tower
//    explodes within a minute (9 km) at any iteration count tried. With the
//    fixed pair it stands (5.5 cm).
//  - iterations grow with the island's stack height and mass ratio
//    (island_iterations): sequential impulses carry a load down a chain of
//    contacts one link per iteration, so tall stacks and heavy-on-light
//    pairs need more of them. Islands lower than kPlainHeight with equal
//    masses keep the scene's iterations (piles of cubes cost the same).
#pragma once

#include <btBulletDynamicsCommon.h>

#include "soda/scene/scene.h"

namespace soda {

/// Islands whose stack height (island_height) is at most this keep the
/// scene's iterations: a 10-box tower stands at 10 iterations (measured).
constexpr int kPlainHeight = 10;
/// Above kPlainHeight, iterations = scene's x (height / kPlainHeight) ^
/// kHeightPower, which starts at x1 where the plain islands end: 11 boxes ->
/// x1.27, 12 -> x1.58, 20 -> x5.7, 30 -> x15.6, 50 -> x56 (capped at
/// kMaxIterationFactor). Every tower and pyramid of the stress suite stands
/// with it in float and double (largest move, float / double: tower-20
/// 0.041 / 0.071 m, tower-30 0.074 / 0.044 m, tower-50 0.065 / 0.096 m;
/// limit 0.1 m; docs/stress.md). With power 2 tower-50 (x25) leaned 0.15 m
/// in float; with 2.3 tower-30 0.089 m. The law before, (height / 6)^2,
/// jumped from x1 to x3.4 at 11: a heap or pile of ten layers is 10 to 13
/// contacts high, and the jump was 44 % (heap 4000) and 67 % (cube-pile
/// 4000) of their row iterations (docs/results/where-the-time-goes.md).
constexpr double kHeightPower = 2.5;
/// Mass ratios above this keep the scene's iterations only if the height
/// allows: 1:10 stands at 10 iterations (measured).
constexpr double kPlainMassRatio = 10.0;
/// Above kPlainMassRatio, iterations = scene's x sqrt(ratio) (1:100 -> x10,
/// 1:1000 -> x31.6; 1:1000 stands from x15 up, 1:100 from x2).
/// Upper bound of either factor: the cost of one island stays bounded.
constexpr double kMaxIterationFactor = 40.0;
/// A *stiff* island is both taller than kPlainHeight and heavier-on-lighter
/// than kPlainMassRatio (a heavy box on a tower: heavy-drop-10). Its impact
/// must travel height links with the mass ratio against it, so its factor
/// is sqrt(ratio) x height (heavy-drop-10: 10 x 11 -> capped at 100, i.e.
/// 1000 iterations; 500 let a tower box slide 0.22 m, 700 0.09 m, 1000
/// 0.05 m, measured with the stiff split impulse below).
constexpr double kMaxStiffFactor = 100.0;
/// kMaxStiffFactor only for islands of at most this many bodies (cost of a
/// small island at 1000 iterations: tens of microseconds); larger stiff
/// islands keep kMaxIterationFactor.
constexpr int kSmallStiffIsland = 32;
/// The warm-starting factor of islands taller than kPlainHeight. Bullet's
/// 0.85 drops 15 % of every contact's impulse each step, which the
/// iterations must carry down the stack again: a 50-box tower lost its top
/// box, 0.17 m at 400 iterations; with 1 it stands (0.065 m). Lower islands
/// keep Bullet's 0.85: with 1 for every island card-house-5 (planks on
/// their 0.1 m edge, height 10) collapsed (5.7 m).
constexpr btScalar kTallWarmStartingFactor = 1;

/// An island of boxes whose touching bodies may close more than this
/// fraction of the smaller one's inner radius in a step
/// (IslandProfile::approach_rate x h) is solved in kIslandSubsteps substeps
/// (island_substeps.h). dense-pile-1000 (docs/stress.md), max penetration,
/// float: 0.188 m with none; 0.113 m with every box island substepped;
/// 0.117 m from 0.02, 0.120 m from 0.05, 0.121 m from 0.1; 0.144 m if
/// only islands taller than kPlainHeight are (the deep points come in low
/// islands). Resting islands stay below it (they move ~0 per step).
constexpr double kSubstepApproach = 0.05;
/// Substeps of such an island: 2 passes the dense pile; 3 gave 0.141 m
/// with the 0.1 threshold (no better), and each one costs a solve. The
/// island's iterations are split between its substeps (each solves
/// ceil(iterations / kIslandSubsteps), at least kMinSubstepIterations), and
/// the second substep warm-starts in full from the first
/// (island_substeps.h): substepping costs a second setup and narrowphase,
/// not a second solve, and every stress case passes in float and double
/// (docs/stress.md, "The solver defaults"). Joint substeps (below) keep the
/// whole iterations in each: split, hanging-chain-100 stretched 9.9 % of a
/// link.
constexpr int kIslandSubsteps = 2;
/// The fewest iterations of a split substep: card-house-5 (planks on their
/// 0.1 m edge, substepped as they settle) fell in double precision with 5
/// per substep (7.5 m) and stands with 6, 7 and 8 in both precisions (6:
/// 0.060 m double, 0.046 m float). The planks are close to tipping, so the
/// verdict is partly chance (with 15 per substep: 0.11 m in double, FAIL).
constexpr int kMinSubstepIterations = 6;

/// An island whose joints hang a chain of more than this many dynamic
/// bodies from a static one (IslandProfile::joint_height), or join two
/// bodies whose masses differ by more than kJointSubstepMassRatio, is
/// solved in kJointSubsteps substeps (island_substeps.h). In whole steps
/// of 1/60 s such a chain stretches whatever the iterations (the
/// hanging-chain-100 stress case: 195 % of a link at 10 iterations, 242 %
/// at 100; 11 % at 2 substeps, 2.8 % at 4; docs/stress.md, "Joint cases").
constexpr int kJointSubstepHeight = kPlainHeight;
constexpr double kJointSubstepMassRatio = 10.0;
constexpr int kJointSubsteps = 4;

/// Sets the canonical defaults on a world's solver info: scene iterations,
/// two fixed, cached friction directions. Called once when a world is built.
void configure_canonical_solver(btContactSolverInfo& info, const SceneSettings& settings);

/// Undoes configure_canonical_solver: Bullet's friction (one row along the
/// slip velocity) with the scene's iterations (SolverDefaults::Bullet).
void configure_bullet_solver(btContactSolverInfo& info, const SceneSettings& settings);

/// What island_iterations reads from an island: a pure function of its
/// bodies and manifolds (the same in every world that solves it).
struct IslandProfile {
  int height = 0;          // longest chain of touching dynamic bodies from a static one (1: rests on one)
  double mass_ratio = 1;   // largest m_a / m_b over touching dynamic pairs (>= 1)
  int bodies = 0;          // dynamic bodies in the island
  /// Largest relative motion of two touching dynamic bodies against their
  /// size, 1/s: (|v_a - v_b| + |w_a| r_a + |w_b| r_b) / min(r_a, r_b), r the
  /// body's sweep radius (inner radius of its shape). Times h: the fraction
  /// of the smaller body's inner radius the pair may close in one step.
  double approach_rate = 0;
  /// Every manifold with points is between two boxes (statics included):
  /// the pairs island_substeps.h can refresh between substeps.
  bool boxes_only = true;
  /// Longest chain of enabled joints from a static or kinematic body, in
  /// dynamic bodies (0: no joint reaches a static one).
  int joint_height = 0;
  /// Largest m_a / m_b over the enabled joints between dynamic bodies (>= 1).
  double joint_mass_ratio = 1;
  /// Tall and heavy-on-light (see kMaxStiffFactor).
  bool stiff() const { return height > kPlainHeight && mass_ratio > kPlainMassRatio; }
};

/// Reads the island's profile. `bodies` are the island's dynamic bodies,
/// `manifolds` its manifolds (any order; those without points are ignored),
/// `joints` its joints (any order; broken ones are ignored).
/// Uses the bodies' companion ids as scratch and leaves them at -1.
IslandProfile profile_island(btCollisionObject* const* bodies, int body_count,
                             btPersistentManifold* const* manifolds, int manifold_count,
                             btTypedConstraint* const* joints = nullptr, int joint_count = 0);

/// The iterations of an island of this profile, from the scene's `base`.
int island_iterations(int base, const IslandProfile& profile);

/// The substeps of an island of this profile with step h (island_substeps.h).
int island_substeps(const IslandProfile& profile, double h);

/// The iterations of each substep when an island of this profile is solved
/// in `substeps` substeps of its `iterations`: split for the contact rule
/// (kIslandSubsteps), whole for the joint rule (kJointSubsteps).
int substep_iterations(int iterations, int substeps, const IslandProfile& profile);

/// The solver info to solve one island with: `base` itself when nothing
/// differs, else `scratch` (a copy of base with the island's iterations;
/// an island taller than kPlainHeight warm-starts with
/// kTallWarmStartingFactor;
/// a stiff island also recovers every penetration by split impulse,
/// split-impulse threshold 0, so no position error enters its velocities:
/// heavy-drop-10 with Bullet's -0.04 m threw tower boxes 24 m at 340
/// iterations and slid them 0.14 m at 1000).
/// `substeps` gets island_substeps(profile, base.m_timeStep); the info
/// returned then holds the iterations of each substep (substep_iterations).
const btContactSolverInfo& island_solver_info(const btContactSolverInfo& base, btContactSolverInfo& scratch,
                                              btCollisionObject* const* bodies, int body_count,
                                              btPersistentManifold* const* manifolds, int manifold_count,
                                              btTypedConstraint* const* joints, int joint_count, int& substeps);

}  // namespace soda

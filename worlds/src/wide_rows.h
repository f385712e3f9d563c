// Internal: the coloured solve's contact and friction sweeps eight runs at
// a time, one run per lane (docs/coloured-solve.md, "Wide rows").
//
// Inside a colour no two runs share a dynamic body (coloured_solver.h), so
// eight runs may be solved at once: lane l of every vector belongs to run l
// of a group of eight consecutive runs of the colour, and a run's rows are
// still solved one after another, in pool order. Every lane computes what
// Bullet's row functions compute for its row — those the libBulletDynamics
// of this project's Debian package runs: gResolveSingleConstraintRow
// {LowerLimit,Generic}_scalar_reference (it is built without USE_SIMD) —
// operation for operation in the same order: a dot product as
// (x·x' + y·y') + z·z', the impulse as (rhs - applied·cfm) - d₁·J - d₂·J,
// the limits by the same comparisons (lower first, then sum > upper), the
// body's velocity change as ((n ∘ m⁻¹)·Δ) ∘ linear factor and
// a ∘ (Δ · angular factor), only for a body with an original body, and the
// residual as Δ · (1.0 / J) in double. So the result is the coloured loop's,
// bit for bit: the lanes are independent IEEE operations, no contraction
// (the project builds with -ffp-contract=off, and the AVX2 kernel is built
// without FMA). A group is solved four lanes at a time by SSE2 (every
// x86-64) or eight at a time by AVX2 where the CPU has it (wide_lanes.h):
// the same operations per lane, so the same bits on every machine. A
// lane without a row (a run shorter than its group's longest) or a friction
// row whose contact carries no impulse keeps its row and bodies exactly as
// they were (blended, never added a zero).
//
// The rows are copied once per solve into blocks laid out by lane
// (pack()), solved there for every iteration, and their impulses and
// friction limits written back to Bullet's rows at the end (unpack()). The
// bodies' velocity changes live, for the whole solve, in a compact array
// of their own (two aligned vectors of four floats a body, x y z and an
// unused w): pack() loads them from Bullet's solver bodies, the groups
// gather from and scatter to it, and store() writes them back. Whoever
// solves rows with Bullet's scalar functions meanwhile (the overflow
// colour, rolling friction) stores the bodies it touches first and loads
// them back after (store(ids) / load(ids)).
//
// Only where Bullet's active row functions are those scalar references and
// btScalar is float (WideRows::applies); the double build keeps the loop
// that calls them.
#pragma once

#include <cstdint>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "wide_lanes.h"

namespace soda {

class SolverPool;

/// Groups from which pack() fills the groups on the pool (a group is a few
/// thousand instructions of copying), and groups per pool task.
constexpr int kParallelMinGroups = 64;
constexpr int kGroupsPerTask = 16;

class WideRows {
 public:
  /// A run as the coloured solver holds it: its two solver bodies, its
  /// contact rows [contact_begin, contact_end) and its friction rows
  /// frictions[0 .. friction_count) (indices into the friction pool).
  struct RunRows {
    int body_a, body_b;
    int contact_begin, contact_end;
    const int* frictions;
    int friction_count;
  };

  /// True where this build can solve wide with the same bits: float, SSE2,
  /// and the solver's active row functions are Bullet's scalar references.
  static bool applies(btSequentialImpulseConstraintSolver& solver);

  /// Copies the rows of `runs` (in groups of eight, in order; a group never
  /// spans two colours: `colour_begin` lists where each colour starts in
  /// `runs`, its last entry the end) into lane blocks, and every solver
  /// body's velocity changes into the compact array; on `pool`'s threads
  /// (null: the calling thread) from kParallelMinGroups groups, the same
  /// blocks either way.
  void pack(const std::vector<RunRows>& runs, const std::vector<int>& colour_begin,
            const btConstraintArray& contacts, const btConstraintArray& frictions,
            const btAlignedObjectArray<btSolverBody>& bodies, SolverPool* pool);
  /// Writes every packed row's impulse (friction rows: and limits) back.
  void unpack(btConstraintArray& contacts, btConstraintArray& frictions) const;

  /// The compact velocity changes of every solver body with an original
  /// body (never Bullet's fixed one) back to Bullet's solver bodies.
  void store(btAlignedObjectArray<btSolverBody>& bodies) const;
  /// Every solver body's velocity changes into the compact array again, on
  /// `pool`'s threads (null: the calling thread) from kParallelMinBodies.
  void load(const btAlignedObjectArray<btSolverBody>& bodies, SolverPool* pool = nullptr);
  /// The same for the solver bodies `ids` only, and back from them.
  void store(const std::vector<int>& ids, btAlignedObjectArray<btSolverBody>& bodies) const;
  void load(const std::vector<int>& ids, const btAlignedObjectArray<btSolverBody>& bodies);

  /// Residual of a sweep part: the largest squared row residual, NaN sticky.
  using Residual = wide::Residual;
  /// Solves the contact rows (friction: false) or the friction rows of the
  /// runs [first, first + count) of the packed order — first a multiple of
  /// eight (wide::kLanes) from its colour's start — against the compact velocity changes
  /// (a body without an original body, Bullet's fixed one, is read, never
  /// written).
  void solve(bool friction, int first, int count, Residual& residual);

  /// Whether solves take the eight-lane AVX2 kernel where the CPU has it
  /// (the default) or the four-lane SSE2 one everywhere: the same bits.
  /// Process-wide, read when a solve packs its rows; the tests compare the
  /// two.
  static void allow_avx2(bool allow);
  /// The kernel the next pack() chooses: true for AVX2.
  static bool uses_avx2();
  /// The kernel the last pack() chose: true for AVX2.
  bool packed_avx2() const { return avx2_; }

 private:
  using Block = wide::Block;
  using Group = wide::Group;
  using Delta = wide::Delta;

  void pack_group(const std::vector<RunRows>& runs, int index, const btConstraintArray& contacts,
                  const btConstraintArray& frictions, const btAlignedObjectArray<btSolverBody>& bodies);
  void solve_group(bool friction, const Group& g, Residual& residual);

  /// Every solver body's velocity changes; deltas_[bodies] is a spare zero
  /// entry for the lanes without a run.
  std::vector<Delta> deltas_;
  bool avx2_ = false;  // this solve's groups take the AVX2 kernel
  static void load_one(const btSolverBody& body, Delta& delta);
  static void store_one(const Delta& delta, btSolverBody& body);
  std::vector<Group> groups_;
  std::vector<int> group_first_;   // each group's first run
  std::vector<int> group_of_run_;  // the group holding each packed run
  std::vector<Block> contacts_, frictions_;  // the first contact_blocks_, friction_blocks_ are this solve's
  int contact_blocks_ = 0, friction_blocks_ = 0;
};

}  // namespace soda

// Internal: the coloured solve's contact and friction sweeps four runs at a
// time, one run per SSE lane (docs/coloured-solve.md, "Wide rows").
//
// Inside a colour no two runs share a dynamic body (coloured_solver.h), so
// four runs may be solved at once: lane l of every vector belongs to run l
// of a group of four consecutive runs of the colour, and a run's rows are
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
// (the project builds with -ffp-contract=off), SSE2 only (every x86-64). A
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

namespace soda {

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

  /// Copies the rows of `runs` (in groups of four, in order; a group never
  /// spans two colours: `colour_begin` lists where each colour starts in
  /// `runs`, its last entry the end) into lane blocks, and every solver
  /// body's velocity changes into the compact array.
  void pack(const std::vector<RunRows>& runs, const std::vector<int>& colour_begin,
            const btConstraintArray& contacts, const btConstraintArray& frictions,
            const btAlignedObjectArray<btSolverBody>& bodies);
  /// Writes every packed row's impulse (friction rows: and limits) back.
  void unpack(btConstraintArray& contacts, btConstraintArray& frictions) const;

  /// The compact velocity changes of every solver body with an original
  /// body (never Bullet's fixed one) back to Bullet's solver bodies.
  void store(btAlignedObjectArray<btSolverBody>& bodies) const;
  /// Every solver body's velocity changes into the compact array again.
  void load(const btAlignedObjectArray<btSolverBody>& bodies);
  /// The same for the solver bodies `ids` only, and back from them.
  void store(const std::vector<int>& ids, btAlignedObjectArray<btSolverBody>& bodies) const;
  void load(const std::vector<int>& ids, const btAlignedObjectArray<btSolverBody>& bodies);

  /// Residual of a sweep part: the largest squared row residual, NaN sticky.
  struct Residual {
    btScalar max = 0;
    bool nan = false;
  };
  /// Solves the contact rows (friction: false) or the friction rows of the
  /// runs [first, first + count) of the packed order — first a multiple of
  /// four from its colour's start — against the compact velocity changes
  /// (a body without an original body, Bullet's fixed one, is read, never
  /// written).
  void solve(bool friction, int first, int count, Residual& residual);

 private:
  struct alignas(16) Block {  // one row of each of the four runs of a group
    float n1[3][4], r1[3][4], n2[3][4], r2[3][4], a1[3][4], a2[3][4];
    float l1[3][4], l2[3][4];  // n1 ∘ m⁻¹ of body a, n2 ∘ m⁻¹ of body b: Bullet's "linear component"
    float rhs[4], cfm[4], jac[4], applied[4], lower[4], upper[4], friction[4];
    double inverse_jac[4];    // 1.0 / jac in double, as the row functions' residual takes it
    std::uint32_t valid[4];   // all ones where the lane has a row
    int row[4];               // the row's index in its pool (-1: none)
    int contact[4];           // friction rows: the block of contacts_ holding their contact row (same lane)
  };
  struct alignas(16) Group {
    float lf_a[3][4], af_a[3][4], lf_b[3][4], af_b[3][4];  // the bodies' linear and angular factors
    int body_a[4], body_b[4];  // into deltas_ (the spare zero entry: no run in this lane)
    bool write_a[4], write_b[4];  // the lane's body has an original body
    int contact_first, contact_blocks;
    int friction_first, friction_blocks;
  };

  void pack_group(const std::vector<RunRows>& runs, int first, int count, const btConstraintArray& contacts,
                  const btConstraintArray& frictions, const btAlignedObjectArray<btSolverBody>& bodies);
  void solve_group(bool friction, const Group& g, Residual& residual);

  /// One solver body's velocity changes (w unused); deltas_[bodies] is a
  /// spare zero entry for the lanes without a run.
  struct alignas(16) Delta {
    float lin[4], ang[4];
  };
  std::vector<Delta> deltas_;
  static void load_one(const btSolverBody& body, Delta& delta);
  static void store_one(const Delta& delta, btSolverBody& body);
  std::vector<Group> groups_;
  std::vector<int> group_of_run_;  // the group holding each packed run
  std::vector<Block> contacts_, frictions_;
};

}  // namespace soda

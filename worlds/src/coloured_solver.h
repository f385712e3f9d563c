// Internal: the constraint solver of every canonical and territory world
// (docs/coloured-solve.md). Bullet's btSequentialImpulseConstraintSolver,
// with the iteration loop of large islands replaced by a coloured one:
//
//   solveGroup
//     solveGroupCacheFriendlySetup       (stock: solver bodies, contact and
//                                         friction rows, in body and
//                                         manifold order; its convertContacts
//                                         OVERRIDDEN to set up a point's
//                                         rows together, and those of large
//                                         islands on the pool, the same
//                                         rows: coloured_setup.cpp)
//     solveGroupCacheFriendlyIterations  OVERRIDDEN for islands of at least
//                                         kColouredMinContactRows contact rows
//     solveGroupCacheFriendlyFinish      (stock: per body and per row;
//                                         OVERRIDDEN to run those loops on
//                                         the pool: coloured_setup.cpp)
//
// The coloured loop, a pure function of the rows that setup produced:
//  1. runs: maximal sequences of consecutive contact rows with the same two
//     solver bodies (one manifold, or several of one body with statics);
//     each run carries its friction and rolling-friction rows, in pool order;
//  2. colours, greedily in run order: a run takes the smallest colour that
//     neither of its dynamic bodies has yet (statics share Bullet's one fixed
//     solver body, which the rows never change: they do not conflict), among
//     kMaxColours; runs left over, and colours of fewer than
//     kMinRunsPerColour runs, go to a last overflow colour solved by one
//     thread in run order;
//  3. each sweep (split impulse, contact, friction, rolling friction — in
//     Bullet's order and with Bullet's early exit) goes colour after colour;
//     inside a colour no two runs share a dynamic body, so the runs may be
//     solved in any order, on any number of threads, with the same bits.
//     A run that touches statics solves against its own copy of the fixed
//     body (the rows add zero to it; the copy keeps threads off shared
//     memory, and keeps a NaN where the sequential solve would spread it
//     only as far as its own run).
// Not coloured (stock loop): smaller islands, joints, Bullet's random or
// interleaved solver modes.
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "soda/worlds/solver_pool.h"
#include "wide_rows.h"

namespace soda {

/// Islands with at least this many contact rows (contact points) are
/// solved coloured. Below it, colouring and one pool job per colour and
/// sweep cost more than a sweep gains on two threads; above it a heap's
/// colours hold enough runs to share (measured in docs/coloured-solve.md).
/// A function of the island alone: every world decides alike.
constexpr int kColouredMinContactRows = 256;
/// Colours tried per run before the overflow (a cube in a heap touches up
/// to ~12 others: greedy colouring needs up to ~2x that).
constexpr int kMaxColours = 32;
/// A colour with fewer runs goes to the overflow: a pool job for a handful of
/// runs costs more than solving them on one thread.
constexpr int kMinRunsPerColour = 16;
/// Runs per pool task: as many as amortise a task's claim and the cache
/// lines it pulls from the other thread, up to kMaxRunsPerTask, but no more
/// than leave every thread kTasksPerThread tasks of a colour and no fewer
/// than kMinRunsPerTask. cube-pile 4000, 300 steps, three alternating runs,
/// least wall s with a fixed 8 / 16 / 32 runs: K = 2 on 2 threads 11.86 /
/// 10.92 / 10.28; 32 / 64 / 128: 9.81 / 9.41 / 9.39; one territory on 2
/// solver threads 16 / 64: 10.42 / 9.35 (docs/results/coloured-solve.md). A fixed 64 left small
/// heaps (cube-pile 200) on one thread. Any split gives the same bits.
constexpr int kMinRunsPerTask = 16;
constexpr int kMaxRunsPerTask = 64;
constexpr int kTasksPerThread = 4;
/// Manifolds from which the contact and friction rows are built on the pool
/// (coloured_setup.cpp): a manifold's rows are ~2,000-4,000 instructions, so
/// below this a pool job costs more than it gains. Results never depend on it.
constexpr int kParallelMinManifolds = 64;
/// Manifolds per pool task of the row setup (~10-20 us of work per claim).
constexpr int kManifoldsPerTask = 16;
/// Island bodies from which the solver bodies are initialised on the pool
/// (~800 instructions a body with Bullet's implicit gyroscopic term).
constexpr int kParallelMinSolverBodies = 256;
/// Bodies per pool task of that stage (and of the bodies' write-back).
constexpr int kSolverBodiesPerTask = 64;
/// Colours from which the sorts of their runs by row counts (before the
/// wide rows' packing) are shared on the pool, one colour a task.
constexpr int kParallelMinColours = 4;
/// Contact rows per pool task of the write-back of impulses to the points
/// (a few dozen instructions a row).
constexpr int kRowsPerWriteBackTask = 256;

class ColouredSolver final : public btSequentialImpulseConstraintSolver {
 public:
  /// Cumulative counts (never reset; worlds take differences per step).
  struct Stats {
    std::size_t coloured_islands = 0;  // solveGroup calls solved coloured
    std::size_t wide_islands = 0;      // ... whose contact and friction sweeps ran eight runs at a time (wide_rows.h)
    std::size_t avx2_islands = 0;      // ... of those, on the AVX2 kernel
    std::size_t coloured_runs = 0;     // runs of those islands, summed
    std::size_t overflow_runs = 0;     // ... solved in the overflow colour
    int colours_max = 0;               // most colours of one island (overflow excluded)
    int threads_max = 0;               // most threads a job of a coloured island could use
    std::size_t point_rows = 0;        // contact points whose rows were set up together (point_rows.h)
    int setup_threads_max = 0;         // most threads a row setup could use (0: never on the pool)
    int body_setup_threads_max = 0;    // most threads a solver body setup could use (0: never on the pool)
    int finish_threads_max = 0;        // most threads a write-back could use (0: never with a pool)
  };

  /// How an island that qualifies (colour() succeeds) is solved.
  enum class Mode {
    /// The coloured loop (step 3 of the header), on the pool's threads.
    Coloured,
    /// The oracle of the tests: the island is coloured as usual, then
    /// Bullet's own sequential loop solves it with its order arrays set to
    /// the colour order (colour after colour, runs in order, each run's
    /// rows in pool order), on the calling thread. Bit-identical to
    /// Coloured by construction, for any per-island settings (iterations,
    /// early exit); a difference is a bug of the coloured loop. Not with
    /// rolling friction (Bullet visits those rows in pool order only):
    /// std::logic_error.
    SequentialInColourOrder,
  };
  void set_mode(Mode mode) { mode_ = mode; }
  Mode mode() const { return mode_; }

  /// The pool the colours' runs are shared on (null: the calling thread
  /// alone). Results never depend on it. Not during a solve.
  void set_pool(std::shared_ptr<SolverPool> pool) { pool_ = std::move(pool); }
  const std::shared_ptr<SolverPool>& pool() const { return pool_; }
  const Stats& stats() const { return stats_; }

  /// Whether a contact point's rows are set up together (point_rows.h) or
  /// by Bullet's setupContactConstraint and setupFrictionConstraint, one
  /// call a row: the same bits either way. Process-wide, for the tests
  /// that hold that (default true). Not during a solve.
  static void allow_point_rows(bool allow);

 protected:
  btScalar solveGroupCacheFriendlyIterations(btCollisionObject** bodies, int numBodies,
                                             btPersistentManifold** manifoldPtr, int numManifolds,
                                             btTypedConstraint** constraints, int numConstraints,
                                             const btContactSolverInfo& infoGlobal,
                                             btIDebugDraw* debugDrawer) override;
  /// Bullet's contact and friction rows, a point's rows set up together
  /// (point_rows.h), on the pool above kParallelMinManifolds manifolds
  /// (coloured_setup.cpp): the same rows, at the same indices, and the same
  /// warm-start deltas as Bullet's loop.
  void convertContacts(btPersistentManifold** manifolds, int count, const btContactSolverInfo& info) override;
  /// Bullet's solver bodies, initialised on the pool above kParallelMinSolverBodies
  /// bodies when all are dynamic (coloured_setup.cpp): the same bodies.
  void convertBodies(btCollisionObject** bodies, int count, const btContactSolverInfo& info) override;
  /// Bullet's finish (impulses to the points, velocities and split-impulse
  /// transforms to the bodies), on the pool for large islands
  /// (coloured_setup.cpp): the same writes.
  btScalar solveGroupCacheFriendlyFinish(btCollisionObject** bodies, int count,
                                         const btContactSolverInfo& info) override;

 private:
  enum class Sweep { Split, Contact, Friction, Rolling };
  struct Run {
    int body_a, body_b;       // solver body indices
    int contact_begin, contact_end;
    int friction_begin, friction_end;  // into friction_rows_
    int rolling_begin, rolling_end;    // into rolling_rows_
  };
  /// Residual of a sweep part: max of squares, NaN sticky (order-free).
  struct Residual {
    btScalar max = 0;
    bool nan = false;
    void add(btScalar r);
    void merge(const Residual& o);
  };

  /// One manifold's place in the row pools (coloured_setup.cpp, step 1).
  struct ManifoldRows {
    int body_a, body_b;  // solver body indices
    int first_contact;   // its first contact row
    int contacts;        // its contact rows (0: skipped)
  };
  /// together: a point's rows by setup_point_rows where it applies.
  void convert_manifold(btPersistentManifold& m, const ManifoldRows& rows, int first_friction,
                        int frictions_per_contact, bool together, const btContactSolverInfo& info);

  bool colour(const btContactSolverInfo& info);
  void assign_colours();
  Residual sweep(Sweep kind);
  void solve_runs(Sweep kind, const int* runs, int count, Residual& residual);

  void set_colour_order();
  void pack_wide();

  /// Contact and friction sweeps of the colours eight runs at a time
  /// (wide_rows.h), where WideRows::applies: the same bits.
  WideRows wide_;
  bool wide_on_ = false;
  std::vector<WideRows::RunRows> wide_runs_;
  std::vector<int> overflow_bodies_;  // the overflow colour's solver bodies but the fixed one

  std::shared_ptr<SolverPool> pool_;
  Mode mode_ = Mode::Coloured;
  Stats stats_;
  int threads_ = 1;  // of the current island

  // Per-island scratch, kept to avoid reallocation.
  std::vector<ManifoldRows> manifold_rows_;
  std::vector<Run> runs_;
  std::vector<int> friction_rows_, rolling_rows_;
  std::vector<int> run_of_contact_;
  std::vector<unsigned long long> body_colours_;  // per solver body: colour bits
  std::vector<int> colour_of_run_;
  std::vector<int> colour_begin_;   // CSR over colour_runs_; the last colour is the overflow
  std::vector<int> colour_runs_;
  std::vector<Residual> task_residuals_;
};

}  // namespace soda

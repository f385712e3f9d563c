#include "coloured_solver.h"

#include <algorithm>
#include <bit>
#include <limits>
#include <stdexcept>

#include "parallel_stages.h"

namespace soda {

void ColouredSolver::Residual::add(btScalar r) {
  const btScalar s = r * r;
  if (s != s) {
    nan = true;
  } else if (s > max) {
    max = s;
  }
}

void ColouredSolver::Residual::merge(const Residual& o) {
  nan = nan || o.nan;
  if (o.max > max) max = o.max;
}

// Steps 1 and 2 of the header. False: this island takes the stock loop.
bool ColouredSolver::colour(const btContactSolverInfo& info) {
  const int contacts = m_tmpSolverContactConstraintPool.size();
  const int frictions = m_tmpSolverContactFrictionConstraintPool.size();
  const int rollings = m_tmpSolverContactRollingFrictionConstraintPool.size();
  if (contacts < kColouredMinContactRows) return false;
  if (m_tmpSolverNonContactConstraintPool.size() != 0) return false;
  if (info.m_solverMode & (SOLVER_RANDMIZE_ORDER | SOLVER_INTERLEAVE_CONTACT_AND_FRICTION_CONSTRAINTS)) return false;
  // Only the first `contacts` (`frictions`) entries are an order: with
  // SOLVER_USE_2_FRICTION_DIRECTIONS Bullet's setup sizes the contact order
  // to twice the contact rows (resizeNoInitialize) and sets only the first
  // half; the rest is whatever earlier, larger islands of this solver left
  // there. Reading it made the choice coloured/stock depend on the world's
  // history, not on the island (N territories != one).
  if (m_orderTmpConstraintPool.size() < contacts || m_orderFrictionConstraintPool.size() < frictions) return false;
  for (int i = 0; i < contacts; ++i)
    if (m_orderTmpConstraintPool[i] != i) return false;
  for (int i = 0; i < frictions; ++i)
    if (m_orderFrictionConstraintPool[i] != i) return false;

  // 1. Runs of contact rows with the same two solver bodies.
  runs_.clear();
  run_of_contact_.resize(static_cast<std::size_t>(contacts));
  for (int i = 0; i < contacts; ++i) {
    const btSolverConstraint& c = m_tmpSolverContactConstraintPool[i];
    if (runs_.empty() || runs_.back().body_a != c.m_solverBodyIdA || runs_.back().body_b != c.m_solverBodyIdB)
      runs_.push_back(Run{c.m_solverBodyIdA, c.m_solverBodyIdB, i, i, 0, 0, 0, 0});
    runs_.back().contact_end = i + 1;
    run_of_contact_[static_cast<std::size_t>(i)] = static_cast<int>(runs_.size()) - 1;
  }
  // Friction and rolling rows by run, in pool order (a counting sort).
  auto bucket = [&](btConstraintArray& pool, int rows, std::vector<int>& out, int Run::*begin, int Run::*end) {
    for (Run& r : runs_) r.*begin = r.*end = 0;
    for (int i = 0; i < rows; ++i) {
      const btSolverConstraint& f = pool[i];
      if (f.m_frictionIndex < 0 || f.m_frictionIndex >= contacts) return false;
      Run& r = runs_[static_cast<std::size_t>(run_of_contact_[static_cast<std::size_t>(f.m_frictionIndex)])];
      if (f.m_solverBodyIdA != r.body_a || f.m_solverBodyIdB != r.body_b) return false;
      ++(r.*end);
    }
    int offset = 0;
    for (Run& r : runs_) {
      r.*begin = offset;
      offset += r.*end;
      r.*end = r.*begin;
    }
    out.resize(static_cast<std::size_t>(rows));
    for (int i = 0; i < rows; ++i) {
      Run& r = runs_[static_cast<std::size_t>(run_of_contact_[static_cast<std::size_t>(pool[i].m_frictionIndex)])];
      out[static_cast<std::size_t>((r.*end)++)] = i;
    }
    return true;
  };
  if (!bucket(m_tmpSolverContactFrictionConstraintPool, frictions, friction_rows_, &Run::friction_begin,
              &Run::friction_end))
    return false;
  if (!bucket(m_tmpSolverContactRollingFrictionConstraintPool, rollings, rolling_rows_, &Run::rolling_begin,
              &Run::rolling_end))
    return false;

  assign_colours();
  return true;
}

// Step 2 of the header: greedy colours in run order; the fixed body
// conflicts with nothing.
void ColouredSolver::assign_colours() {
  const int fixed = m_fixedBodyId;
  body_colours_.assign(static_cast<std::size_t>(m_tmpSolverBodyPool.size()), 0ull);
  colour_of_run_.resize(runs_.size());
  std::vector<int> size(kMaxColours + 1, 0);
  for (std::size_t r = 0; r < runs_.size(); ++r) {
    const int a = runs_[r].body_a, b = runs_[r].body_b;
    const unsigned long long used = (a != fixed ? body_colours_[static_cast<std::size_t>(a)] : 0ull) |
                                    (b != fixed ? body_colours_[static_cast<std::size_t>(b)] : 0ull);
    int c = std::countr_zero(~used);
    if (c >= kMaxColours) {
      c = kMaxColours;  // overflow
    } else {
      const unsigned long long bit = 1ull << c;
      if (a != fixed) body_colours_[static_cast<std::size_t>(a)] |= bit;
      if (b != fixed) body_colours_[static_cast<std::size_t>(b)] |= bit;
    }
    colour_of_run_[r] = c;
    ++size[static_cast<std::size_t>(c)];
  }
  // Small colours join the overflow; the rest are numbered in order.
  std::vector<int> rank(kMaxColours + 1, 0);
  int colours = 0;
  for (std::size_t c = 0; c < kMaxColours; ++c) rank[c] = size[c] >= kMinRunsPerColour ? colours++ : -1;
  colour_begin_.assign(static_cast<std::size_t>(colours) + 2, 0);
  for (std::size_t r = 0; r < runs_.size(); ++r) {
    int k = rank[static_cast<std::size_t>(colour_of_run_[r])];
    if (colour_of_run_[r] == kMaxColours || k < 0) k = colours;
    colour_of_run_[r] = k;
    ++colour_begin_[static_cast<std::size_t>(k) + 1];
  }
  for (std::size_t k = 0; k <= static_cast<std::size_t>(colours); ++k) colour_begin_[k + 1] += colour_begin_[k];
  colour_runs_.resize(runs_.size());
  std::vector<int> cursor(colour_begin_.begin(), colour_begin_.end() - 1);
  for (std::size_t r = 0; r < runs_.size(); ++r)
    colour_runs_[static_cast<std::size_t>(cursor[static_cast<std::size_t>(colour_of_run_[r])]++)] = static_cast<int>(r);

  ++stats_.coloured_islands;
  stats_.coloured_runs += runs_.size();
  stats_.overflow_runs += static_cast<std::size_t>(colour_begin_[static_cast<std::size_t>(colours) + 1] -
                                                   colour_begin_[static_cast<std::size_t>(colours)]);
  stats_.colours_max = std::max(stats_.colours_max, colours);
}

// The rows of `count` runs, in order, as Bullet's loops solve them.
void ColouredSolver::solve_runs(Sweep kind, const int* runs, int count, Residual& residual) {
  const int fixed = m_fixedBodyId;
  for (int k = 0; k < count; ++k) {
    const Run& r = runs_[static_cast<std::size_t>(runs[k])];
    btSolverBody fixed_copy;
    if (fixed >= 0 && (r.body_a == fixed || r.body_b == fixed)) fixed_copy = m_tmpSolverBodyPool[fixed];
    btSolverBody& a = r.body_a == fixed ? fixed_copy : m_tmpSolverBodyPool[r.body_a];
    btSolverBody& b = r.body_b == fixed ? fixed_copy : m_tmpSolverBodyPool[r.body_b];
    switch (kind) {
      case Sweep::Split:
        for (int i = r.contact_begin; i < r.contact_end; ++i)
          residual.add(m_resolveSplitPenetrationImpulse(a, b, m_tmpSolverContactConstraintPool[i]));
        break;
      case Sweep::Contact:
        for (int i = r.contact_begin; i < r.contact_end; ++i)
          residual.add(m_resolveSingleConstraintRowLowerLimit(a, b, m_tmpSolverContactConstraintPool[i]));
        break;
      case Sweep::Friction:
        for (int j = r.friction_begin; j < r.friction_end; ++j) {
          btSolverConstraint& f = m_tmpSolverContactFrictionConstraintPool[friction_rows_[static_cast<std::size_t>(j)]];
          const btScalar total = m_tmpSolverContactConstraintPool[f.m_frictionIndex].m_appliedImpulse;
          if (total > btScalar(0)) {
            f.m_lowerLimit = -(f.m_friction * total);
            f.m_upperLimit = f.m_friction * total;
            residual.add(m_resolveSingleConstraintRowGeneric(a, b, f));
          }
        }
        break;
      case Sweep::Rolling:
        for (int j = r.rolling_begin; j < r.rolling_end; ++j) {
          btSolverConstraint& f =
              m_tmpSolverContactRollingFrictionConstraintPool[rolling_rows_[static_cast<std::size_t>(j)]];
          const btScalar total = m_tmpSolverContactConstraintPool[f.m_frictionIndex].m_appliedImpulse;
          if (total > btScalar(0)) {
            btScalar magnitude = f.m_friction * total;
            if (magnitude > f.m_friction) magnitude = f.m_friction;
            f.m_lowerLimit = -magnitude;
            f.m_upperLimit = magnitude;
            residual.add(m_resolveSingleConstraintRowGeneric(a, b, f));
          }
        }
        break;
    }
  }
}

// Step 3: colour after colour; the overflow last, on this thread.
ColouredSolver::Residual ColouredSolver::sweep(Sweep kind) {
  if (wide_on_ && kind == Sweep::Rolling) {
    // Bullet's scalar rows, on Bullet's solver bodies, for every colour.
    wide_.store(m_tmpSolverBodyPool);
    wide_on_ = false;
    const Residual total = sweep(kind);
    wide_on_ = true;
    wide_.load(m_tmpSolverBodyPool, pool_.get());
    return total;
  }
  Residual total;
  const bool wide_sweep = wide_on_ && (kind == Sweep::Contact || kind == Sweep::Friction);
  const int colours = static_cast<int>(colour_begin_.size()) - 2;
  for (int c = 0; c < colours; ++c) {
    const int begin = colour_begin_[static_cast<std::size_t>(c)];
    const int count = colour_begin_[static_cast<std::size_t>(c) + 1] - begin;
    // A multiple of wide::kLanes: a task starts on a group of the wide rows.
    const int fitted = pool_ ? std::clamp(count / (kTasksPerThread * pool_->threads()), kMinRunsPerTask,
                                          kMaxRunsPerTask)
                             : kMaxRunsPerTask;
    const int per_task = (fitted + wide::kLanes - 1) / wide::kLanes * wide::kLanes;
    const int tasks = (count + per_task - 1) / per_task;
    task_residuals_.assign(static_cast<std::size_t>(tasks), Residual{});
    auto task = [&](int t) {
      const int first = begin + t * per_task;
      const int n = std::min(per_task, begin + count - first);
      Residual& residual = task_residuals_[static_cast<std::size_t>(t)];
      if (wide_sweep) {
        WideRows::Residual r;
        wide_.solve(kind == Sweep::Friction, first, n, r);
        residual.merge(Residual{r.max, r.nan});
      } else {
        solve_runs(kind, &colour_runs_[static_cast<std::size_t>(first)], n, residual);
      }
    };
    if (pool_) {
      threads_ = std::max(threads_, pool_->run(tasks, task));
    } else {
      for (int t = 0; t < tasks; ++t) task(t);
    }
    for (const Residual& r : task_residuals_) total.merge(r);
  }
  const int begin = colour_begin_[static_cast<std::size_t>(colours)];
  const int count = colour_begin_[static_cast<std::size_t>(colours) + 1] - begin;
  if (count > 0) {
    if (wide_sweep) wide_.store(overflow_bodies_, m_tmpSolverBodyPool);
    solve_runs(kind, &colour_runs_[static_cast<std::size_t>(begin)], count, total);
    if (wide_sweep) wide_.load(overflow_bodies_, m_tmpSolverBodyPool);
  }
  return total;
}

// The colours' runs (not the overflow) in colour order, packed eight by eight.
void ColouredSolver::pack_wide() {
  const std::size_t colours = colour_begin_.size() - 2;
  const int packed = colour_begin_[colours];
  // Inside a colour the runs' order is free (no two share a dynamic body):
  // runs of as many rows side by side fill the lanes of a group.
  auto rows = [&](int r) {
    const Run& run = runs_[static_cast<std::size_t>(r)];
    return std::pair{run.contact_end - run.contact_begin, run.friction_end - run.friction_begin};
  };
  run_in_chunks(pool_.get(), static_cast<int>(colours), kParallelMinColours, 1, [&](int begin, int end) {
    for (int c = begin; c < end; ++c)
      std::stable_sort(colour_runs_.begin() + colour_begin_[c], colour_runs_.begin() + colour_begin_[c + 1],
                       [&](int x, int y) { return rows(x) < rows(y); });
  });
  wide_runs_.clear();
  for (int k = 0; k < packed; ++k) {
    const Run& r = runs_[static_cast<std::size_t>(colour_runs_[static_cast<std::size_t>(k)])];
    wide_runs_.push_back(WideRows::RunRows{r.body_a, r.body_b, r.contact_begin, r.contact_end,
                                           friction_rows_.data() + r.friction_begin,
                                           r.friction_end - r.friction_begin});
  }
  // The overflow's bodies, which its scalar rows read from Bullet's solver bodies.
  overflow_bodies_.clear();
  for (int k = packed; k < colour_begin_[colours + 1]; ++k) {
    const Run& r = runs_[static_cast<std::size_t>(colour_runs_[static_cast<std::size_t>(k)])];
    for (const int b : {r.body_a, r.body_b})
      if (b != m_fixedBodyId) overflow_bodies_.push_back(b);
  }
  std::sort(overflow_bodies_.begin(), overflow_bodies_.end());
  overflow_bodies_.erase(std::unique(overflow_bodies_.begin(), overflow_bodies_.end()), overflow_bodies_.end());
  const std::vector<int> begins(colour_begin_.begin(), colour_begin_.begin() + static_cast<std::ptrdiff_t>(colours) + 1);
  wide_.pack(wide_runs_, begins, m_tmpSolverContactConstraintPool, m_tmpSolverContactFrictionConstraintPool,
             m_tmpSolverBodyPool, pool_.get());
}

// Mode::SequentialInColourOrder: Bullet's order arrays in the order the
// coloured sweeps visit the rows (only their first `contacts` / `frictions`
// entries are read by Bullet's non-interleaved loop).
void ColouredSolver::set_colour_order() {
  if (m_tmpSolverContactRollingFrictionConstraintPool.size() > 0)
    throw std::logic_error("ColouredSolver: SequentialInColourOrder does not support rolling friction");
  int contact = 0, friction = 0;
  for (const int r : colour_runs_) {
    const Run& run = runs_[static_cast<std::size_t>(r)];
    for (int i = run.contact_begin; i < run.contact_end; ++i) m_orderTmpConstraintPool[contact++] = i;
    for (int j = run.friction_begin; j < run.friction_end; ++j)
      m_orderFrictionConstraintPool[friction++] = friction_rows_[static_cast<std::size_t>(j)];
  }
}

// As btSequentialImpulseConstraintSolver::solveGroupCacheFriendlyIterations
// (split-impulse iterations, then the velocity iterations with the same
// early exit), each sweep coloured.
btScalar ColouredSolver::solveGroupCacheFriendlyIterations(btCollisionObject** bodies, int numBodies,
                                                           btPersistentManifold** manifoldPtr, int numManifolds,
                                                           btTypedConstraint** constraints, int numConstraints,
                                                           const btContactSolverInfo& info, btIDebugDraw* debugDrawer) {
  if (numConstraints != 0 || !colour(info))
    return btSequentialImpulseConstraintSolver::solveGroupCacheFriendlyIterations(
        bodies, numBodies, manifoldPtr, numManifolds, constraints, numConstraints, info, debugDrawer);
  if (mode_ == Mode::SequentialInColourOrder) {
    set_colour_order();
    stats_.threads_max = std::max(stats_.threads_max, 1);
    return btSequentialImpulseConstraintSolver::solveGroupCacheFriendlyIterations(
        bodies, numBodies, manifoldPtr, numManifolds, constraints, numConstraints, info, debugDrawer);
  }
  threads_ = 1;
  wide_on_ = WideRows::applies(*this);
  if (wide_on_) {
    pack_wide();
    ++stats_.wide_islands;
    if (wide_.packed_avx2()) ++stats_.avx2_islands;
  }
  const btScalar threshold = info.m_leastSquaresResidualThreshold;
  auto done = [&](const Residual& r) { return !r.nan && r.max <= threshold; };
  if (info.m_splitImpulse)
    for (int iteration = 0; iteration < info.m_numIterations; ++iteration)
      if (done(sweep(Sweep::Split)) || iteration >= info.m_numIterations - 1) break;

  const int max_iterations = std::max(m_maxOverrideNumSolverIterations, info.m_numIterations);
  const bool rolling = m_tmpSolverContactRollingFrictionConstraintPool.size() > 0;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    Residual r;
    if (iteration < info.m_numIterations) {
      r.merge(sweep(Sweep::Contact));
      r.merge(sweep(Sweep::Friction));
      if (rolling) r.merge(sweep(Sweep::Rolling));
    }
    m_leastSquaresResidual = r.nan ? std::numeric_limits<btScalar>::quiet_NaN() : r.max;
    if (done(r) || iteration >= max_iterations - 1) {
      m_analyticsData.m_numSolverCalls++;
      m_analyticsData.m_numIterationsUsed = iteration + 1;
      m_analyticsData.m_islandId = numBodies > 0 ? bodies[0]->getCompanionId() : -2;
      m_analyticsData.m_numBodies = numBodies;
      m_analyticsData.m_numContactManifolds = numManifolds;
      m_analyticsData.m_remainingLeastSquaresResidual = m_leastSquaresResidual;
      break;
    }
  }
  if (wide_on_) {
    wide_.store(m_tmpSolverBodyPool);
    wide_.unpack(m_tmpSolverContactConstraintPool, m_tmpSolverContactFrictionConstraintPool);
  }
  wide_on_ = false;
  stats_.threads_max = std::max(stats_.threads_max, threads_);
  return 0.f;
}

}  // namespace soda

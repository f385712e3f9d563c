// The coloured sweeps eight runs at a time (wide_rows.h), and the SSE2
// kernel (wide_lanes.h).
#include "wide_rows.h"

#include <algorithm>
#include <atomic>
#include <span>
#include <stdexcept>

#include "parallel_stages.h"

#if defined(__SSE2__) && !defined(BT_USE_DOUBLE_PRECISION)
#include <emmintrin.h>
#include <xmmintrin.h>
#define SODA_WIDE_ROWS 1
#else
#define SODA_WIDE_ROWS 0
#endif

namespace soda {

bool WideRows::applies(btSequentialImpulseConstraintSolver& solver) {
#if SODA_WIDE_ROWS
  return solver.getActiveConstraintRowSolverGeneric() == solver.getScalarConstraintRowSolverGeneric() &&
         solver.getActiveConstraintRowSolverLowerLimit() == solver.getScalarConstraintRowSolverLowerLimit();
#else
  (void)solver;
  return false;
#endif
}

namespace {

// One row of a Bullet pool into lane `l` of a block.
template <class Block>
void put_row(Block& b, int l, int index, const btSolverConstraint& c, const btSolverBody& body_a,
             const btSolverBody& body_b) {
  const btVector3* vectors[6] = {&c.m_contactNormal1, &c.m_relpos1CrossNormal, &c.m_contactNormal2,
                                 &c.m_relpos2CrossNormal, &c.m_angularComponentA, &c.m_angularComponentB};
  float(*fields[6])[wide::kLanes] = {b.n1, b.r1, b.n2, b.r2, b.a1, b.a2};
  for (int v = 0; v < 6; ++v)
    for (int k = 0; k < 3; ++k) fields[v][k][l] = float(vectors[v]->m_floats[k]);
  const btVector3 l1 = c.m_contactNormal1 * body_a.internalGetInvMass();  // as the row function does
  const btVector3 l2 = c.m_contactNormal2 * body_b.internalGetInvMass();
  for (int k = 0; k < 3; ++k) {
    b.l1[k][l] = float(l1.m_floats[k]);
    b.l2[k][l] = float(l2.m_floats[k]);
  }
  b.rhs[l] = float(c.m_rhs);
  b.cfm[l] = float(c.m_cfm);
  b.jac[l] = float(c.m_jacDiagABInv);
  b.inverse_jac[l] = 1. / c.m_jacDiagABInv;
  b.applied[l] = float(c.m_appliedImpulse);
  b.lower[l] = float(c.m_lowerLimit);
  b.upper[l] = float(c.m_upperLimit);
  b.friction[l] = float(c.m_friction);
  b.valid[l] = ~0u;
  b.row[l] = index;
}

}  // namespace

void WideRows::pack(const std::vector<RunRows>& runs, const std::vector<int>& colour_begin,
                    const btConstraintArray& contacts, const btConstraintArray& frictions,
                    const btAlignedObjectArray<btSolverBody>& bodies, SolverPool* pool) {
  avx2_ = uses_avx2();
  deltas_.resize(static_cast<std::size_t>(bodies.size()) + 1);
  load(bodies, pool);
  deltas_.back() = Delta{};
  // Each group's runs and the places of its blocks, in order; then the
  // groups filled in, each writing only its own blocks.
  groups_.clear();
  group_first_.clear();
  group_of_run_.assign(runs.size(), -1);
  contact_blocks_ = friction_blocks_ = 0;
  for (std::size_t c = 0; c + 1 < colour_begin.size(); ++c)
    for (int first = colour_begin[c]; first < colour_begin[c + 1]; first += wide::kLanes) {
      Group g{};
      g.runs = std::min(wide::kLanes, colour_begin[c + 1] - first);
      for (int l = 0; l < g.runs; ++l) {
        const RunRows& r = runs[static_cast<std::size_t>(first + l)];
        g.contact_blocks = std::max(g.contact_blocks, r.contact_end - r.contact_begin);
        g.friction_blocks = std::max(g.friction_blocks, r.friction_count);
        group_of_run_[static_cast<std::size_t>(first + l)] = static_cast<int>(groups_.size());
      }
      g.contact_first = contact_blocks_;
      g.friction_first = friction_blocks_;
      contact_blocks_ += g.contact_blocks;
      friction_blocks_ += g.friction_blocks;
      groups_.push_back(g);
      group_first_.push_back(first);
    }
  // The block arrays only grow: each group sets every field of its blocks.
  if (contacts_.size() < static_cast<std::size_t>(contact_blocks_))
    contacts_.resize(static_cast<std::size_t>(contact_blocks_));
  if (frictions_.size() < static_cast<std::size_t>(friction_blocks_))
    frictions_.resize(static_cast<std::size_t>(friction_blocks_));
  run_in_chunks(pool, static_cast<int>(groups_.size()), kParallelMinGroups, kGroupsPerTask, [&](int begin, int end) {
    for (int g = begin; g < end; ++g) pack_group(runs, g, contacts, frictions, bodies);
  });
}

void WideRows::pack_group(const std::vector<RunRows>& runs, int index, const btConstraintArray& contacts,
                          const btConstraintArray& frictions, const btAlignedObjectArray<btSolverBody>& bodies) {
  Group& g = groups_[static_cast<std::size_t>(index)];
  const int first = group_first_[static_cast<std::size_t>(index)];
  Block empty{};
  std::fill(std::begin(empty.row), std::end(empty.row), -1);
  std::fill(std::begin(empty.contact), std::end(empty.contact), -1);
  std::fill_n(contacts_.begin() + g.contact_first, g.contact_blocks, empty);
  std::fill_n(frictions_.begin() + g.friction_first, g.friction_blocks, empty);
  const int spare = bodies.size();
  for (int l = 0; l < wide::kLanes; ++l) g.body_a[l] = g.body_b[l] = spare;
  for (int l = 0; l < g.runs; ++l) {
    const RunRows& r = runs[static_cast<std::size_t>(first + l)];
    g.body_a[l] = r.body_a;
    g.body_b[l] = r.body_b;
    const btSolverBody& a = bodies[r.body_a];
    const btSolverBody& b = bodies[r.body_b];
    g.write_a[l] = a.m_originalBody != nullptr;
    g.write_b[l] = b.m_originalBody != nullptr;
    for (int k = 0; k < 3; ++k) {
      g.lf_a[k][l] = float(a.m_linearFactor.m_floats[k]);
      g.af_a[k][l] = float(a.m_angularFactor.m_floats[k]);
      g.lf_b[k][l] = float(b.m_linearFactor.m_floats[k]);
      g.af_b[k][l] = float(b.m_angularFactor.m_floats[k]);
    }
    for (int k = 0; k < r.contact_end - r.contact_begin; ++k)
      put_row(contacts_[static_cast<std::size_t>(g.contact_first + k)], l, r.contact_begin + k,
              contacts[r.contact_begin + k], a, b);
    for (int k = 0; k < r.friction_count; ++k) {
      const btSolverConstraint& f = frictions[r.frictions[k]];
      Block& block = frictions_[static_cast<std::size_t>(g.friction_first + k)];
      put_row(block, l, r.frictions[k], f, a, b);
      block.contact[l] = g.contact_first + (f.m_frictionIndex - r.contact_begin);
    }
  }
}

void WideRows::unpack(btConstraintArray& contacts, btConstraintArray& frictions) const {
  for (const Block& b : std::span(contacts_.data(), static_cast<std::size_t>(contact_blocks_)))
    for (int l = 0; l < wide::kLanes; ++l)
      if (b.row[l] >= 0) contacts[b.row[l]].m_appliedImpulse = b.applied[l];
  for (const Block& b : std::span(frictions_.data(), static_cast<std::size_t>(friction_blocks_)))
    for (int l = 0; l < wide::kLanes; ++l)
      if (b.row[l] >= 0) {
        btSolverConstraint& f = frictions[b.row[l]];
        f.m_appliedImpulse = b.applied[l];
        f.m_lowerLimit = b.lower[l];
        f.m_upperLimit = b.upper[l];
      }
}

void WideRows::solve(bool friction, int first, int count, Residual& residual) {
  if (count <= 0) return;
  const int last = group_of_run_[static_cast<std::size_t>(first + count - 1)];
  for (int g = group_of_run_[static_cast<std::size_t>(first)]; g <= last; ++g)
    solve_group(friction, groups_[static_cast<std::size_t>(g)], residual);
}

namespace {
std::atomic<bool> avx2_allowed{true};
}  // namespace

void WideRows::allow_avx2(bool allow) { avx2_allowed.store(allow); }

bool WideRows::uses_avx2() {
  static const bool supported = wide::avx2_supported();
  return supported && avx2_allowed.load();
}

void WideRows::store(btAlignedObjectArray<btSolverBody>& bodies) const {
  for (int i = 0; i < bodies.size(); ++i) store_one(deltas_[static_cast<std::size_t>(i)], bodies[i]);
}

void WideRows::load(const btAlignedObjectArray<btSolverBody>& bodies, SolverPool* pool) {
  run_in_chunks(pool, bodies.size(), kParallelMinBodies, kBodiesPerTask, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) load_one(bodies[i], deltas_[static_cast<std::size_t>(i)]);
  });
}

void WideRows::store(const std::vector<int>& ids, btAlignedObjectArray<btSolverBody>& bodies) const {
  for (const int i : ids) store_one(deltas_[static_cast<std::size_t>(i)], bodies[i]);
}

void WideRows::load(const std::vector<int>& ids, const btAlignedObjectArray<btSolverBody>& bodies) {
  for (const int i : ids) load_one(bodies[i], deltas_[static_cast<std::size_t>(i)]);
}

void WideRows::load_one(const btSolverBody& body, Delta& delta) {
  const btVector3& lin = body.m_deltaLinearVelocity;
  const btVector3& ang = body.m_deltaAngularVelocity;
  delta = Delta{{float(lin.x()), float(lin.y()), float(lin.z()), 0.f},
                {float(ang.x()), float(ang.y()), float(ang.z()), 0.f}};
}

// x, y and z only, and only to a body with an original body
// (btSolverBody::internalApplyImpulse writes no other).
void WideRows::store_one(const Delta& delta, btSolverBody& body) {
  if (!body.m_originalBody) return;
  for (int k = 0; k < 3; ++k) {
    body.m_deltaLinearVelocity.m_floats[k] = delta.lin[k];
    body.m_deltaAngularVelocity.m_floats[k] = delta.ang[k];
  }
}

#if SODA_WIDE_ROWS

namespace wide {
namespace {

// SSE2's operations for the kernel (wide_kernel.h): four lanes.
struct V4 {
  using T = __m128;
  static constexpr int kWidth = 4;
  static T load(const float* p) { return _mm_load_ps(p); }
  static void store(float* p, T v) { _mm_store_ps(p, v); }
  static T zero() { return _mm_setzero_ps(); }
  static T sign() { return _mm_set1_ps(-0.0f); }
  static T add(T a, T b) { return _mm_add_ps(a, b); }
  static T sub(T a, T b) { return _mm_sub_ps(a, b); }
  static T mul(T a, T b) { return _mm_mul_ps(a, b); }
  static T lt(T a, T b) { return _mm_cmplt_ps(a, b); }
  static T gt(T a, T b) { return _mm_cmpgt_ps(a, b); }
  static T and_(T a, T b) { return _mm_and_ps(a, b); }
  static T andnot(T a, T b) { return _mm_andnot_ps(a, b); }
  static T or_(T a, T b) { return _mm_or_ps(a, b); }
  static T xor_(T a, T b) { return _mm_xor_ps(a, b); }
  static T max(T a, T b) { return _mm_max_ps(a, b); }
  static T unordered(T a, T b) { return _mm_cmpunord_ps(a, b); }
  static bool any(T mask) { return _mm_movemask_ps(mask) != 0; }

  // Four bodies' x, y, z into three vectors, and back (w unused).
  static void gather(const Delta* deltas, const int* body, T lin[3], T ang[3]) {
    const Delta &d0 = deltas[body[0]], &d1 = deltas[body[1]], &d2 = deltas[body[2]], &d3 = deltas[body[3]];
    T r0 = _mm_load_ps(d0.lin), r1 = _mm_load_ps(d1.lin), r2 = _mm_load_ps(d2.lin), r3 = _mm_load_ps(d3.lin);
    _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
    lin[0] = r0, lin[1] = r1, lin[2] = r2;
    r0 = _mm_load_ps(d0.ang), r1 = _mm_load_ps(d1.ang), r2 = _mm_load_ps(d2.ang), r3 = _mm_load_ps(d3.ang);
    _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
    ang[0] = r0, ang[1] = r1, ang[2] = r2;
  }
  static void scatter(const T lin[3], const T ang[3], const int* body, const bool* write, Delta* deltas) {
    T l0 = lin[0], l1 = lin[1], l2 = lin[2], l3 = _mm_setzero_ps();
    _MM_TRANSPOSE4_PS(l0, l1, l2, l3);
    T a0 = ang[0], a1 = ang[1], a2 = ang[2], a3 = _mm_setzero_ps();
    _MM_TRANSPOSE4_PS(a0, a1, a2, a3);
    const T ls[4] = {l0, l1, l2, l3}, as[4] = {a0, a1, a2, a3};
    for (int l = 0; l < 4; ++l) {
      if (!write[l]) continue;
      _mm_store_ps(deltas[body[l]].lin, ls[l]);
      _mm_store_ps(deltas[body[l]].ang, as[l]);
    }
  }
  // Δ · (1.0 / J) in double, rounded to float.
  static T residual(T impulse, const double* inverse_jac) {
    const __m128d low = _mm_mul_pd(_mm_cvtps_pd(impulse), _mm_load_pd(inverse_jac));
    const __m128d high = _mm_mul_pd(_mm_cvtps_pd(_mm_movehl_ps(impulse, impulse)), _mm_load_pd(inverse_jac + 2));
    return _mm_movelh_ps(_mm_cvtpd_ps(low), _mm_cvtpd_ps(high));
  }
  static void into(T largest, T nan, Residual& residual) {
    alignas(16) float values[4];
    alignas(16) std::uint32_t bad[4];
    _mm_store_ps(values, largest);
    _mm_store_ps(reinterpret_cast<float*>(bad), nan);
    for (int l = 0; l < 4; ++l) {
      if (bad[l]) residual.nan = true;
      if (values[l] > residual.max) residual.max = values[l];
    }
  }
};

#include "wide_kernel.h"

}  // namespace

void solve_group_sse2(bool friction, const Group& group, const Rows& rows, Residual& residual) {
  solve_group<V4>(friction, group, rows, residual);
}

}  // namespace wide

void WideRows::solve_group(bool friction, const Group& g, Residual& residual) {
  const wide::Rows rows{contacts_.data(), frictions_.data(), deltas_.data()};
  if (avx2_) {
    wide::solve_group_avx2(friction, g, rows, residual);
  } else {
    wide::solve_group_sse2(friction, g, rows, residual);
  }
}

#else

void WideRows::solve_group(bool, const Group&, Residual&) {
  throw std::logic_error("WideRows: not in this build (WideRows::applies is false)");
}

#endif

}  // namespace soda

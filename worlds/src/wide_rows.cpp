// The coloured sweeps four runs at a time (wide_rows.h).
#include "wide_rows.h"

#include <algorithm>
#include <stdexcept>

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
  float(*fields[6])[4] = {b.n1, b.r1, b.n2, b.r2, b.a1, b.a2};
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
                    const btAlignedObjectArray<btSolverBody>& bodies) {
  groups_.clear();
  contacts_.clear();
  frictions_.clear();
  group_of_run_.assign(runs.size(), -1);
  deltas_.resize(static_cast<std::size_t>(bodies.size()) + 1);
  load(bodies);
  deltas_.back() = Delta{};
  for (std::size_t c = 0; c + 1 < colour_begin.size(); ++c)
    for (int first = colour_begin[c]; first < colour_begin[c + 1]; first += 4)
      pack_group(runs, first, std::min(4, colour_begin[c + 1] - first), contacts, frictions, bodies);
}

void WideRows::pack_group(const std::vector<RunRows>& runs, int first, int count, const btConstraintArray& contacts,
                          const btConstraintArray& frictions, const btAlignedObjectArray<btSolverBody>& bodies) {
  Group g{};
  int contact_blocks = 0, friction_blocks = 0;
  for (int l = 0; l < count; ++l) {
    const RunRows& r = runs[static_cast<std::size_t>(first + l)];
    contact_blocks = std::max(contact_blocks, r.contact_end - r.contact_begin);
    friction_blocks = std::max(friction_blocks, r.friction_count);
  }
  g.contact_first = static_cast<int>(contacts_.size());
  g.contact_blocks = contact_blocks;
  g.friction_first = static_cast<int>(frictions_.size());
  g.friction_blocks = friction_blocks;
  Block empty{};
  std::fill(std::begin(empty.row), std::end(empty.row), -1);
  std::fill(std::begin(empty.contact), std::end(empty.contact), -1);
  contacts_.resize(contacts_.size() + static_cast<std::size_t>(contact_blocks), empty);
  frictions_.resize(frictions_.size() + static_cast<std::size_t>(friction_blocks), empty);
  const int spare = bodies.size();
  for (int l = 0; l < 4; ++l) g.body_a[l] = g.body_b[l] = spare;
  for (int l = 0; l < count; ++l) {
    const RunRows& r = runs[static_cast<std::size_t>(first + l)];
    group_of_run_[static_cast<std::size_t>(first + l)] = static_cast<int>(groups_.size());
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
  groups_.push_back(g);
}

void WideRows::unpack(btConstraintArray& contacts, btConstraintArray& frictions) const {
  for (const Block& b : contacts_)
    for (int l = 0; l < 4; ++l)
      if (b.row[l] >= 0) contacts[b.row[l]].m_appliedImpulse = b.applied[l];
  for (const Block& b : frictions_)
    for (int l = 0; l < 4; ++l)
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

void WideRows::store(btAlignedObjectArray<btSolverBody>& bodies) const {
  for (int i = 0; i < bodies.size(); ++i) store_one(deltas_[static_cast<std::size_t>(i)], bodies[i]);
}

void WideRows::load(const btAlignedObjectArray<btSolverBody>& bodies) {
  for (int i = 0; i < bodies.size(); ++i) load_one(bodies[i], deltas_[static_cast<std::size_t>(i)]);
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
  delta = Delta{{float(lin.x()), float(lin.y()), float(lin.z()), 0.f}, {float(ang.x()), float(ang.y()), float(ang.z()), 0.f}};
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

namespace {

// One side of four runs, lane by lane: the bodies' delta linear and
// angular velocities (x, y, z), their linear and angular factors.
struct Side {
  __m128 lin[3], ang[3];
  const float (*lf)[4];
  const float (*af)[4];
};

template <class Delta>
void gather(Side& s, const int body[4], const float (*lf)[4], const float (*af)[4], const Delta* deltas) {
  const Delta &d0 = deltas[body[0]], &d1 = deltas[body[1]], &d2 = deltas[body[2]], &d3 = deltas[body[3]];
  __m128 r0 = _mm_load_ps(d0.lin), r1 = _mm_load_ps(d1.lin), r2 = _mm_load_ps(d2.lin), r3 = _mm_load_ps(d3.lin);
  _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
  s.lin[0] = r0;
  s.lin[1] = r1;
  s.lin[2] = r2;
  r0 = _mm_load_ps(d0.ang), r1 = _mm_load_ps(d1.ang), r2 = _mm_load_ps(d2.ang), r3 = _mm_load_ps(d3.ang);
  _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
  s.ang[0] = r0;
  s.ang[1] = r1;
  s.ang[2] = r2;
  s.lf = lf;
  s.af = af;
}

// The lanes back to the bodies that take writes (w is unused).
template <class Delta>
void scatter(const Side& s, const int body[4], const bool write[4], Delta* deltas) {
  __m128 l0 = s.lin[0], l1 = s.lin[1], l2 = s.lin[2], l3 = _mm_setzero_ps();
  _MM_TRANSPOSE4_PS(l0, l1, l2, l3);
  __m128 a0 = s.ang[0], a1 = s.ang[1], a2 = s.ang[2], a3 = _mm_setzero_ps();
  _MM_TRANSPOSE4_PS(a0, a1, a2, a3);
  const __m128 lin[4] = {l0, l1, l2, l3}, ang[4] = {a0, a1, a2, a3};
  for (int l = 0; l < 4; ++l) {
    if (!write[l]) continue;
    _mm_store_ps(deltas[body[l]].lin, lin[l]);
    _mm_store_ps(deltas[body[l]].ang, ang[l]);
  }
}

// btVector3::dot lane by lane: (x·x' + y·y') + z·z'.
inline __m128 dot3(const float (*a)[4], const __m128* b) {
  return _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_load_ps(a[0]), b[0]), _mm_mul_ps(_mm_load_ps(a[1]), b[1])),
                    _mm_mul_ps(_mm_load_ps(a[2]), b[2]));
}

inline __m128 blend(__m128 mask, __m128 yes, __m128 no) {
  return _mm_or_ps(_mm_and_ps(mask, yes), _mm_andnot_ps(mask, no));
}

// btSolverBody::internalApplyImpulse lane by lane, where mask is set:
// lin += (l · Δ) ∘ linear factor, ang += a ∘ (Δ · angular factor), l the
// row's linear component n ∘ m⁻¹.
inline void apply(Side& s, const float (*l)[4], const float (*a)[4], __m128 impulse, __m128 mask) {
  for (int k = 0; k < 3; ++k) {
    const __m128 lin = _mm_mul_ps(_mm_mul_ps(_mm_load_ps(l[k]), impulse), _mm_load_ps(s.lf[k]));
    const __m128 ang = _mm_mul_ps(_mm_load_ps(a[k]), _mm_mul_ps(impulse, _mm_load_ps(s.af[k])));
    s.lin[k] = blend(mask, _mm_add_ps(s.lin[k], lin), s.lin[k]);
    s.ang[k] = blend(mask, _mm_add_ps(s.ang[k], ang), s.ang[k]);
  }
}

// One block of rows, as gResolveSingleConstraintRow{LowerLimit,Generic}_
// scalar_reference lane by lane; `mask`: the lanes that solve. Leaves the
// lanes' final impulses in `impulse_out`.
template <class Block>
inline __attribute__((always_inline)) void solve_block(Block& b, Side& a, Side& o, __m128 mask, __m128 lower, __m128 upper, bool generic,
                 __m128& impulse_out) {
  const __m128 applied = _mm_load_ps(b.applied);
  const __m128 jac = _mm_load_ps(b.jac);
  __m128 impulse = _mm_sub_ps(_mm_load_ps(b.rhs), _mm_mul_ps(applied, _mm_load_ps(b.cfm)));
  const __m128 d1 = _mm_add_ps(dot3(b.n1, a.lin), dot3(b.r1, a.ang));
  const __m128 d2 = _mm_add_ps(dot3(b.n2, o.lin), dot3(b.r2, o.ang));
  impulse = _mm_sub_ps(impulse, _mm_mul_ps(d1, jac));
  impulse = _mm_sub_ps(impulse, _mm_mul_ps(d2, jac));
  const __m128 sum = _mm_add_ps(applied, impulse);
  const __m128 below = _mm_cmplt_ps(sum, lower);
  __m128 result = sum;
  if (generic) {
    const __m128 above = _mm_andnot_ps(below, _mm_cmpgt_ps(sum, upper));
    impulse = blend(above, _mm_sub_ps(upper, applied), impulse);
    result = blend(above, upper, result);
  }
  impulse = blend(below, _mm_sub_ps(lower, applied), impulse);
  result = blend(below, lower, result);
  _mm_store_ps(b.applied, blend(mask, result, applied));
  apply(a, b.l1, b.a1, impulse, mask);
  apply(o, b.l2, b.a2, impulse, mask);
  impulse_out = impulse;
}

// The rows' residuals as the row functions return them, Δ · (1.0 / J) in
// double rounded to float, squared: into `largest` where `mask` is set and
// the square is a number, into `nan` where it is not. (The maximum of the
// squares, never below +0, does not depend on the order it is taken in.)
struct Residuals {
  __m128 largest = _mm_setzero_ps();
  __m128 nan = _mm_setzero_ps();
  void add(__m128 impulse, const double* inverse_jac, __m128 mask) {
    const __m128d low = _mm_mul_pd(_mm_cvtps_pd(impulse), _mm_load_pd(inverse_jac));
    const __m128d high = _mm_mul_pd(_mm_cvtps_pd(_mm_movehl_ps(impulse, impulse)), _mm_load_pd(inverse_jac + 2));
    const __m128 r = _mm_movelh_ps(_mm_cvtpd_ps(low), _mm_cvtpd_ps(high));
    const __m128 square = _mm_mul_ps(r, r);
    const __m128 bad = _mm_cmpunord_ps(square, square);
    nan = _mm_or_ps(nan, _mm_and_ps(mask, bad));
    largest = _mm_max_ps(largest, _mm_and_ps(_mm_andnot_ps(bad, mask), square));
  }
  template <class Residual>
  void into(Residual& residual) const {
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

}  // namespace

void WideRows::solve_group(bool friction, const Group& g, Residual& residual) {
  Side a, o;
  gather(a, g.body_a, g.lf_a, g.af_a, deltas_.data());
  gather(o, g.body_b, g.lf_b, g.af_b, deltas_.data());
  Residuals residuals;
  if (!friction) {
    for (int k = 0; k < g.contact_blocks; ++k) {
      Block& b = contacts_[static_cast<std::size_t>(g.contact_first + k)];
      const __m128 mask = _mm_load_ps(reinterpret_cast<const float*>(b.valid));
      __m128 impulse;
      solve_block(b, a, o, mask, _mm_load_ps(b.lower), _mm_load_ps(b.upper), false, impulse);
      residuals.add(impulse, b.inverse_jac, mask);
    }
  } else {
    const __m128 sign = _mm_set1_ps(-0.0f);
    for (int k = 0; k < g.friction_blocks; ++k) {
      Block& b = frictions_[static_cast<std::size_t>(g.friction_first + k)];
      alignas(16) float total[4];
      for (int l = 0; l < 4; ++l)
        total[l] = b.contact[l] >= 0 ? contacts_[static_cast<std::size_t>(b.contact[l])].applied[l] : 0.0f;
      const __m128 t = _mm_load_ps(total);
      const __m128 mask =
          _mm_and_ps(_mm_load_ps(reinterpret_cast<const float*>(b.valid)), _mm_cmpgt_ps(t, _mm_setzero_ps()));
      const __m128 limit = _mm_mul_ps(_mm_load_ps(b.friction), t);
      const __m128 lower = blend(mask, _mm_xor_ps(limit, sign), _mm_load_ps(b.lower));
      const __m128 upper = blend(mask, limit, _mm_load_ps(b.upper));
      _mm_store_ps(b.lower, lower);
      _mm_store_ps(b.upper, upper);
      __m128 impulse;
      solve_block(b, a, o, mask, lower, upper, true, impulse);
      residuals.add(impulse, b.inverse_jac, mask);
    }
  }
  residuals.into(residual);
  scatter(a, g.body_a, g.write_a, deltas_.data());
  scatter(o, g.body_b, g.write_b, deltas_.data());
}

#else

void WideRows::solve_group(bool, const Group&, Residual&) {
  throw std::logic_error("WideRows: not in this build (WideRows::applies is false)");
}

#endif

}  // namespace soda

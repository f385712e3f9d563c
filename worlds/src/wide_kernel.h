// Internal: the wide rows' kernel, written once for any lane width. Each
// kernel's file (wide_rows.cpp: SSE2, wide_rows_avx2.cpp: AVX2) defines a
// struct V of its vector operations and then includes this header inside an
// anonymous namespace, so each instantiation stays in its own file.
//
// V provides: T (the vector), kWidth (its lanes: 4 or 8), load / store
// (aligned), zero, sign (-0.0f in every lane), add, sub, mul, lt, gt (ordered
// comparisons), and_, andnot (~a & b), or_, xor_, max, unordered, any (some
// lane's mask set), gather / scatter (a lane per body of the compact
// deltas), residual (Δ · (1.0 / J) in double, rounded to float) and into
// (the lanes' residuals into a Residual).
//
// Every lane computes what Bullet's row functions compute for its row
// (wide_rows.h has the operations and their order); a lane that does not
// solve keeps its row and bodies exactly as they were (blended, never a zero
// added).
//
// Requires wide_lanes.h, included by the file before its anonymous namespace.

// One side of the lanes [o, o + kWidth) of a group: the bodies' velocity
// changes and the lanes' linear and angular factors.
template <class V>
struct Side {
  typename V::T lin[3], ang[3];
  const float* lf[3];
  const float* af[3];
};

template <class V>
Side<V> gather_side(const int* body, const float (*lf)[kLanes], const float (*af)[kLanes], int o,
                    const Delta* deltas) {
  Side<V> s;
  V::gather(deltas, body + o, s.lin, s.ang);
  for (int k = 0; k < 3; ++k) {
    s.lf[k] = lf[k] + o;
    s.af[k] = af[k] + o;
  }
  return s;
}

// btVector3::dot lane by lane: (x·x' + y·y') + z·z'.
template <class V>
inline typename V::T dot3(const float (*a)[kLanes], int o, const typename V::T* b) {
  return V::add(V::add(V::mul(V::load(a[0] + o), b[0]), V::mul(V::load(a[1] + o), b[1])),
                V::mul(V::load(a[2] + o), b[2]));
}

template <class V>
inline typename V::T blend(typename V::T mask, typename V::T yes, typename V::T no) {
  return V::or_(V::and_(mask, yes), V::andnot(mask, no));
}

// btSolverBody::internalApplyImpulse lane by lane, where mask is set:
// lin += (l · Δ) ∘ linear factor, ang += a ∘ (Δ · angular factor), l the
// row's linear component n ∘ m⁻¹.
template <class V>
inline void apply(Side<V>& s, const float (*l)[kLanes], const float (*a)[kLanes], int o, typename V::T impulse,
                  typename V::T mask) {
  for (int k = 0; k < 3; ++k) {
    const typename V::T lin = V::mul(V::mul(V::load(l[k] + o), impulse), V::load(s.lf[k]));
    const typename V::T ang = V::mul(V::load(a[k] + o), V::mul(impulse, V::load(s.af[k])));
    s.lin[k] = blend<V>(mask, V::add(s.lin[k], lin), s.lin[k]);
    s.ang[k] = blend<V>(mask, V::add(s.ang[k], ang), s.ang[k]);
  }
}

// The rows' residuals, squared: into `largest` where `mask` is set and the
// square is a number, into `nan` where it is not. (The maximum of the
// squares, never below +0, does not depend on the order it is taken in.)
template <class V>
struct Residuals {
  typename V::T largest = V::zero();
  typename V::T nan = V::zero();
  void add(typename V::T impulse, const double* inverse_jac, typename V::T mask) {
    const typename V::T r = V::residual(impulse, inverse_jac);
    const typename V::T square = V::mul(r, r);
    const typename V::T bad = V::unordered(square, square);
    nan = V::or_(nan, V::and_(mask, bad));
    largest = V::max(largest, V::and_(V::andnot(bad, mask), square));
  }
};

// One block's lanes [o, o + kWidth), as gResolveSingleConstraintRow
// {LowerLimit,Generic}_scalar_reference lane by lane; `mask`: the lanes
// that solve. Returns the lanes' impulses.
template <class V>
inline typename V::T solve_block(Block& b, int o, Side<V>& a, Side<V>& z, typename V::T mask, typename V::T lower,
                                 typename V::T upper, bool generic) {
  using T = typename V::T;
  const T applied = V::load(b.applied + o);
  const T jac = V::load(b.jac + o);
  T impulse = V::sub(V::load(b.rhs + o), V::mul(applied, V::load(b.cfm + o)));
  const T d1 = V::add(dot3<V>(b.n1, o, a.lin), dot3<V>(b.r1, o, a.ang));
  const T d2 = V::add(dot3<V>(b.n2, o, z.lin), dot3<V>(b.r2, o, z.ang));
  impulse = V::sub(impulse, V::mul(d1, jac));
  impulse = V::sub(impulse, V::mul(d2, jac));
  const T sum = V::add(applied, impulse);
  const T below = V::lt(sum, lower);
  T result = sum;
  if (generic) {
    const T above = V::andnot(below, V::gt(sum, upper));
    impulse = blend<V>(above, V::sub(upper, applied), impulse);
    result = blend<V>(above, upper, result);
  }
  impulse = blend<V>(below, V::sub(lower, applied), impulse);
  result = blend<V>(below, lower, result);
  V::store(b.applied + o, blend<V>(mask, result, applied));
  apply<V>(a, b.l1, b.a1, o, impulse, mask);
  apply<V>(z, b.l2, b.a2, o, impulse, mask);
  return impulse;
}

// A group's contact rows, or its friction rows with their limits from the
// contacts' impulses, kWidth lanes at a time: each block's parts (lanes
// [o, o + kWidth)) one after the other, so that a block is read once
// whatever the width; parts without a run are left out. A block part none
// of whose lanes solves changes nothing, so it is skipped.
template <class V>
void solve_group(bool friction, const Group& g, const Rows& rows, Residual& residual) {
  using T = typename V::T;
  constexpr int kParts = kLanes / V::kWidth;
  const int parts = (g.runs + V::kWidth - 1) / V::kWidth;
  Side<V> a[kParts]{}, z[kParts]{};
  for (int p = 0; p < parts; ++p) {
    a[p] = gather_side<V>(g.body_a, g.lf_a, g.af_a, p * V::kWidth, rows.deltas);
    z[p] = gather_side<V>(g.body_b, g.lf_b, g.af_b, p * V::kWidth, rows.deltas);
  }
  Residuals<V> residuals;
  if (!friction) {
    for (int k = 0; k < g.contact_blocks; ++k) {
      Block& b = rows.contacts[g.contact_first + k];
      for (int p = 0, o = 0; p < parts; ++p, o += V::kWidth) {
        const T mask = V::load(reinterpret_cast<const float*>(b.valid + o));
        if (!V::any(mask)) continue;
        const T impulse = solve_block<V>(b, o, a[p], z[p], mask, V::load(b.lower + o), V::load(b.upper + o), false);
        residuals.add(impulse, b.inverse_jac + o, mask);
      }
    }
  } else {
    for (int k = 0; k < g.friction_blocks; ++k) {
      Block& b = rows.frictions[g.friction_first + k];
      for (int p = 0, o = 0; p < parts; ++p, o += V::kWidth) {
        alignas(32) float total[V::kWidth];
        for (int l = 0; l < V::kWidth; ++l) {
          const int c = b.contact[o + l];
          total[l] = c >= 0 ? rows.contacts[c].applied[o + l] : 0.0f;
        }
        const T t = V::load(total);
        const T mask = V::and_(V::load(reinterpret_cast<const float*>(b.valid + o)), V::gt(t, V::zero()));
        if (!V::any(mask)) continue;
        const T limit = V::mul(V::load(b.friction + o), t);
        const T lower = blend<V>(mask, V::xor_(limit, V::sign()), V::load(b.lower + o));
        const T upper = blend<V>(mask, limit, V::load(b.upper + o));
        V::store(b.lower + o, lower);
        V::store(b.upper + o, upper);
        const T impulse = solve_block<V>(b, o, a[p], z[p], mask, lower, upper, true);
        residuals.add(impulse, b.inverse_jac + o, mask);
      }
    }
  }
  V::into(residuals.largest, residuals.nan, residual);
  for (int p = 0, o = 0; p < parts; ++p, o += V::kWidth) {
    V::scatter(a[p].lin, a[p].ang, g.body_a + o, g.write_a + o, rows.deltas);
    V::scatter(z[p].lin, z[p].ang, g.body_b + o, g.write_b + o, rows.deltas);
  }
}

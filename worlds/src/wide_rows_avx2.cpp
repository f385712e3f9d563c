// The wide rows' AVX2 kernel: eight lanes at a time (wide_lanes.h). This
// file alone is compiled with -mavx2 (worlds/CMakeLists.txt; no FMA, and
// -ffp-contract=off as everywhere): it includes nothing but the lane layout
// and the intrinsics, so no inline function of the rest of the program is
// ever compiled here with AVX instructions. Runs only where the CPU says it
// has AVX2 (avx2_supported).
#include "wide_lanes.h"

#if defined(__AVX2__)

#include <immintrin.h>

namespace soda::wide {
namespace {

// AVX2's operations for the kernel (wide_kernel.h): eight lanes. The same
// IEEE operations, comparisons (ordered, quiet) and conversions as SSE2's.
struct V8 {
  using T = __m256;
  static constexpr int kWidth = 8;
  static T load(const float* p) { return _mm256_load_ps(p); }
  static void store(float* p, T v) { _mm256_store_ps(p, v); }
  static T zero() { return _mm256_setzero_ps(); }
  static T sign() { return _mm256_set1_ps(-0.0f); }
  static T add(T a, T b) { return _mm256_add_ps(a, b); }
  static T sub(T a, T b) { return _mm256_sub_ps(a, b); }
  static T mul(T a, T b) { return _mm256_mul_ps(a, b); }
  static T lt(T a, T b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
  static T gt(T a, T b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
  static T and_(T a, T b) { return _mm256_and_ps(a, b); }
  static T andnot(T a, T b) { return _mm256_andnot_ps(a, b); }
  static T or_(T a, T b) { return _mm256_or_ps(a, b); }
  static T xor_(T a, T b) { return _mm256_xor_ps(a, b); }
  static T max(T a, T b) { return _mm256_max_ps(a, b); }
  static T unordered(T a, T b) { return _mm256_cmp_ps(a, b, _CMP_UNORD_Q); }
  static bool any(T mask) { return _mm256_movemask_ps(mask) != 0; }

  // Four bodies' x, y, z as three vectors of four lanes.
  static void transpose_in(const float* p0, const float* p1, const float* p2, const float* p3, __m128 out[3]) {
    __m128 r0 = _mm_load_ps(p0), r1 = _mm_load_ps(p1), r2 = _mm_load_ps(p2), r3 = _mm_load_ps(p3);
    _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
    out[0] = r0, out[1] = r1, out[2] = r2;
  }
  static void gather(const Delta* deltas, const int* body, T lin[3], T ang[3]) {
    const Delta* d[8];
    for (int l = 0; l < 8; ++l) d[l] = &deltas[body[l]];
    __m128 lo[3], hi[3];
    transpose_in(d[0]->lin, d[1]->lin, d[2]->lin, d[3]->lin, lo);
    transpose_in(d[4]->lin, d[5]->lin, d[6]->lin, d[7]->lin, hi);
    for (int k = 0; k < 3; ++k) lin[k] = _mm256_set_m128(hi[k], lo[k]);
    transpose_in(d[0]->ang, d[1]->ang, d[2]->ang, d[3]->ang, lo);
    transpose_in(d[4]->ang, d[5]->ang, d[6]->ang, d[7]->ang, hi);
    for (int k = 0; k < 3; ++k) ang[k] = _mm256_set_m128(hi[k], lo[k]);
  }
  // Lanes [half * 4, half * 4 + 4) of x, y, z as four bodies' vectors (w 0).
  static void transpose_out(const T v[3], int half, __m128 out[4]) {
    __m128 r[4];
    for (int k = 0; k < 3; ++k) r[k] = half ? _mm256_extractf128_ps(v[k], 1) : _mm256_castps256_ps128(v[k]);
    r[3] = _mm_setzero_ps();
    _MM_TRANSPOSE4_PS(r[0], r[1], r[2], r[3]);
    for (int l = 0; l < 4; ++l) out[l] = r[l];
  }
  static void scatter(const T lin[3], const T ang[3], const int* body, const bool* write, Delta* deltas) {
    for (int half = 0; half < 2; ++half) {
      __m128 ls[4], as[4];
      transpose_out(lin, half, ls);
      transpose_out(ang, half, as);
      for (int l = 0; l < 4; ++l) {
        if (!write[half * 4 + l]) continue;
        _mm_store_ps(deltas[body[half * 4 + l]].lin, ls[l]);
        _mm_store_ps(deltas[body[half * 4 + l]].ang, as[l]);
      }
    }
  }
  // Δ · (1.0 / J) in double, rounded to float.
  static T residual(T impulse, const double* inverse_jac) {
    const __m256d low = _mm256_mul_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(impulse)), _mm256_load_pd(inverse_jac));
    const __m256d high =
        _mm256_mul_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(impulse, 1)), _mm256_load_pd(inverse_jac + 4));
    return _mm256_set_m128(_mm256_cvtpd_ps(high), _mm256_cvtpd_ps(low));
  }
  static void into(T largest, T nan, Residual& residual) {
    alignas(32) float values[8];
    _mm256_store_ps(values, largest);
    if (_mm256_movemask_ps(nan)) residual.nan = true;
    for (int l = 0; l < 8; ++l)
      if (values[l] > residual.max) residual.max = values[l];
  }
};

#include "wide_kernel.h"

}  // namespace

void solve_group_avx2(bool friction, const Group& group, const Rows& rows, Residual& residual) {
  solve_group<V8>(friction, group, rows, residual);
}

bool avx2_supported() { return __builtin_cpu_supports("avx2"); }

}  // namespace soda::wide

#else

namespace soda::wide {

// Not compiled for AVX2 (not x86-64): never taken.
void solve_group_avx2(bool, const Group&, const Rows&, Residual&) {}
bool avx2_supported() { return false; }

}  // namespace soda::wide

#endif

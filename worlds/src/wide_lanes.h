// Internal: the lane layout of the wide rows (wide_rows.h) and its two
// kernels, SSE2 (four lanes at a time, every x86-64) and AVX2 (eight at a
// time, where the CPU has it; wide_rows_avx2.cpp). Plain data only: the
// AVX2 kernel's file is compiled with -mavx2 and must not share an inline
// function with the rest of the program (the linker may keep either copy of
// one), so this header includes nothing that defines one.
//
// The kernels compute the same operations lane by lane (wide_kernel.h), so
// the bits do not depend on which one runs: a group of eight runs solved
// four lanes at a time (each block's two halves one after the other) or
// eight at once gives each run the same results, since no two runs of a
// group share a dynamic body.
#pragma once

#include <cstdint>

namespace soda::wide {

/// Runs per group: lane l of every vector of a group belongs to its run l.
constexpr int kLanes = 8;

/// One row of each of the eight runs of a group.
struct alignas(32) Block {
  float n1[3][kLanes], r1[3][kLanes], n2[3][kLanes], r2[3][kLanes], a1[3][kLanes], a2[3][kLanes];
  float l1[3][kLanes], l2[3][kLanes];  // n1 ∘ m⁻¹ of body a, n2 ∘ m⁻¹ of body b: Bullet's "linear component"
  float rhs[kLanes], cfm[kLanes], jac[kLanes], applied[kLanes], lower[kLanes], upper[kLanes], friction[kLanes];
  double inverse_jac[kLanes];    // 1.0 / jac in double, as the row functions' residual takes it
  std::uint32_t valid[kLanes];   // all ones where the lane has a row
  int row[kLanes];               // the row's index in its pool (-1: none)
  int contact[kLanes];           // friction rows: the contact block holding their contact row (same lane)
};

/// Eight runs of one colour.
struct alignas(32) Group {
  float lf_a[3][kLanes], af_a[3][kLanes], lf_b[3][kLanes], af_b[3][kLanes];  // the bodies' linear, angular factors
  int body_a[kLanes], body_b[kLanes];  // into the deltas (the spare zero entry: no run in this lane)
  bool write_a[kLanes], write_b[kLanes];  // the lane's body has an original body
  int runs;  // lanes [0, runs) hold a run
  int contact_first, contact_blocks;
  int friction_first, friction_blocks;
};

/// One solver body's velocity changes, x y z (w unused).
struct alignas(32) Delta {
  float lin[4], ang[4];
};

/// What a group's sweep reads and writes besides the group.
struct Rows {
  Block* contacts;
  Block* frictions;
  Delta* deltas;
};

/// The largest squared row residual of a sweep part, NaN sticky.
struct Residual {
  float max = 0;
  bool nan = false;
};

/// One group's contact rows (friction: false) or friction rows.
void solve_group_sse2(bool friction, const Group& group, const Rows& rows, Residual& residual);
/// The same, eight lanes at a time. Only where avx2_supported().
void solve_group_avx2(bool friction, const Group& group, const Rows& rows, Residual& residual);
/// This build has the AVX2 kernel and this CPU runs it.
bool avx2_supported();

}  // namespace soda::wide

// loadbalance/ — the cost model: a world's busy time per internal step
// predicted from what it holds, and so the cost of each cell
// (docs/loadbalance.md, "Cost model").
//
//   busy ≈ overhead + per_body · bodies + per_awake · awake_bodies
//                   + per_pair · contact_pairs + per_triangle · body_triangles
//
// Every body pays per_body (asleep bodies still cost Bullet's per-body loops),
// awake bodies per_awake more (prediction, broadphase, integration), and
// every contact pair per_pair (narrowphase and solve), and every awake body
// per_triangle for each triangle of level geometry within its home cell's
// reach (body_triangles: the concave narrowphase tests the triangles under
// a body's box). overhead is the per-step
// cost of a world that holds nothing (messages, bookkeeping); it belongs to
// the world, not to a cell, so cell_cost() leaves it out.
//
// fit() takes least squares over samples (one per world and period), pulled
// gently towards the prior (ridge) so that a direction the data cannot see —
// awake == bodies in every sample, no contacts yet — keeps the prior's value,
// and keeps every coefficient >= 0 (a negative cost would make cells with
// more work look cheaper). With fewer than kMinFitSamples samples it returns
// the prior unchanged.
//
// Thread safety: plain values and pure functions.
#pragma once

#include <span>
#include <vector>

#include "soda/loadbalance/policy.h"

namespace soda {

/// Coefficients of the model, seconds per internal step (per item).
struct CostCoefficients {
  double overhead = 0;   // per world
  double per_body = 0;   // per dynamic body owned
  double per_awake = 0;  // per awake body, on top of per_body
  double per_pair = 0;   // per contact pair (manifold with points)
  double per_triangle = 0;  // per awake body and triangle within its home cell's reach
  friend bool operator==(const CostCoefficients&, const CostCoefficients&) = default;
};

/// The documented prior (docs/loadbalance.md, "Cost model", measured on the
/// float build, Release, on the 2-core CI machine class): 20 µs per world
/// and step (an idle world of an 8-territory hotspot run: 19 µs), 0.05 µs
/// per body (420 sleeping cubes: 0.01 ms per step), 3.5 µs more per awake
/// body and 1.5 µs per contact pair (fits over hotspot, avalanche,
/// falling-cubes and alternating-load in one world: 3.3–9.1 and 0.8–3.4 µs);
/// per_triangle is kTriangleWeight of an awake body's per_body + per_awake
/// (callgrind, docs/loadbalance.md "Triangles").
inline constexpr CostCoefficients kPriorCost{20e-6, 0.05e-6, 3.5e-6, 1.5e-6, kTriangleWeight * (0.05e-6 + 3.5e-6)};

/// Fewest samples fit() uses: two per coefficient, so that one odd period
/// cannot set a coefficient alone.
inline constexpr int kMinFitSamples = 8;

/// One measurement: what a world held and its busy time per internal step.
struct CostSample {
  double bodies = 0;
  double awake_bodies = 0;
  double contact_pairs = 0;
  double busy = 0;  // s per internal step
  double body_triangles = 0;
};

/// The sample a WorldLoad gives (bodies, awake, pairs, body triangles at the
/// balance step; busy over the period).
CostSample cost_sample(const WorldLoad& load);

/// How well a model predicts busy times: |predicted - measured| / measured
/// over samples with measured > 0.
struct CostFitQuality {
  int samples = 0;                  // samples with busy > 0
  double mean_relative_error = 0;   // mean of |error| / busy
  double max_relative_error = 0;
  /// sum |error| / sum busy: the error on the time that matters (a world
  /// with almost nothing to do weighs little, however far off in relative
  /// terms its prediction is).
  double weighted_relative_error = 0;
};

class CostModel {
 public:
  /// The prior.
  CostModel() : coefficients_(kPriorCost) {}
  explicit CostModel(const CostCoefficients& c, bool fitted = false)
      : coefficients_(c), fitted_(fitted) {}

  /// Least squares over samples, ridge-pulled towards `prior`, coefficients
  /// >= 0 (header comment). The prior itself (fitted() false) below
  /// kMinFitSamples samples.
  static CostModel fit(std::span<const CostSample> samples, const CostCoefficients& prior = kPriorCost);

  const CostCoefficients& coefficients() const { return coefficients_; }
  /// True when fit() had data enough; false for the prior.
  bool fitted() const { return fitted_; }

  /// Predicted busy time per internal step of a world holding these, s.
  double predict(double bodies, double awake_bodies, double contact_pairs, double body_triangles = 0) const;
  double predict(const WorldLoad& load) const;
  /// Cost of one cell, s per internal step (no overhead: a cell's share).
  double cell_cost(const CellLoad& cell) const;
  /// Prediction error over the samples (busy > 0 only).
  CostFitQuality quality(std::span<const CostSample> samples) const;

 private:
  CostCoefficients coefficients_;
  bool fitted_ = false;
};

}  // namespace soda

// loadbalance/ — the monitor every measuring policy keeps: smoothed loads,
// their classes, and the cost model refitted over recent periods
// (docs/loadbalance.md, "Metrics and thresholds", "Cost model").
//
// A LoadMonitor is a pure function of the views it was given, in order: an
// experiment harness that feeds its own monitor the same views sees exactly
// what a policy saw (the smoothed loads, the classes, the model and how well
// it predicted).
//
// Thread safety: one thread at a time.
#pragma once

#include <cstdint>
#include <deque>
#include <vector>

#include "soda/loadbalance/cost_model.h"
#include "soda/loadbalance/load_metrics.h"

namespace soda {

/// Periods of samples the cost model is fitted over: long enough to see a
/// few different loads per world (K worlds give K samples per period), short
/// enough to follow a scene whose costs change (sleeping piles, new
/// contacts). 8 periods of the default 20 steps: 160 steps, under 3 s.
inline constexpr int kCostHistoryPeriods = 8;

class LoadMonitor {
 public:
  explicit LoadMonitor(const BalanceOptions& options);

  /// Takes one balance period: first measures how well the current model
  /// predicts this period's busy times (out of sample), then updates the
  /// smoothed loads and classes and refits the model with this period's
  /// samples added.
  void update(const LoadView& view);

  /// After a policy moved cells: world w's load is now estimated at
  /// estimates[w] (s per internal step); the smoothed value and its history
  /// shift to it (LoadSmoother::shift), and classes and mean follow.
  void account_moves(const std::vector<double>& estimates);

  /// Smoothed busy time per world, s per internal step (LoadSmoother).
  const std::vector<double>& smoothed() const { return smoother_.smoothed(); }
  /// Class of each world's smoothed load against the mean.
  const std::vector<LoadClass>& classes() const { return classes_; }
  /// Mean of smoothed().
  double mean() const { return mean_; }
  /// The model fitted over the last kCostHistoryPeriods periods (the prior
  /// before enough samples).
  const CostModel& model() const { return model_; }
  /// How well the model before the last update() predicted that period's
  /// measured busy times (samples 0 before any model had data to predict).
  const CostFitQuality& last_prediction() const { return last_prediction_; }
  /// Balance periods taken.
  std::int64_t periods() const { return smoother_.periods(); }

 private:
  void reclassify();

  BalanceOptions options_;
  LoadSmoother smoother_;
  std::vector<LoadClass> classes_;
  double mean_ = 0;
  std::deque<std::vector<CostSample>> history_;  // newest last
  CostModel model_;
  CostFitQuality last_prediction_;
};

}  // namespace soda

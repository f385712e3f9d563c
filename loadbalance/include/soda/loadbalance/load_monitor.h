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
/// Largest factor between a world's measured and predicted load that the
/// calibration follows: beyond it the model is missing something (a merged
/// island solved elsewhere, a cold start) and the factor mostly carries
/// noise.
inline constexpr double kCalibrationLimit = 4.0;
/// Weight of the whole scene's calibration in each world's, as a share of
/// the mean smoothed prediction: kappa_w = (measured_w + p * kappa_all) /
/// (predicted_w + p), p = kCalibrationPrior x mean predicted, kappa_all =
/// sum measured / sum predicted. A world that held its share of the load
/// keeps 80 % of its own ratio; one that held next to nothing (its
/// measurement mostly overhead and timer noise) takes the scene's.
inline constexpr double kCalibrationPrior = 0.25;

class LoadMonitor {
 public:
  explicit LoadMonitor(const BalanceOptions& options);

  /// Takes one balance period: first measures how well the current model
  /// predicts this period's busy times (out of sample), then updates the
  /// smoothed loads, refits the model (each world's median sample of its
  /// last three periods added: spike-free), and updates the smoothed
  /// predictions, the estimates and their classes.
  void update(const LoadView& view);

  /// Smoothed measured busy time per world, s per internal step
  /// (LoadSmoother).
  const std::vector<double>& smoothed() const { return busy_.smoothed(); }
  /// The load each world holds now, s per internal step: the model's
  /// prediction for what it holds at the balance step, times its
  /// calibration kappa = smoothed measured / smoothed predicted load,
  /// shrunk towards the scene's (kCalibrationPrior) and clamped to
  /// [1/kCalibrationLimit, kCalibrationLimit]. The contents are
  /// fresh — bodies that moved in during the period count, cells a policy
  /// moved count where they are now — while the scale comes from the
  /// measurements, smoothed so that a spike does not move it. With no
  /// prediction (nothing held, no model) the smoothed measurement itself.
  const std::vector<double>& estimated() const { return estimated_; }
  /// Class of each world's estimated load against the mean.
  const std::vector<LoadClass>& classes() const { return classes_; }
  /// Mean of estimated().
  double mean() const { return mean_; }
  /// The model fitted over the last kCostHistoryPeriods periods (the prior
  /// before enough samples).
  const CostModel& model() const { return model_; }
  /// How well the model before the last update() predicted that period's
  /// measured busy times (samples 0 before any model had data to predict).
  const CostFitQuality& last_prediction() const { return last_prediction_; }
  /// Balance periods taken.
  std::int64_t periods() const { return busy_.periods(); }

 private:
  BalanceOptions options_;
  LoadSmoother busy_;       // measured
  LoadSmoother predicted_;  // the model's prediction for the same periods
  std::vector<double> estimated_;
  std::vector<LoadClass> classes_;
  double mean_ = 0;
  std::vector<std::deque<CostSample>> recent_;   // per world, its last three periods
  std::deque<std::vector<CostSample>> history_;  // the fit's samples per period, newest last
  CostModel model_;
  CostFitQuality last_prediction_;
};

}  // namespace soda

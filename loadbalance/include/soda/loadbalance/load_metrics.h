// loadbalance/ — load metrics: a world's load smoothed over balance periods
// and classified against the mean (docs/loadbalance.md, "Metrics and
// thresholds").
//
// The thesis' discrete-step metric (§3.3.1) is JDT / TTS: time spent
// computing the step to be rendered over the thread's total time. With fixed
// steps every world must reach every balance step, so the time a world
// spends per step is what slows the others: the load of world i is its busy
// CPU per internal step (WorldLoad::busy, restores and re-runs included),
// and its load ratio is busy_i / mean_j busy_j. busy / (busy + wait) — the
// share of the world's wall time spent working — is JDT / TTS itself and is
// reported (utilisation()), but not used to classify: on a machine with
// fewer cores than worlds a world's wall time includes time it was runnable
// but not running, which is neither work nor waiting for neighbours.
//
// Smoothing (LoadSmoother): a median of the last three periods, then an
// exponential moving average. The median removes a single-period spike
// whatever its height (one sample of three); the average damps the rest.
// So one spike never flips a classification and cells do not move back and
// forth after it; a lasting change shows after two periods.
//
// Thread safety: values and functions here are not synchronised; a
// LoadSmoother is used by one thread at a time.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "soda/loadbalance/policy.h"

namespace soda {

/// A world's load against the mean (§3.3.1's levels, on smoothed busy time).
enum class LoadClass { Underloaded, Normal, Overloaded };

/// "underloaded" | "normal" | "overloaded".
const char* load_class_name(LoadClass load_class);

/// Class of each load: Overloaded above overload x mean, Underloaded below
/// underload x mean, else Normal. All Normal when the mean is 0 (nothing to
/// balance) or there is one load. Units: any, the same for every load.
std::vector<LoadClass> classify(std::span<const double> loads, double underload, double overload);

/// max / mean of the loads (1 = even; 1 for an empty list or a zero mean).
double imbalance(std::span<const double> loads);

/// JDT / TTS for discrete steps: busy / (busy + wait), in [0, 1]; 0 when
/// both are 0.
double utilisation(const WorldLoad& load);

/// Smoothed busy time per world: the median of the world's last three
/// periods (of the ones seen so far: one, itself; two, the smaller), then an
/// exponential moving average with weight `smoothing` for the newest median.
/// The first period sets the average. A world that measured no step in a
/// period (WorldLoad::steps == 0) keeps its smoothed value.
class LoadSmoother {
 public:
  /// smoothing in (0, 1] (BalanceOptions::smoothing); not checked here
  /// (make_balance_policy checks options).
  explicit LoadSmoother(double smoothing) : smoothing_(smoothing) {}

  /// Takes one period's measurements; returns the smoothed busy time per
  /// world (seconds per internal step), indexed by world id. The world count
  /// is taken from the first view; a view with a different count restarts
  /// the history.
  const std::vector<double>& update(const LoadView& view);
  /// The values update() last returned (empty before the first update).
  const std::vector<double>& smoothed() const { return smoothed_; }
  /// Number of updates taken since the (re)start.
  std::int64_t periods() const { return periods_; }

 private:
  struct History {
    std::array<double, 3> last{};  // the last three periods' busy times
    int next = 0;                  // slot the next period overwrites
    int count = 0;                 // periods held, up to 3
  };
  double filtered(const History& h) const;

  double smoothing_;
  std::vector<History> history_;
  std::vector<double> smoothed_;
  std::int64_t periods_ = 0;
};

}  // namespace soda

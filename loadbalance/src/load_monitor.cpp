#include "soda/loadbalance/load_monitor.h"

#include <algorithm>

namespace soda {

LoadMonitor::LoadMonitor(const BalanceOptions& options)
    : options_(options), busy_(options.smoothing), predicted_(options.smoothing) {}

void LoadMonitor::update(const LoadView& view) {
  std::vector<CostSample> samples;
  samples.reserve(view.worlds.size());
  for (const WorldLoad& w : view.worlds)
    if (w.steps > 0) samples.push_back(cost_sample(w));
  last_prediction_ = model_.quality(samples);

  // The fit takes, per world, the sample of its last three periods whose
  // busy time is the median (the smaller of two; the one of one) — a period
  // really measured, with what the world held then: a one-period spike
  // never enters the model.
  busy_.update(view);
  recent_.resize(view.worlds.size());
  std::vector<CostSample> filtered;
  for (std::size_t w = 0; w < view.worlds.size(); ++w) {
    if (view.worlds[w].steps <= 0) continue;
    std::deque<CostSample>& r = recent_[w];
    r.push_back(cost_sample(view.worlds[w]));
    if (r.size() > 3) r.pop_front();
    std::vector<CostSample> sorted(r.begin(), r.end());
    std::stable_sort(sorted.begin(), sorted.end(), [](const CostSample& a, const CostSample& b) { return a.busy < b.busy; });
    filtered.push_back(sorted.size() == 3 ? sorted[1] : sorted[0]);
  }
  history_.push_back(std::move(filtered));
  while (history_.size() > static_cast<std::size_t>(kCostHistoryPeriods)) history_.pop_front();
  std::vector<CostSample> all;
  for (const auto& period : history_) all.insert(all.end(), period.begin(), period.end());
  model_ = CostModel::fit(all);

  const std::vector<double>& busy = busy_.smoothed();
  LoadView prediction = view;  // the same periods, busy replaced by the model's prediction
  for (WorldLoad& w : prediction.worlds) w.busy = model_.predict(w);
  const std::vector<double>& predicted = predicted_.update(prediction);

  // Each world's calibration is shrunk towards the whole scene's, the more
  // so the less the world held (kCalibrationPrior): a world that held next
  // to nothing measures mostly its overhead and timer noise, and its own
  // ratio, applied to the load it has just been given, was off by up to the
  // clamp (drift 900 on 2 worlds, step 40: world 1 had held 2 bodies,
  // measured 70 us against 27 predicted, and its 213 new bodies were
  // estimated at 2.7 ms against 0.94 measured: no move for a period).
  double busy_sum = 0, predicted_sum = 0;
  for (std::size_t w = 0; w < view.worlds.size(); ++w)
    if (predicted[w] > 0 && busy[w] > 0) {
      busy_sum += busy[w];
      predicted_sum += predicted[w];
    }
  const double global = predicted_sum > 0 ? busy_sum / predicted_sum : 1.0;
  const double prior = kCalibrationPrior * predicted_sum / static_cast<double>(std::max<std::size_t>(1, view.worlds.size()));
  estimated_.assign(view.worlds.size(), 0.0);
  for (std::size_t w = 0; w < view.worlds.size(); ++w) {
    const double now = prediction.worlds[w].busy;
    estimated_[w] = busy[w];
    if (now > 0 && predicted[w] > 0 && busy[w] > 0)
      estimated_[w] = now * std::clamp((busy[w] + prior * global) / (predicted[w] + prior), 1.0 / kCalibrationLimit,
                                       kCalibrationLimit);
  }
  classes_ = classify(estimated_, options_.underload, options_.overload);
  double sum = 0;
  for (double l : estimated_) sum += l;
  mean_ = estimated_.empty() ? 0.0 : sum / static_cast<double>(estimated_.size());
}

}  // namespace soda

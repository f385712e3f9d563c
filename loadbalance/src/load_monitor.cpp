#include "soda/loadbalance/load_monitor.h"

#include <algorithm>

namespace soda {

LoadMonitor::LoadMonitor(const BalanceOptions& options)
    : options_(options), smoother_(options.smoothing) {}

void LoadMonitor::update(const LoadView& view) {
  std::vector<CostSample> samples;
  samples.reserve(view.worlds.size());
  for (const WorldLoad& w : view.worlds)
    if (w.steps > 0) samples.push_back(cost_sample(w));
  last_prediction_ = model_.quality(samples);

  smoother_.update(view);
  reclassify();

  history_.push_back(std::move(samples));
  while (history_.size() > static_cast<std::size_t>(kCostHistoryPeriods)) history_.pop_front();
  std::vector<CostSample> all;
  for (const auto& period : history_) all.insert(all.end(), period.begin(), period.end());
  model_ = CostModel::fit(all);
}

void LoadMonitor::account_moves(const std::vector<double>& estimates) {
  const std::vector<double>& loads = smoother_.smoothed();
  for (std::size_t w = 0; w < loads.size() && w < estimates.size(); ++w) smoother_.shift(w, estimates[w] - loads[w]);
  reclassify();
}

void LoadMonitor::reclassify() {
  const std::vector<double>& loads = smoother_.smoothed();
  classes_ = classify(loads, options_.underload, options_.overload);
  double sum = 0;
  for (double l : loads) sum += l;
  mean_ = loads.empty() ? 0.0 : sum / static_cast<double>(loads.size());
}

}  // namespace soda

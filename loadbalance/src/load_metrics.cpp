#include "soda/loadbalance/load_metrics.h"

#include <algorithm>

namespace soda {

const char* load_class_name(LoadClass load_class) {
  switch (load_class) {
    case LoadClass::Underloaded: return "underloaded";
    case LoadClass::Normal: return "normal";
    case LoadClass::Overloaded: return "overloaded";
  }
  return "?";
}

namespace {

double mean_of(std::span<const double> loads) {
  double sum = 0;
  for (double l : loads) sum += l;
  return loads.empty() ? 0.0 : sum / static_cast<double>(loads.size());
}

}  // namespace

std::vector<LoadClass> classify(std::span<const double> loads, double underload, double overload) {
  std::vector<LoadClass> out(loads.size(), LoadClass::Normal);
  const double mean = mean_of(loads);
  if (loads.size() < 2 || !(mean > 0)) return out;
  for (std::size_t i = 0; i < loads.size(); ++i) {
    if (loads[i] > overload * mean) out[i] = LoadClass::Overloaded;
    else if (loads[i] < underload * mean) out[i] = LoadClass::Underloaded;
  }
  return out;
}

double imbalance(std::span<const double> loads) {
  const double mean = mean_of(loads);
  if (!(mean > 0)) return 1.0;
  return *std::max_element(loads.begin(), loads.end()) / mean;
}

double utilisation(const WorldLoad& load) {
  const double total = load.busy + load.wait;
  return total > 0 ? load.busy / total : 0.0;
}

double LoadSmoother::filtered(const History& h) const {
  if (h.count == 1) return h.last[0];
  if (h.count == 2) return std::min(h.last[0], h.last[1]);
  std::array<double, 3> v = h.last;
  std::sort(v.begin(), v.end());
  return v[1];
}

const std::vector<double>& LoadSmoother::update(const LoadView& view) {
  if (view.worlds.size() != history_.size()) {
    history_.assign(view.worlds.size(), History{});
    smoothed_.assign(view.worlds.size(), 0.0);
    periods_ = 0;
  }
  for (std::size_t i = 0; i < view.worlds.size(); ++i) {
    const WorldLoad& w = view.worlds[i];
    if (w.steps <= 0) continue;
    History& h = history_[i];
    const bool first = h.count == 0;
    h.last[static_cast<std::size_t>(h.next)] = w.busy;
    h.next = (h.next + 1) % 3;
    h.count = std::min(h.count + 1, 3);
    const double m = filtered(h);
    smoothed_[i] = first ? m : smoothing_ * m + (1.0 - smoothing_) * smoothed_[i];
  }
  ++periods_;
  return smoothed_;
}

}  // namespace soda

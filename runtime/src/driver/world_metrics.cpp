// WorldMetrics folded over steps, over the processes of one world and over
// worlds (world_metrics.h), every counter through for_each_counter.
#include "soda/runtime/world_metrics.h"

#include <algorithm>

#include "step/message_tally.h"
#include "driver/metrics_sums.h"

namespace soda {
namespace {

// `into` += `from` by the counter's fold; `across_worlds`: Now adds, else
// keeps `into` (the newer).
template <class T>
void fold(T& into, const T& from, CounterFold how, bool across_worlds) {
  switch (how) {
    case CounterFold::Sum: into += from; break;
    case CounterFold::Max: into = std::max(into, from); break;
    case CounterFold::Now:
      if (across_worlds) into += from;
      break;
  }
}

void add_counters(WorldMetrics& t, const WorldMetrics& m, bool across_worlds) {
  for_each_counter([&](const char*, auto member, CounterFold how) { fold(t.*member, m.*member, how, across_worlds); });
  for (std::size_t i = 0; i < kStageCount; ++i) {
    t.stages[i].cpu_seconds += m.stages[i].cpu_seconds;
    t.stages[i].wait_seconds += m.stages[i].wait_seconds;
    t.stages[i].items += m.stages[i].items;
    t.stages[i].messages += m.stages[i].messages;
    t.stages[i].bytes += m.stages[i].bytes;
  }
  add_traffic(t.traffic, m.traffic);
}

}  // namespace

void add_step_counters(WorldMetrics& m, const TerritoryCounters& step) {
#define SODA_ADD_STEP_COUNTER(type, name, how, what) \
  fold(m.name, static_cast<decltype(m.name)>(step.name), CounterFold::how, false);
  SODA_TERRITORY_COUNTERS(SODA_ADD_STEP_COUNTER)
#undef SODA_ADD_STEP_COUNTER
}

void add_replaced_run(WorldMetrics& m, const WorldMetrics& replaced) {
  add_counters(m, replaced, false);
  m.cpu_step_max_ms = std::max(m.cpu_step_max_ms, replaced.cpu_step_max_ms);
}

WorldMetrics total_metrics(const std::vector<WorldMetrics>& worlds) {
  WorldMetrics t;
  double lead_sum = 0;
  std::int64_t steps = 0;
  for (const WorldMetrics& m : worlds) {
    add_counters(t, m, true);
    t.steps = std::max(t.steps, m.steps);
    lead_sum += m.lead_mean * static_cast<double>(m.steps);
    steps += m.steps;
  }
  t.lead_mean = steps > 0 ? lead_sum / static_cast<double>(steps) : 0.0;  // weighted by each world's steps
  return t;
}

}  // namespace soda

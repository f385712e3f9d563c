// WorldMetrics declared once (world_metrics.h, territory_counters.h):
// for_each_counter visits every counter under its field's name, and the
// folds (a step's counts, a replaced process, totals over worlds) follow
// each counter's CounterFold.
#include <cstdint>
#include <set>
#include <string>
#include <type_traits>

#include <gtest/gtest.h>

#include "driver/metrics_sums.h"
#include "soda/runtime/world_metrics.h"

namespace soda {
namespace {

// Every counter of `m` set to `base` + its position in the lists.
void number_counters(WorldMetrics& m, int base) {
  int i = 0;
  for_each_counter(m, [&](const char*, auto& value, CounterFold) {
    value = static_cast<std::remove_reference_t<decltype(value)>>(base + i++);
  });
}

TEST(WorldMetrics, ForEachCounterNamesEachFieldOnce) {
  WorldMetrics m;
  number_counters(m, 1);
  std::set<std::string> names;
  int count = 0;
  for_each_counter(m, [&](const char* name, const auto& value, CounterFold) {
    EXPECT_TRUE(names.insert(name).second) << name << " twice";
    EXPECT_EQ(static_cast<int>(value), 1 + count) << name;
    ++count;
  });
  EXPECT_EQ(names.size(), static_cast<std::size_t>(count));
  // The name is the field's: a line of either list reaches the field of
  // that name (the first territory counter, the last process counter).
  EXPECT_EQ(m.border_bodies, 1u);
  EXPECT_TRUE(names.count("border_bodies") && names.count("kept_states_max") && names.count("bets"));
  EXPECT_EQ(m.kept_states_max, static_cast<std::size_t>(count));
}

TEST(WorldMetrics, FoldsFollowEachCountersKind) {
  WorldMetrics a, b;
  number_counters(a, 10);
  number_counters(b, 1000);
  a.steps = 5, b.steps = 7;
  a.lead_mean = 1, b.lead_mean = 3;
  const WorldMetrics total = total_metrics({a, b});
  WorldMetrics carried = b;
  add_replaced_run(carried, a);
  for_each_counter([&](const char* name, auto member, CounterFold fold) {
    const double x = static_cast<double>(a.*member), y = static_cast<double>(b.*member);
    const double t = static_cast<double>(total.*member), c = static_cast<double>(carried.*member);
    switch (fold) {
      case CounterFold::Sum: EXPECT_EQ(t, x + y) << name; EXPECT_EQ(c, x + y) << name; break;
      case CounterFold::Max: EXPECT_EQ(t, y) << name; EXPECT_EQ(c, y) << name; break;
      case CounterFold::Now: EXPECT_EQ(t, x + y) << name; EXPECT_EQ(c, y) << name; break;
    }
  });
  EXPECT_EQ(total.steps, 7);
  EXPECT_DOUBLE_EQ(total.lead_mean, (1.0 * 5 + 3.0 * 7) / 12);
}

TEST(WorldMetrics, AStepsCountersAddUpByTheirFold) {
  WorldMetrics m;
  TerritoryCounters c;
  c.border_bodies = 3;
  c.solver_threads = 4;
  c.owned_bodies = 99;  // a size of the step, not a counter of the run
  add_step_counters(m, c);
  c.solver_threads = 2;
  add_step_counters(m, c);
  EXPECT_EQ(m.border_bodies, 6u);
  EXPECT_EQ(m.solver_threads, 4);
  EXPECT_EQ(m.owned_bodies, 0u);
}

}  // namespace
}  // namespace soda

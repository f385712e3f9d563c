// Load metrics: classification against the mean, the spike filter and the
// moving average of LoadSmoother.
#include <gtest/gtest.h>

#include <vector>

#include "soda/loadbalance/load_metrics.h"

namespace soda {
namespace {

LoadView view_of(const std::vector<double>& busy) {
  LoadView view;
  for (std::size_t i = 0; i < busy.size(); ++i) {
    WorldLoad w;
    w.world = static_cast<WorldId>(i);
    w.steps = 20;
    w.busy = busy[i];
    view.worlds.push_back(w);
  }
  return view;
}

TEST(LoadMetrics, ClassifiesAgainstTheMean) {
  const std::vector<double> loads{1.0, 2.0, 3.0, 2.0};  // mean 2
  const std::vector<LoadClass> c = classify(loads, 0.85, 1.15);
  EXPECT_EQ(c, (std::vector<LoadClass>{LoadClass::Underloaded, LoadClass::Normal, LoadClass::Overloaded,
                                       LoadClass::Normal}));
  EXPECT_DOUBLE_EQ(imbalance(loads), 1.5);
  // Nothing to balance: one world, or no load at all.
  EXPECT_EQ(classify(std::vector<double>{5.0}, 0.85, 1.15), std::vector<LoadClass>{LoadClass::Normal});
  EXPECT_EQ(classify(std::vector<double>{0.0, 0.0}, 0.85, 1.15),
            (std::vector<LoadClass>{LoadClass::Normal, LoadClass::Normal}));
  EXPECT_DOUBLE_EQ(imbalance(std::vector<double>{0.0, 0.0}), 1.0);
  EXPECT_STREQ(load_class_name(LoadClass::Overloaded), "overloaded");
}

TEST(LoadMetrics, UtilisationIsBusyOverBusyPlusWait) {
  WorldLoad w;
  w.busy = 3e-3;
  w.wait = 1e-3;
  EXPECT_DOUBLE_EQ(utilisation(w), 0.75);
  EXPECT_DOUBLE_EQ(utilisation(WorldLoad{}), 0.0);
}

// One period ten times as expensive (a burst of contacts, a page fault, the
// machine's other jobs) must not make a world overloaded — whatever the
// smoothing weight, even 1 (no average at all).
TEST(LoadSmoother, ASingleSpikeNeverFlipsAClass) {
  for (double smoothing : {0.25, 0.5, 1.0}) {
    LoadSmoother s(smoothing);
    for (int period = 0; period < 12; ++period) {
      const double spike = period == 5 ? 10.0 : 1.0;
      const std::vector<double>& loads = s.update(view_of({spike * 1e-3, 1e-3, 1e-3, 1e-3}));
      const std::vector<LoadClass> c = classify(loads, 0.85, 1.15);
      for (std::size_t w = 0; w < c.size(); ++w)
        EXPECT_EQ(c[w], LoadClass::Normal) << "smoothing " << smoothing << ", period " << period << ", world " << w;
    }
  }
}

// A lasting change shows after two periods (the median of three needs two
// of them), then the average follows.
TEST(LoadSmoother, ALastingChangeShowsAfterTwoPeriods) {
  LoadSmoother s(0.5);
  for (int period = 0; period < 4; ++period) s.update(view_of({1e-3, 1e-3}));
  EXPECT_EQ(classify(s.update(view_of({3e-3, 1e-3})), 0.85, 1.15)[0], LoadClass::Normal);
  const std::vector<LoadClass> second = classify(s.update(view_of({3e-3, 1e-3})), 0.85, 1.15);
  EXPECT_EQ(second[0], LoadClass::Overloaded);
  EXPECT_EQ(second[1], LoadClass::Underloaded);
  for (int period = 0; period < 30; ++period) s.update(view_of({3e-3, 1e-3}));
  EXPECT_NEAR(s.smoothed()[0], 3e-3, 1e-12);
  EXPECT_EQ(s.periods(), 36);
}

TEST(LoadSmoother, AWorldThatMeasuredNothingKeepsItsValue) {
  LoadSmoother s(0.5);
  s.update(view_of({2e-3, 1e-3}));
  LoadView idle = view_of({9.0, 1e-3});
  idle.worlds[0].steps = 0;
  EXPECT_DOUBLE_EQ(s.update(idle)[0], 2e-3);
  // A different world count restarts the history.
  EXPECT_DOUBLE_EQ(s.update(view_of({5e-3, 1e-3, 1e-3}))[0], 5e-3);
  EXPECT_EQ(s.periods(), 1);
}

}  // namespace
}  // namespace soda

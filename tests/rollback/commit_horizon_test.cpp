// SharedMemoryHorizon: gvt() may go down (a mark lowered under a hold), the
// highest GVT read may not; a pin from outside (a user input at a past step)
// is refused below it (issue 14: a past input there reached a world's
// committed steps).
#include <gtest/gtest.h>

#include "soda/rollback/commit_horizon.h"

namespace soda {
namespace {

TEST(CommitHorizon, HighestGvtNeverGoesDownWhenAMarkIsLoweredUnderAPin) {
  SharedMemoryHorizon h(2, 0);
  h.report(0, 53);
  h.report(1, 53);
  EXPECT_EQ(h.gvt(), 53);  // a world reads 53: it commits up to 52
  ASSERT_TRUE(h.try_pin(53));
  h.report(0, 48);  // restored to the checkpoint before the pinned step
  h.unpin(53);
  EXPECT_EQ(h.gvt(), 48);
  EXPECT_EQ(h.highest_gvt(), 53);
  EXPECT_TRUE(h.try_pin(50));         // a world's own rollback: its marks hold it
  h.unpin(50);
  EXPECT_FALSE(h.try_pin_final(50));  // an input there would change committed steps
  EXPECT_TRUE(h.try_pin_final(53));
  h.unpin(53);
  h.report(0, 60);
  EXPECT_EQ(h.highest_gvt(), 53);
  EXPECT_EQ(h.gvt(), 53);
}

TEST(CommitHorizon, TryPinFinalHoldsGvtAtItsStep) {
  SharedMemoryHorizon h(1, 10);
  EXPECT_FALSE(h.try_pin_final(9));
  ASSERT_TRUE(h.try_pin_final(12));
  h.report(0, 20);
  EXPECT_EQ(h.gvt(), 12);
  h.unpin(12);
  EXPECT_EQ(h.gvt(), 20);
  EXPECT_EQ(h.highest_gvt(), 20);
}

}  // namespace
}  // namespace soda

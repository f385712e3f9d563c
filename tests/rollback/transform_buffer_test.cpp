// Unit tests of the circular transform buffer, single-threaded, for both
// precisions. The threaded tests are in transform_buffer_concurrency_test.cpp.
#include "soda/rollback/transform_buffer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace soda {
namespace {

constexpr double kDt = 0.25;  // exact in binary, so step times are exact

template <class Real>
TransformEntry<Real> make_entry(std::int64_t step, std::vector<BodyId> ids = {1, 2}) {
  TransformEntry<Real> entry;
  entry.step = step;
  entry.time = static_cast<double>(step) * kDt;
  for (BodyId id : ids) {
    BodyPose<Real> pose;
    pose.id = id;
    pose.position[0] = static_cast<Real>(step);
    pose.position[1] = static_cast<Real>(id);
    entry.poses.push_back(pose);
  }
  return entry;
}

template <class Real>
class TransformBufferTest : public ::testing::Test {
 protected:
  using Buffer = TransformBuffer<Real>;
  // Publishes steps [first, last], asserting that each fits.
  void fill(Buffer& buffer, std::int64_t first, std::int64_t last) {
    for (std::int64_t s = first; s <= last; ++s) ASSERT_TRUE(buffer.try_publish(make_entry<Real>(s)));
  }
};

using Precisions = ::testing::Types<float, double>;
TYPED_TEST_SUITE(TransformBufferTest, Precisions);

TYPED_TEST(TransformBufferTest, ZeroCapacityThrows) {
  EXPECT_THROW(TransformBuffer<TypeParam>(0), std::invalid_argument);
}

// Contacts must be ascending by pair, a < b, with 1 to 4 points.
TYPED_TEST(TransformBufferTest, BadContactsAreRefused) {
  auto contact = [](BodyId a, BodyId b, std::uint32_t points) {
    PairContact<TypeParam> c;
    c.a = a;
    c.b = b;
    c.point_count = points;
    return c;
  };
  const std::vector<std::vector<PairContact<TypeParam>>> bad = {
      {contact(2, 1, 1)}, {contact(1, 2, 0)}, {contact(1, 2, 5)}, {contact(1, 3, 1), contact(1, 2, 1)},
      {contact(1, 2, 1), contact(1, 2, 1)}};
  for (const auto& contacts : bad) {
    TransformBuffer<TypeParam> buffer(4);
    auto entry = make_entry<TypeParam>(0);
    entry.contacts = contacts;
    EXPECT_THROW(buffer.try_publish(std::move(entry)), std::invalid_argument);
  }
  TransformBuffer<TypeParam> buffer(4);
  auto entry = make_entry<TypeParam>(0);
  entry.contacts = {contact(1, 2, 1), contact(1, 3, 4), contact(2, 3, 2)};
  EXPECT_TRUE(buffer.try_publish(std::move(entry)));
  EXPECT_EQ(buffer.read_at(0.0)->contacts.size(), 3u);
}

TYPED_TEST(TransformBufferTest, TryPublishFalseWhenFullAndEntryUntouched) {
  TransformBuffer<TypeParam> buffer(3);
  this->fill(buffer, 0, 2);
  EXPECT_EQ(buffer.size(), 3u);
  auto entry = make_entry<TypeParam>(3);
  EXPECT_FALSE(buffer.try_publish(std::move(entry)));
  EXPECT_EQ(entry.poses.size(), 2u);  // not moved from on failure
  EXPECT_EQ(buffer.size(), buffer.capacity());
  EXPECT_EQ(buffer.latest_step(), 2);
}

TYPED_TEST(TransformBufferTest, CommitFreesWhenNoReader) {
  TransformBuffer<TypeParam> buffer(3);
  this->fill(buffer, 0, 2);
  buffer.set_commit_step(1);
  EXPECT_EQ(buffer.size(), 1u);
  EXPECT_EQ(buffer.oldest_step(), 2);
  EXPECT_TRUE(buffer.try_publish(make_entry<TypeParam>(3)));
  EXPECT_EQ(buffer.latest_step(), 3);
}

// A reader past the commit step frees what is at or below it; a rollback
// above the commit step then empties the buffer: read_at finds nothing at
// or before the steps to be republished, and freed_step tells "not yet"
// (after it) from "gone for good" (at or before it).
TYPED_TEST(TransformBufferTest, FreedStepTellsGoneFromDroppedByARollback) {
  TransformBuffer<TypeParam> buffer(8);
  EXPECT_EQ(buffer.freed_step(), TransformBuffer<TypeParam>::kNoStep);
  const auto reader = buffer.add_reader();
  this->fill(buffer, 0, 5);
  buffer.set_commit_step(3);
  ASSERT_TRUE(buffer.read_at(reader, 5 * kDt));  // the cursor onto 5 frees 0 .. 3
  EXPECT_EQ(buffer.oldest_step(), 4);
  EXPECT_EQ(buffer.freed_step(), 3);
  buffer.invalidate_from(4);  // a rollback at 4: nothing held
  EXPECT_EQ(buffer.size(), 0u);
  EXPECT_FALSE(buffer.read_at(reader, 5 * kDt));
  EXPECT_LT(buffer.freed_step(), 5) << "step 5 is to be republished, not gone";
  EXPECT_GE(buffer.freed_step(), 3) << "step 3 is gone";
  this->fill(buffer, 4, 5);
  EXPECT_TRUE(buffer.read_at(reader, 5 * kDt));
}

TYPED_TEST(TransformBufferTest, NoReaderNeverStallsOnceCommitted) {
  TransformBuffer<TypeParam> buffer(1);
  for (std::int64_t s = 0; s < 100; ++s) {
    ASSERT_TRUE(buffer.try_publish(make_entry<TypeParam>(s)));
    buffer.set_commit_step(s);
    EXPECT_EQ(buffer.size(), 0u);
    EXPECT_EQ(buffer.latest_step(), s);  // still known once freed
  }
  EXPECT_EQ(buffer.latest_time(), 99 * kDt);
}

TYPED_TEST(TransformBufferTest, ReaderCursorPinsItsEntryAndLater) {
  TransformBuffer<TypeParam> buffer(8);
  this->fill(buffer, 0, 5);
  const auto reader = buffer.add_reader();
  buffer.set_commit_step(5);
  EXPECT_EQ(buffer.size(), 6u);  // a reader that has read nothing pins all
  EXPECT_EQ(buffer.read_next(reader)->step, 0);
  EXPECT_EQ(buffer.read_next(reader)->step, 1);
  EXPECT_EQ(buffer.read_next(reader)->step, 2);
  EXPECT_EQ(buffer.cursor(reader), 2);
  EXPECT_EQ(buffer.oldest_step(), 2);  // 0 and 1 freed, the cursor's entry kept
  // The kept entry still serves interpolation from the cursor onwards.
  const auto sample = buffer.interpolate(reader, 2.5 * kDt);
  ASSERT_TRUE(sample.has_value());
  EXPECT_EQ(sample->before_step, 2);
  EXPECT_EQ(sample->after_step, 3);
}

TYPED_TEST(TransformBufferTest, FreeingWaitsForCommitAndSlowestReader) {
  TransformBuffer<TypeParam> buffer(8);
  this->fill(buffer, 0, 5);
  const auto fast = buffer.add_reader();
  const auto slow = buffer.add_reader();
  for (int i = 0; i < 5; ++i) buffer.read_next(fast);  // cursor 4
  buffer.read_next(slow);                              // cursor 0
  EXPECT_EQ(buffer.size(), 6u);  // commit step not set: nothing freed
  buffer.set_commit_step(3);
  EXPECT_EQ(buffer.oldest_step(), 0);  // the slow reader pins 0
  buffer.read_next(slow);
  buffer.read_next(slow);  // cursor 2
  EXPECT_EQ(buffer.oldest_step(), 2);
  buffer.remove_reader(slow);
  EXPECT_EQ(buffer.oldest_step(), 4);  // commit 3 frees up to 3; fast pins 4
  buffer.set_commit_step(10);
  EXPECT_EQ(buffer.oldest_step(), 4);  // fast still pins its entry
  buffer.remove_reader(fast);
  EXPECT_EQ(buffer.size(), 0u);
}

TYPED_TEST(TransformBufferTest, ReadAtPicksClosestAtOrBefore) {
  TransformBuffer<TypeParam> buffer(8);
  this->fill(buffer, 10, 14);  // times 2.5, 2.75, 3.0, 3.25, 3.5
  const auto reader = buffer.add_reader();
  EXPECT_EQ(buffer.read_at(reader, 2.49), nullptr);
  EXPECT_EQ(buffer.cursor(reader), TransformBuffer<TypeParam>::kNoStep);
  EXPECT_EQ(buffer.read_at(reader, 2.5)->step, 10);
  EXPECT_EQ(buffer.read_at(reader, 3.2)->step, 12);
  EXPECT_EQ(buffer.cursor(reader), 12);
  EXPECT_EQ(buffer.read_at(reader, 3.25)->step, 13);
  EXPECT_EQ(buffer.read_at(reader, 100.0)->step, 14);
  EXPECT_EQ(buffer.read_at(reader, 2.8)->step, 11);  // the cursor may go back
  EXPECT_EQ(buffer.read_next(reader)->step, 12);
  EXPECT_EQ(buffer.read_at(3.0)->step, 12);  // no reader: no cursor
  EXPECT_THROW(buffer.read_at(reader, std::nan("")), std::invalid_argument);
}

TYPED_TEST(TransformBufferTest, InterpolationMidwayIsExactForLinearMotion) {
  using Real = TypeParam;
  TransformBuffer<Real> buffer(4);
  // x(t) = x0 + v t; orientation turning about z from 0 to 90 degrees.
  const Real x0[3] = {1, -2, 0.5};
  const Real v[3] = {2, 4, -1};
  for (std::int64_t s = 0; s < 2; ++s) {
    TransformEntry<Real> entry;
    entry.step = s;
    entry.time = 0.5 * static_cast<double>(s);
    BodyPose<Real> pose;
    pose.id = 7;
    for (int k = 0; k < 3; ++k) {
      pose.position[k] = x0[k] + v[k] * static_cast<Real>(entry.time);
      pose.linear_velocity[k] = v[k];
      pose.angular_velocity[k] = static_cast<Real>(s);
    }
    const double half_angle = s == 0 ? 0.0 : std::numbers::pi / 4;
    pose.orientation[2] = static_cast<Real>(std::sin(half_angle));
    pose.orientation[3] = static_cast<Real>(std::cos(half_angle));
    entry.poses.push_back(pose);
    ASSERT_TRUE(buffer.try_publish(std::move(entry)));
  }
  const auto sample = buffer.interpolate(0.25);
  ASSERT_TRUE(sample.has_value());
  EXPECT_EQ(sample->weight, 0.5);
  ASSERT_EQ(sample->poses.size(), 1u);
  const BodyPose<Real>& pose = sample->poses[0];
  EXPECT_EQ(pose.id, 7u);
  EXPECT_EQ(pose.position[0], Real(1.5));  // exact, not near
  EXPECT_EQ(pose.position[1], Real(-1));
  EXPECT_EQ(pose.position[2], Real(0.25));
  EXPECT_EQ(pose.linear_velocity[1], Real(4));
  EXPECT_EQ(pose.angular_velocity[0], Real(0.5));
  const double tolerance = sizeof(Real) == 4 ? 1e-6 : 1e-14;
  EXPECT_NEAR(pose.orientation[2], std::sin(std::numbers::pi / 8), tolerance);  // 45 degrees
  EXPECT_NEAR(pose.orientation[3], std::cos(std::numbers::pi / 8), tolerance);
  // At an entry's own time, its poses come back bit for bit.
  const auto at_start = buffer.interpolate(0.0);
  EXPECT_EQ(at_start->weight, 0.0);
  EXPECT_EQ(at_start->poses[0].position[0], Real(1));
  // After the newest entry: its poses, no extrapolation.
  const auto late = buffer.interpolate(9.0);
  EXPECT_EQ(late->before_step, 1);
  EXPECT_EQ(late->after_step, 1);
  EXPECT_EQ(late->poses[0].position[0], Real(2));
}

TYPED_TEST(TransformBufferTest, InterpolationKeepsBodiesOfTheEarlierEntry) {
  using Real = TypeParam;
  TransformBuffer<Real> buffer(4);
  ASSERT_TRUE(buffer.try_publish(make_entry<Real>(0, {1, 2, 5})));
  ASSERT_TRUE(buffer.try_publish(make_entry<Real>(1, {2, 3, 5})));
  const auto sample = buffer.interpolate(0.5 * kDt);
  ASSERT_TRUE(sample.has_value());
  ASSERT_EQ(sample->poses.size(), 3u);
  EXPECT_EQ(sample->poses[0].id, 1u);  // left at step 1: kept as it was
  EXPECT_EQ(sample->poses[0].position[0], Real(0));
  EXPECT_EQ(sample->poses[1].id, 2u);
  EXPECT_EQ(sample->poses[1].position[0], Real(0.5));
  EXPECT_EQ(sample->poses[2].id, 5u);  // body 3 is not there yet
}

TYPED_TEST(TransformBufferTest, InvalidateAndRepublishBumpsRevision) {
  TransformBuffer<TypeParam> buffer(8);
  this->fill(buffer, 0, 5);
  const auto behind = buffer.add_reader();
  const auto ahead = buffer.add_reader();
  buffer.read_next(behind);  // cursor 0
  for (int i = 0; i < 5; ++i) buffer.read_next(ahead);  // cursor 4
  buffer.invalidate_from(3);
  EXPECT_EQ(buffer.latest_step(), 2);
  EXPECT_EQ(buffer.size(), 3u);
  EXPECT_EQ(buffer.cursor(behind), 0);
  EXPECT_EQ(buffer.cursor(ahead), 2);  // moved back before the invalidated step
  EXPECT_EQ(buffer.read_next(ahead), nullptr);
  EXPECT_THROW(buffer.try_publish(make_entry<TypeParam>(6)), std::logic_error);
  this->fill(buffer, 3, 4);
  const auto again = buffer.read_next(ahead);
  EXPECT_EQ(again->step, 3);
  EXPECT_EQ(again->revision, 1u);
  EXPECT_EQ(buffer.read_next(ahead)->revision, 1u);
  // A second rollback inside the rewritten range: revision 2 there, and the
  // steps above, dropped once, get 1.
  buffer.invalidate_from(4);
  this->fill(buffer, 4, 6);
  EXPECT_EQ(buffer.read_at(4 * kDt)->revision, 2u);
  EXPECT_EQ(buffer.read_at(5 * kDt)->revision, 1u);
  EXPECT_EQ(buffer.read_at(6 * kDt)->revision, 0u);
  EXPECT_EQ(buffer.read_at(2 * kDt)->revision, 0u);
}

TYPED_TEST(TransformBufferTest, InvalidateBeyondLatestIsNoOp) {
  TransformBuffer<TypeParam> buffer(4);
  this->fill(buffer, 0, 1);
  buffer.invalidate_from(2);
  buffer.invalidate_from(50);
  EXPECT_EQ(buffer.size(), 2u);
  EXPECT_TRUE(buffer.try_publish(make_entry<TypeParam>(2)));
  EXPECT_EQ(buffer.read_at(2 * kDt)->revision, 0u);
}

TYPED_TEST(TransformBufferTest, CommittedStepsCannotBeInvalidated) {
  TransformBuffer<TypeParam> buffer(4);
  this->fill(buffer, 0, 3);
  buffer.set_commit_step(1);
  EXPECT_THROW(buffer.invalidate_from(1), std::logic_error);
  EXPECT_NO_THROW(buffer.invalidate_from(2));
  EXPECT_THROW(buffer.set_commit_step(0), std::logic_error);  // never goes back
  EXPECT_NO_THROW(buffer.set_commit_step(1));
  // Step 1 was freed; republishing step 2 still checks against its time.
  auto early = make_entry<TypeParam>(2);
  early.time = 0.1;
  EXPECT_THROW(buffer.try_publish(std::move(early)), std::logic_error);
  EXPECT_TRUE(buffer.try_publish(make_entry<TypeParam>(2)));
}

TYPED_TEST(TransformBufferTest, OutOfOrderPublishThrows) {
  TransformBuffer<TypeParam> buffer(8);
  this->fill(buffer, 5, 6);
  EXPECT_THROW(buffer.try_publish(make_entry<TypeParam>(8)), std::logic_error);  // gap
  EXPECT_THROW(buffer.try_publish(make_entry<TypeParam>(6)), std::logic_error);  // repeat
  EXPECT_THROW(buffer.publish(make_entry<TypeParam>(4)), std::logic_error);      // back
  auto same_time = make_entry<TypeParam>(7);
  same_time.time = 6 * kDt;
  EXPECT_THROW(buffer.try_publish(std::move(same_time)), std::logic_error);
  auto unsorted = make_entry<TypeParam>(7, {3, 2});
  EXPECT_THROW(buffer.try_publish(std::move(unsorted)), std::invalid_argument);
  auto duplicate = make_entry<TypeParam>(7, {2, 2});
  EXPECT_THROW(buffer.try_publish(std::move(duplicate)), std::invalid_argument);
  auto infinite = make_entry<TypeParam>(7);
  infinite.time = std::numeric_limits<double>::infinity();
  EXPECT_THROW(buffer.try_publish(std::move(infinite)), std::invalid_argument);
  EXPECT_EQ(buffer.size(), 2u);
  EXPECT_TRUE(buffer.try_publish(make_entry<TypeParam>(7)));
}

TYPED_TEST(TransformBufferTest, UnknownReaderThrows) {
  TransformBuffer<TypeParam> buffer(2);
  const auto reader = buffer.add_reader();
  buffer.remove_reader(reader);
  EXPECT_THROW(buffer.read_next(reader), std::invalid_argument);
  EXPECT_THROW(buffer.read_at(reader, 0.0), std::invalid_argument);
  EXPECT_THROW(buffer.interpolate(reader, 0.0), std::invalid_argument);
  EXPECT_THROW(buffer.cursor(reader), std::invalid_argument);
  EXPECT_THROW(buffer.remove_reader(reader), std::invalid_argument);
  EXPECT_THROW(buffer.remove_reader(BufferReaderId{42}), std::invalid_argument);
  EXPECT_NE(buffer.add_reader(), reader);  // ids are not reused
}

TYPED_TEST(TransformBufferTest, StopMakesWaitsReturn) {
  TransformBuffer<TypeParam> buffer(1);
  this->fill(buffer, 0, 0);
  const auto reader = buffer.add_reader();
  buffer.stop();
  auto entry = make_entry<TypeParam>(1);
  EXPECT_FALSE(buffer.publish(std::move(entry)));  // full and stopped: no wait
  EXPECT_EQ(entry.step, 1);
  EXPECT_EQ(buffer.wait_next(reader)->step, 0);  // what is there is still served
  EXPECT_EQ(buffer.wait_next(reader), nullptr);
  EXPECT_TRUE(buffer.wait_for_time(0.0));
  EXPECT_FALSE(buffer.wait_for_time(1.0));
}

}  // namespace
}  // namespace soda

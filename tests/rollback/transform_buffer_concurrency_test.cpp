// Threaded tests of the circular transform buffer: blocking waits and their
// release, and a hammer test (one writer with rollbacks, three readers) meant
// to run under ThreadSanitizer. Every pose field the writer publishes is a
// function of (step, revision, body id, field), so a torn or mixed entry, or
// a wrong revision, fails the readers' checks.
#include "soda/rollback/transform_buffer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <thread>
#include <vector>

namespace soda {
namespace {

constexpr double kDt = 1.0 / 64.0;  // exact in binary
constexpr BodyId kBodies[] = {2, 3, 5, 8, 13, 21};
constexpr int kFields = 13;  // 3 position, 4 orientation, 3 + 3 velocities

double time_of(std::int64_t step) { return static_cast<double>(step) * kDt; }

template <class Real>
Real field_value(std::int64_t step, std::uint64_t revision, BodyId id, int field) {
  const double code = ((static_cast<double>(step) * 8 + static_cast<double>(revision)) * 32 +
                       static_cast<double>(id)) * 16 + field;
  return static_cast<Real>(code);
}

// Field 0..12 of a pose: 3 position, 4 orientation, 3 + 3 velocities.
template <class Pose>  // BodyPose<Real>, const or not
auto* field_ptr(Pose& pose, int field) {
  if (field < 3) return &pose.position[field];
  if (field < 7) return &pose.orientation[field - 3];
  if (field < 10) return &pose.linear_velocity[field - 7];
  return &pose.angular_velocity[field - 10];
}

template <class Real>
TransformEntry<Real> make_entry(std::int64_t step, std::uint64_t revision) {
  TransformEntry<Real> entry;
  entry.step = step;
  entry.time = time_of(step);
  for (BodyId id : kBodies) {
    BodyPose<Real> pose;
    pose.id = id;
    for (int f = 0; f < kFields; ++f) *field_ptr(pose, f) = field_value<Real>(step, revision, id, f);
    entry.poses.push_back(pose);
  }
  return entry;
}

// Empty if `entry` is exactly what the writer built for its step and revision.
template <class Real>
std::string inconsistency(const TransformEntry<Real>& entry) {
  if (entry.time != time_of(entry.step)) return "time of step " + std::to_string(entry.step);
  if (entry.poses.size() != std::size(kBodies)) return "pose count";
  for (std::size_t i = 0; i < entry.poses.size(); ++i) {
    const BodyPose<Real>& pose = entry.poses[i];
    if (pose.id != kBodies[i]) return "body id";
    for (int f = 0; f < kFields; ++f) {
      if (*field_ptr(pose, f) != field_value<Real>(entry.step, entry.revision, pose.id, f)) {
        return "torn entry: step " + std::to_string(entry.step) + " revision " +
               std::to_string(entry.revision) + " body " + std::to_string(pose.id) +
               " field " + std::to_string(f);
      }
    }
  }
  return {};
}

// Per-thread failure log: counts, and keeps the first message.
struct Failures {
  int count = 0;
  std::string first;
  void add(const std::string& what) {
    if (count++ == 0) first = what;
  }
};

template <class Real>
class TransformBufferConcurrencyTest : public ::testing::Test {};
using Precisions = ::testing::Types<float, double>;
TYPED_TEST_SUITE(TransformBufferConcurrencyTest, Precisions);

// Waits a little and tells whether `done` is still false: only used to check
// that a call is (still) blocked; the releases themselves never sleep.
bool still_blocked(const std::atomic<bool>& done) {
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  return !done.load();
}

TYPED_TEST(TransformBufferConcurrencyTest, FullPublishWaitsForReaderThenCommit) {
  TransformBuffer<TypeParam> buffer(2);
  const auto reader = buffer.add_reader();
  ASSERT_TRUE(buffer.publish(make_entry<TypeParam>(0, 0)));
  ASSERT_TRUE(buffer.publish(make_entry<TypeParam>(1, 0)));
  std::atomic<bool> done{false};
  bool published = false;
  std::thread writer([&] {
    published = buffer.publish(make_entry<TypeParam>(2, 0));
    done = true;
  });
  EXPECT_TRUE(still_blocked(done));
  buffer.read_next(reader);
  buffer.read_next(reader);  // cursor 1: step 0 no longer needed by the reader
  EXPECT_TRUE(still_blocked(done));  // ... but not committed
  buffer.set_commit_step(0);
  writer.join();
  EXPECT_TRUE(published);
  EXPECT_EQ(buffer.oldest_step(), 1);
  EXPECT_EQ(buffer.latest_step(), 2);
}

TYPED_TEST(TransformBufferConcurrencyTest, StopReleasesWaiters) {
  TransformBuffer<TypeParam> buffer(1);
  ASSERT_TRUE(buffer.publish(make_entry<TypeParam>(0, 0)));
  const auto reader = buffer.add_reader();
  ASSERT_NE(buffer.read_next(reader), nullptr);
  std::atomic<int> done{0};
  bool published = true;
  typename TransformBuffer<TypeParam>::EntryPtr next;
  bool reached = true;
  std::thread writer([&] { published = buffer.publish(make_entry<TypeParam>(1, 0)); ++done; });
  std::thread waiter([&] { next = buffer.wait_next(reader); ++done; });
  std::thread watcher([&] { reached = buffer.wait_for_time(1.0); ++done; });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(done.load(), 0);
  buffer.stop();
  writer.join();
  waiter.join();
  watcher.join();
  EXPECT_FALSE(published);
  EXPECT_EQ(next, nullptr);
  EXPECT_FALSE(reached);
}

TYPED_TEST(TransformBufferConcurrencyTest, WaitNextWakesOnPublishAndOnRemoval) {
  TransformBuffer<TypeParam> buffer(4);
  const auto reader = buffer.add_reader();
  std::int64_t step = -1;
  std::thread waiter([&] { step = buffer.wait_next(reader)->step; });
  ASSERT_TRUE(buffer.publish(make_entry<TypeParam>(7, 0)));
  waiter.join();
  EXPECT_EQ(step, 7);
  bool threw = false;
  std::thread orphan([&] {
    try {
      buffer.wait_next(reader);
    } catch (const std::invalid_argument&) {
      threw = true;
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  buffer.remove_reader(reader);
  orphan.join();
  EXPECT_TRUE(threw);
}

// One writer publishing kSteps steps with rollbacks, committing kCommitLag
// steps behind itself; three readers: sequential (wait_next), random access
// with reader churn (read_at), and an interpolating renderer. The writer
// blocks on a full buffer and is released only by reader progress + commit.
TYPED_TEST(TransformBufferConcurrencyTest, HammerWithRollbacks) {
  using Real = TypeParam;
  using Buffer = TransformBuffer<Real>;
  constexpr std::int64_t kSteps = 20000;
  constexpr std::size_t kCapacity = 16;
  constexpr std::int64_t kCommitLag = 8;  // < kCapacity, or a full buffer could never free
  Buffer buffer(kCapacity);
  // Readers register before the writer starts, as the runtime's do: a reader
  // added later only sees what is still held.
  const auto sequential_reader = buffer.add_reader();
  const auto random_reader = buffer.add_reader();
  const auto render_reader = buffer.add_reader();

  std::vector<std::uint64_t> revision(kSteps, 0);  // the writer's model; read after join
  Failures writer_failures;
  int rollbacks = 0;
  std::size_t max_size = 0;
  std::thread writer([&] {
    std::mt19937 rng(1234);
    std::int64_t step = 0;
    std::int64_t committed = Buffer::kNoStep;  // a commit horizon never goes back
    for (int publishes = 1; step < kSteps; ++publishes) {
      if (!buffer.publish(make_entry<Real>(step, revision[step]))) {
        writer_failures.add("publish returned false before stop");
        return;
      }
      max_size = std::max(max_size, buffer.size());
      committed = std::max(committed, step - kCommitLag);
      buffer.set_commit_step(committed);
      if (publishes % 37 == 0 && step + 1 < kSteps) {  // never after the last step
        const std::int64_t back = std::uniform_int_distribution<std::int64_t>(0, kCommitLag - 1)(rng);
        const std::int64_t from = std::max(step - back, committed + 1);
        buffer.invalidate_from(from);
        for (std::int64_t s = from; s <= step; ++s) ++revision[s];
        ++rollbacks;
        step = from;
        continue;
      }
      ++step;
    }
    buffer.stop();
  });

  // Reader 1: every entry in order; a step seen again must be a newer revision.
  Failures sequential_failures;
  typename Buffer::EntryPtr sequential_last;
  std::thread sequential([&] {
    Failures& fail = sequential_failures;
    const auto reader = sequential_reader;
    std::vector<std::int64_t> seen(kSteps, -1);
    std::int64_t last = -1;
    while (auto entry = buffer.wait_next(reader)) {
      if (auto what = inconsistency(*entry); !what.empty()) fail.add(what);
      if (entry->step > last + 1) fail.add("skipped a step after " + std::to_string(last));
      const std::int64_t rev = static_cast<std::int64_t>(entry->revision);
      if (rev <= seen[entry->step]) fail.add("step seen again without a newer revision");
      seen[entry->step] = rev;
      last = entry->step;
      sequential_last = entry;
    }
    buffer.remove_reader(reader);
  });

  // Reader 2: read_at around a rising time, sometimes back; re-registers often.
  Failures random_failures;
  int random_misses = 0;
  std::thread random_access([&] {
    Failures& fail = random_failures;
    std::mt19937 rng(99);
    auto reader = random_reader;
    std::vector<std::int64_t> seen(kSteps, -1);
    for (std::int64_t i = 1;; ++i) {
      const double target = time_of(i);
      if (!buffer.wait_for_time(target)) break;
      const double at = target - kDt * std::uniform_int_distribution<int>(0, 3)(rng);
      auto entry = buffer.read_at(reader, at);
      if (!entry) {
        ++random_misses;  // only before the first step, or freed by the others
        continue;
      }
      if (auto what = inconsistency(*entry); !what.empty()) fail.add(what);
      if (entry->time > at) fail.add("read_at returned an entry after the time");
      const std::int64_t rev = static_cast<std::int64_t>(entry->revision);
      if (rev < seen[entry->step]) fail.add("revision went backwards");
      seen[entry->step] = rev;
      if (i % 100 == 0) {
        // A new reader pins every held entry until it reads: read at once,
        // before waiting again, or the writer could stall on a full buffer.
        buffer.remove_reader(reader);
        reader = buffer.add_reader();
        buffer.read_at(reader, target);
      }
    }
    buffer.remove_reader(reader);
  });

  // Reader 3: a renderer interpolating at 0.37 steps per frame.
  Failures render_failures;
  int frames = 0;
  std::thread renderer([&] {
    Failures& fail = render_failures;
    const auto reader = render_reader;
    std::vector<std::int64_t> seen(kSteps, -1);
    for (double t = 0.0;; t += 0.37 * kDt) {
      if (!buffer.wait_for_time(t)) break;
      const auto sample = (frames % 5 == 4) ? buffer.interpolate(t) : buffer.interpolate(reader, t);
      if (!sample) continue;
      ++frames;
      const std::int64_t b = sample->before_step;
      const std::int64_t a = sample->after_step;
      if (!(time_of(b) <= t) || (a != b && !(a == b + 1 && t < time_of(a)))) {
        fail.add("bad bracket at time " + std::to_string(t));
        continue;
      }
      const std::int64_t rev = static_cast<std::int64_t>(sample->before_revision);
      if (rev < seen[b]) fail.add("revision went backwards");
      seen[b] = rev;
      if (sample->poses.size() != std::size(kBodies)) {
        fail.add("pose count");
        continue;
      }
      for (const BodyPose<Real>& pose : sample->poses) {
        for (int f = 0; f < kFields; ++f) {
          if (f >= 3 && f < 7) continue;  // orientation is renormalised
          const Real lo = field_value<Real>(b, sample->before_revision, pose.id, f);
          const Real hi = field_value<Real>(a, sample->after_revision, pose.id, f);
          const Real v = *field_ptr(pose, f);
          if (sample->weight == 0.0 ? v != lo : (v < std::min(lo, hi) || v > std::max(lo, hi))) {
            fail.add("interpolated value outside its bracket, step " + std::to_string(b));
          }
        }
      }
    }
    buffer.remove_reader(reader);
  });

  writer.join();
  sequential.join();
  random_access.join();
  renderer.join();

  EXPECT_EQ(writer_failures.count, 0) << writer_failures.first;
  EXPECT_EQ(sequential_failures.count, 0) << sequential_failures.first;
  EXPECT_EQ(random_failures.count, 0) << random_failures.first;
  EXPECT_EQ(render_failures.count, 0) << render_failures.first;
  ASSERT_NE(sequential_last, nullptr);
  EXPECT_EQ(sequential_last->step, kSteps - 1);
  EXPECT_EQ(sequential_last->revision, revision[kSteps - 1]);
  EXPECT_LE(max_size, kCapacity);
  EXPECT_GT(rollbacks, 400);
  EXPECT_GT(frames, 1000);
  EXPECT_EQ(buffer.reader_count(), 0u);
  std::printf("rollbacks %d, frames %d, read_at misses %d, max size %zu\n", rollbacks, frames,
              random_misses, max_size);
}

}  // namespace
}  // namespace soda

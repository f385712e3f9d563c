// Delta entries of the transform buffer (docs/transform-buffer.md, "Delta
// entries"): readers get, bit for bit, what was published whether the buffer
// stores deltas or every pose, through rollbacks (invalidate_from) and
// bodies joining and leaving; and a buffered step's memory follows the
// bodies that move, not the bodies held.
#include "soda/rollback/transform_buffer.h"

#include <gtest/gtest.h>

#include <cstring>
#include <map>
#include <random>
#include <string>
#include <vector>

namespace soda {
namespace {

constexpr double kDt = 0.25;

template <class Real>
std::string difference(const TransformEntry<Real>& a, const TransformEntry<Real>& b) {
  if (a.step != b.step || a.revision != b.revision || a.time != b.time || a.busy_seconds != b.busy_seconds)
    return "step " + std::to_string(a.step) + " vs " + std::to_string(b.step) + ": header differs";
  if (a.poses.size() != b.poses.size())
    return "step " + std::to_string(a.step) + ": " + std::to_string(a.poses.size()) + " poses vs " +
           std::to_string(b.poses.size());
  for (std::size_t i = 0; i < a.poses.size(); ++i) {
    const BodyPose<Real>& p = a.poses[i];
    const BodyPose<Real>& q = b.poses[i];
    if (p.id != q.id || p.sleeping != q.sleeping || std::memcmp(p.position, q.position, sizeof p.position) ||
        std::memcmp(p.orientation, q.orientation, sizeof p.orientation) ||
        std::memcmp(p.linear_velocity, q.linear_velocity, sizeof p.linear_velocity) ||
        std::memcmp(p.angular_velocity, q.angular_velocity, sizeof p.angular_velocity))
      return "step " + std::to_string(a.step) + ": body " + std::to_string(q.id) + " differs";
  }
  if (a.contacts.size() != b.contacts.size())
    return "step " + std::to_string(a.step) + ": " + std::to_string(a.contacts.size()) + " contacts vs " +
           std::to_string(b.contacts.size());
  for (std::size_t i = 0; i < a.contacts.size(); ++i)
    if (a.contacts[i].a != b.contacts[i].a || a.contacts[i].b != b.contacts[i].b ||
        a.contacts[i].point_count != b.contacts[i].point_count ||
        std::memcmp(a.contacts[i].points, b.contacts[i].points, sizeof a.contacts[i].points) != 0)
      return "step " + std::to_string(a.step) + ": contact " + std::to_string(i) + " differs";
  return "";
}

// A world of bodies of which some move each step: `moving` share of them
// (1 = all), bodies joining and leaving now and then.
template <class Real>
struct World {
  std::mt19937_64 rng;
  std::map<BodyId, BodyPose<Real>> bodies;
  BodyId next_id = 0;
  explicit World(std::uint64_t seed, int n) : rng(seed) {
    for (int i = 0; i < n; ++i) add();
  }
  void add() {
    BodyPose<Real> p;
    p.id = next_id;
    next_id += 1 + static_cast<BodyId>(rng() % 3);
    p.position[0] = static_cast<Real>(p.id);
    p.sleeping = true;
    bodies[p.id] = p;
  }
  void step(double moving) {
    std::uniform_real_distribution<double> u(0, 1);
    for (auto& [id, p] : bodies) {
      if (u(rng) >= moving) continue;
      p.position[1] += static_cast<Real>(0.125);
      p.linear_velocity[2] = static_cast<Real>(u(rng));
      p.orientation[0] = static_cast<Real>(-0.0);  // -0 and 0 differ in bits
      p.sleeping = !p.sleeping;
    }
    if (u(rng) < 0.1) add();
    if (u(rng) < 0.1 && !bodies.empty()) {
      auto it = bodies.begin();
      std::advance(it, static_cast<long>(rng() % bodies.size()));
      bodies.erase(it);
    }
  }
  TransformEntry<Real> entry(std::int64_t step, std::uint64_t salt) const {
    TransformEntry<Real> e;
    e.step = step;
    e.time = static_cast<double>(step) * kDt;
    e.busy_seconds = static_cast<double>(salt % 7) * 1e-3;
    for (const auto& [id, p] : bodies) e.poses.push_back(p);
    // Contacts of each step's own (no two steps alike): 0 to 4 pairs.
    for (std::uint64_t k = 0; k < salt % 5; ++k) {
      PairContact<Real> c;
      c.a = static_cast<BodyId>(2 * k);
      c.b = static_cast<BodyId>(2 * k + 1 + salt % 3);
      c.point_count = 1 + static_cast<std::uint32_t>((salt >> 8) % 4);
      c.points[0].impulse = static_cast<Real>(static_cast<double>(salt % 1000) + static_cast<double>(step));
      c.points[0].normal_on_b[1] = 1;
      e.contacts.push_back(c);
    }
    return e;
  }
};

template <class Real>
class DeltaEntryTest : public ::testing::Test {};
using Precisions = ::testing::Types<float, double>;
TYPED_TEST_SUITE(DeltaEntryTest, Precisions);

// The same steps published into a delta buffer and a full one, with
// rollbacks that republish steps with other contents, phases where nothing,
// a few or every body moves: every read (read_next, read_at, interpolate)
// is the same, bit for bit.
TYPED_TEST(DeltaEntryTest, ReadersGetWhatWasPublished) {
  using Real = TypeParam;
  TransformBuffer<Real> delta(12, true);
  TransformBuffer<Real> full(12, false);
  ASSERT_TRUE(delta.delta());
  ASSERT_FALSE(full.delta());
  const auto rd = delta.add_reader();
  const auto rf = full.add_reader();
  World<Real> world(7, 300);
  std::vector<World<Real>> history{world};  // world state after each step, for rollbacks
  std::mt19937_64 rng(11);
  std::int64_t step = 0;
  int reads = 0, rollbacks = 0;
  ASSERT_TRUE(delta.try_publish(world.entry(0, 0)));
  ASSERT_TRUE(full.try_publish(world.entry(0, 0)));
  for (int i = 0; i < 600; ++i) {
    const int phase = (i / 50) % 4;
    const double moving = phase == 0 ? 0.0 : phase == 1 ? 0.02 : phase == 2 ? 1.0 : 0.3;
    if (rng() % 13 == 0 && step > delta.commit_step() + 2) {
      const std::int64_t back = delta.commit_step() + 1 + static_cast<std::int64_t>(rng() % 2);
      delta.invalidate_from(back);
      full.invalidate_from(back);
      step = back - 1;
      history.erase(history.begin() + step + 1, history.end());
      world = history.back();
      world.rng.seed(rng());  // the re-run differs
      ++rollbacks;
    }
    world.step(moving);
    ++step;
    history.push_back(world);
    const std::uint64_t salt = rng();
    ASSERT_TRUE(delta.try_publish(world.entry(step, salt)));
    ASSERT_TRUE(full.try_publish(world.entry(step, salt)));
    while (auto a = delta.read_next(rd)) {
      auto b = full.read_next(rf);
      ASSERT_TRUE(b);
      ASSERT_EQ(difference(*a, *b), "") << "read_next";
      ++reads;
    }
    if (step > 4) {
      const double t = (static_cast<double>(step) - 1.5) * kDt;
      auto a = delta.read_at(t);
      auto b = full.read_at(t);
      ASSERT_EQ(!a, !b);  // freed in both (just after a rollback) or held in both
      if (a) {
        ASSERT_EQ(difference(*a, *b), "") << "read_at";
        ++reads;
      }
      auto sa = delta.interpolate(t + 0.3 * kDt);
      auto sb = full.interpolate(t + 0.3 * kDt);
      ASSERT_EQ(!sa, !sb);
      if (sa) {
        ASSERT_EQ(sa->poses.size(), sb->poses.size());
        for (std::size_t k = 0; k < sa->poses.size(); ++k)
          ASSERT_EQ(std::memcmp(sa->poses[k].position, sb->poses[k].position, sizeof sa->poses[k].position), 0);
      }
    }
    const std::int64_t commit = step - 3;
    if (commit > delta.commit_step()) {
      delta.set_commit_step(commit);
      full.set_commit_step(commit);
    }
  }
  EXPECT_GT(reads, 1000);
  EXPECT_GT(rollbacks, 20);
}

// 10,000 bodies of which 100 move: a buffered step holds about the 100, and
// every entry shares one key; without deltas each holds all 10,100.
TYPED_TEST(DeltaEntryTest, MemoryFollowsMovingBodies) {
  using Real = TypeParam;
  constexpr std::size_t kCapacity = 32;
  for (bool on : {true, false}) {
    TransformBuffer<Real> buffer(kCapacity, on);
    (void)buffer.add_reader();  // reads nothing: pins every entry
    World<Real> still(3, 10000);
    World<Real> moving(5, 100);
    for (auto& [id, p] : moving.bodies) p.id = id + 1'000'000;
    for (std::int64_t s = 0; s < static_cast<std::int64_t>(kCapacity); ++s) {
      moving.step(1.0);
      moving.bodies.erase(moving.bodies.begin()->first);  // keep 100, ids shift: joins and leaves
      moving.add();
      TransformEntry<Real> e = still.entry(s, 0);
      for (const auto& [id, p] : moving.bodies) {
        BodyPose<Real> q = p;
        q.id = id + 1'000'000;
        e.poses.push_back(q);
      }
      ASSERT_TRUE(buffer.try_publish(std::move(e)));
    }
    const BufferMemory m = buffer.memory();
    ASSERT_EQ(m.entries, kCapacity);
    const std::size_t per_step = m.delta_bytes / m.entries;
    std::printf("[ %s delta %s ] %zu entries, %zu keys, %zu delta bytes per step, %zu key bytes\n",
                sizeof(Real) == 4 ? "float" : "double", on ? "on" : "off", m.entries, m.key_entries, per_step,
                m.key_bytes);
    if (on) {
      EXPECT_EQ(m.key_entries, 1u);
      EXPECT_LE(per_step, 3 * 100 * sizeof(BodyPose<Real>) + 512);
    } else {
      EXPECT_EQ(m.key_entries, kCapacity);
      EXPECT_GE(m.key_bytes, kCapacity * 10100 * sizeof(BodyPose<Real>));
    }
  }
}

// Bodies that move once and stop (a wave through a field of sleepers) do not
// pile up in every later delta: the key moves on (delta_encoder.h's rule).
TYPED_TEST(DeltaEntryTest, StoppedBodiesLeaveTheDelta) {
  using Real = TypeParam;
  constexpr std::size_t kCapacity = 16;
  TransformBuffer<Real> buffer(kCapacity, true);
  World<Real> world(9, 4000);
  std::vector<BodyId> ids;
  for (const auto& [id, p] : world.bodies) ids.push_back(id);
  for (std::int64_t s = 0; s < 400; ++s) {
    for (std::size_t k = 0; k < 20; ++k)  // 20 new bodies move, once
      world.bodies[ids[(static_cast<std::size_t>(s) * 20 + k) % ids.size()]].position[2] += Real(1);
    TransformEntry<Real> e = world.entry(s, 0);
    ASSERT_TRUE(buffer.try_publish(std::move(e)));
    buffer.set_commit_step(s);  // no reader: committed entries go, a few stay held
  }
  (void)buffer.add_reader();
  for (std::int64_t s = 400; s < 400 + static_cast<std::int64_t>(kCapacity) - 1; ++s) {
    for (std::size_t k = 0; k < 20; ++k)
      world.bodies[ids[(static_cast<std::size_t>(s) * 20 + k) % ids.size()]].position[2] += Real(1);
    ASSERT_TRUE(buffer.try_publish(world.entry(s, 0)));
  }
  const BufferMemory m = buffer.memory();
  // At most 2a + K / capacity + a per entry (a = 20): about 310 poses.
  EXPECT_LE(m.delta_bytes / m.entries, (3 * 20 + 4000 / kCapacity + 20) * sizeof(BodyPose<Real>) + 512);
  EXPECT_GE(m.key_entries, 1u);
}

}  // namespace
}  // namespace soda

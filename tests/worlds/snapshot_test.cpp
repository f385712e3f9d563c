// Snapshots: a fresh world built from a snapshot (bodies inserted in a
// shuffled order), directly or through bytes, continues the trajectory bit
// for bit; malformed bytes are rejected with SnapshotFormatError.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <string>
#include <utility>

#include <btBulletDynamicsCommon.h>

#include "soda/worlds/canonical_world.h"
#include "soda/worlds/snapshot_parts.h"
#include "soda/worlds/value_codec.h"
#include "worlds/world_test_util.h"

namespace soda {
namespace {

using test::kSteps;
constexpr int kSnapshotStep = 200;

void expect_restore_reproduces(const std::string& name) {
  const Scene s = test::scene(name);
  CanonicalWorld reference(s);
  test::run(reference, kSnapshotStep);
  const WorldSnapshot snap = reference.snapshot();
  const std::uint64_t at_snapshot = reference.state_hash(true);
  std::size_t asleep_in_snapshot = 0;
  for (const BodySnapshot& b : snap.bodies) asleep_in_snapshot += b.state.activation_state == ISLAND_SLEEPING;
  if (name == "falling-cubes") {
    EXPECT_GT(asleep_in_snapshot, 0u) << "the snapshot should hold sleepers";
  }
  test::run(reference, kSteps - kSnapshotStep);

  CanonicalWorld restored(snap, test::shuffled_order(snap.bodies.size(), 11));
  EXPECT_EQ(hash_hex(restored.state_hash(true)), hash_hex(at_snapshot));
  test::run(restored, kSteps - kSnapshotStep);

  const std::vector<std::uint8_t> bytes = serialize(snap);
  CanonicalWorld from_bytes(deserialize_snapshot(bytes), test::reversed_order(snap.bodies.size()));
  test::run(from_bytes, kSteps - kSnapshotStep);

  std::printf("[ %s %s ] %d steps: uninterrupted %s, restored at %d (shuffled) %s, via %zu bytes %s; "
              "%zu manifolds and %zu sleepers in snapshot; sleeping at end %zu %zu %zu\n",
              name.c_str(), kPrecisionName, kSteps, hash_hex(reference.state_hash()).c_str(), kSnapshotStep,
              hash_hex(restored.state_hash()).c_str(), bytes.size(), hash_hex(from_bytes.state_hash()).c_str(),
              snap.manifolds.size(), asleep_in_snapshot, reference.sleeping_count(), restored.sleeping_count(),
              from_bytes.sleeping_count());
  EXPECT_GT(snap.manifolds.size(), 0u);
  EXPECT_EQ(restored.steps_done(), kSteps);
  EXPECT_EQ(hash_hex(reference.state_hash(true)), hash_hex(restored.state_hash(true)));
  EXPECT_EQ(hash_hex(reference.state_hash(true)), hash_hex(from_bytes.state_hash(true)));
  EXPECT_EQ(reference.sleeping_count(), restored.sleeping_count());
  EXPECT_EQ(reference.sleeping_count(), from_bytes.sleeping_count());
}

TEST(Snapshot, FreshWorldRestoreFallingCubes) { expect_restore_reproduces("falling-cubes"); }
TEST(Snapshot, FreshWorldRestoreCubePile) { expect_restore_reproduces("cube-pile"); }

// A sphere's manifolds with boxes belong to convex-convex algorithms, which
// create their manifold lazily: restore must create it too.
TEST(Snapshot, FreshWorldRestoreWithSpheres) {
  const Scene s = test::scene("projectile", 0);
  CanonicalWorld a(s);
  test::run(a, 100);
  const WorldSnapshot snap = a.snapshot();
  bool sphere_contact = false;
  for (const ManifoldState& m : snap.manifolds) sphere_contact = sphere_contact || m.id1 == 5;
  EXPECT_TRUE(sphere_contact) << "the snapshot should hold the sphere's ground contact";
  CanonicalWorld b(snap, test::reversed_order(snap.bodies.size()));
  test::run(a, 200);
  test::run(b, 200);
  std::printf("[ projectile %s ] uninterrupted %s, restored at 100 %s\n", kPrecisionName,
              hash_hex(a.state_hash(true)).c_str(), hash_hex(b.state_hash(true)).c_str());
  EXPECT_EQ(hash_hex(a.state_hash(true)), hash_hex(b.state_hash(true)));
}

// The contact state is part of the state: dropping it changes the trajectory.
TEST(Snapshot, ContactStateMatters) {
  const Scene s = test::scene("cube-pile", 200);
  CanonicalWorld a(s);
  test::run(a, 150);
  WorldSnapshot snap = a.snapshot();
  snap.manifolds.clear();
  CanonicalWorld b(snap);
  test::run(a, 50);
  test::run(b, 50);
  std::printf("[ cube-pile %s ] with contact state %s, without %s\n", kPrecisionName,
              hash_hex(a.state_hash()).c_str(), hash_hex(b.state_hash()).c_str());
  EXPECT_NE(a.state_hash(), b.state_hash());
}

TEST(Snapshot, OneUlpInARestoredWorldChangesTheHash) {
  const Scene s = test::scene("falling-cubes", 50);
  CanonicalWorld a(s);
  test::run(a, 30);
  WorldSnapshot snap = a.snapshot();
  btScalar& x = snap.bodies[17].state.origin[0];
  x = std::nextafter(x, btScalar(1e30));
  CanonicalWorld b(snap);
  std::printf("[ one ulp %s ] world %s, restored with one ulp more %s\n", kPrecisionName,
              hash_hex(a.state_hash()).c_str(), hash_hex(b.state_hash()).c_str());
  EXPECT_NE(a.state_hash(), b.state_hash());
}

TEST(Snapshot, BytesRoundTripExactly) {
  const Scene s = test::scene("cube-pile", 100);
  CanonicalWorld a(s);
  test::run(a, 100);
  const WorldSnapshot snap = a.snapshot();
  const std::vector<std::uint8_t> bytes = serialize(snap);
  EXPECT_EQ(serialize(deserialize_snapshot(bytes)), bytes);
  EXPECT_EQ(contact_hash(deserialize_snapshot(bytes).manifolds), contact_hash(snap.manifolds));
}

// same_bits compares without encoding (re-runs compare states every step):
// it must say what comparing the bytes says, for a change in any part.
TEST(Snapshot, SameBitsAgreesWithTheBytes) {
  const Scene s = test::scene("cube-pile", 100);
  CanonicalWorld a(s);
  test::run(a, 100);
  const WorldSnapshot snap = a.snapshot();
  ASSERT_FALSE(snap.manifolds.empty());
  auto next_ulp = [](btScalar& x) { x = std::nextafter(x, btScalar(1e30)); };
  std::vector<std::pair<const char*, std::function<void(WorldSnapshot&)>>> changes = {
      {"nothing", [](WorldSnapshot&) {}},
      {"steps_done", [](WorldSnapshot& w) { ++w.steps_done; }},
      {"settings.dt", [](WorldSnapshot& w) { w.settings.dt *= 2; }},
      {"a body's origin", [&](WorldSnapshot& w) { next_ulp(w.bodies[5].state.origin[1]); }},
      {"a body's activation state", [](WorldSnapshot& w) { w.bodies[7].state.activation_state ^= 3; }},
      {"a body's friction", [](WorldSnapshot& w) { w.bodies[3].description.friction += 0.25; }},
      {"a body's hull", [](WorldSnapshot& w) { w.bodies[2].description.shape.points.push_back(Vec3::Ones()); }},
      {"a contact's impulse", [&](WorldSnapshot& w) { next_ulp(w.manifolds.back().points.front().applied_impulse); }},
      {"a contact's lifetime", [](WorldSnapshot& w) { ++w.manifolds.front().points.back().lifetime; }},
      {"a manifold's points", [](WorldSnapshot& w) { w.manifolds.front().points.pop_back(); }},
      {"a body less", [](WorldSnapshot& w) { w.bodies.pop_back(); }},
  };
  for (const auto& [what, change] : changes) {
    WorldSnapshot other = snap;
    change(other);
    EXPECT_EQ(same_bits(snap, other), serialize(snap) == serialize(other)) << what;
    EXPECT_EQ(same_bits(snap, other), std::string(what) == "nothing") << what;
  }
}

TEST(Snapshot, MalformedBytesThrow) {
  const Scene s = test::scene("cube-pile", 30);
  CanonicalWorld a(s);
  test::run(a, 60);
  const std::vector<std::uint8_t> bytes = serialize(a.snapshot());
  // Every truncation.
  for (std::size_t n = 0; n < bytes.size(); n += (n < 64 ? 1 : 7)) {
    std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n));
    EXPECT_THROW(deserialize_snapshot(cut), SnapshotFormatError) << "truncated to " << n;
  }
  auto with = [&](std::size_t at, std::uint8_t value) {
    std::vector<std::uint8_t> b = bytes;
    b[at] = value;
    return b;
  };
  EXPECT_THROW(deserialize_snapshot(with(0, 'X')), SnapshotFormatError);           // magic
  EXPECT_THROW(deserialize_snapshot(with(12, 3)), SnapshotFormatError);            // precision
  std::vector<std::uint8_t> longer = bytes;
  longer.push_back(0);
  EXPECT_THROW(deserialize_snapshot(longer), SnapshotFormatError);                 // trailing
  std::vector<std::uint8_t> huge = bytes;
  const std::size_t body_count_at = 8 + 4 + 4 + 8 + 4 + 4 + 24 + 4 + 8;
  for (int i = 0; i < 4; ++i) huge[body_count_at + i] = 0xff;
  EXPECT_THROW(deserialize_snapshot(huge), SnapshotFormatError);                   // count
  // Random single-byte corruptions never crash: they throw or decode.
  for (std::size_t at = 0; at < bytes.size(); at += 13) {
    try {
      (void)deserialize_snapshot(with(at, static_cast<std::uint8_t>(bytes[at] ^ 0xa5)));
    } catch (const SnapshotFormatError&) {
    }
  }
}

// One world's part (a snapshot over MPI ranks travels as parts): its
// manifolds name bodies it does not hold and may hold a pair twice (live
// and kept). deserialize_snapshot refuses such bytes, deserialize_part_snapshot
// reads them back bit for bit; both refuse manifolds out of order.
TEST(Snapshot, APartNamesBodiesItDoesNotHold) {
  const Scene s = test::scene("cube-pile", 100);
  CanonicalWorld a(s);
  test::run(a, 100);
  WorldSnapshot part = a.snapshot();
  ASSERT_GE(part.manifolds.size(), 2u);
  const BodyId named = part.manifolds.front().id1;
  part.bodies.erase(std::remove_if(part.bodies.begin(), part.bodies.end(),
                                   [&](const BodySnapshot& b) { return b.description.id == named; }),
                    part.bodies.end());
  part.manifolds.insert(part.manifolds.begin(), part.manifolds.front());  // live and kept
  const std::vector<std::uint8_t> bytes = serialize(part);
  EXPECT_THROW(deserialize_snapshot(bytes), SnapshotFormatError);
  EXPECT_EQ(serialize(deserialize_part_snapshot(bytes)), bytes);
  std::swap(part.manifolds.front(), part.manifolds.back());
  EXPECT_THROW(deserialize_part_snapshot(serialize(part)), SnapshotFormatError);
  EXPECT_THROW(deserialize_part_snapshot(std::vector<std::uint8_t>(bytes.begin(), bytes.end() - 1)),
               SnapshotFormatError);
}

// A manifold's points are held inline (at most 4): growing past 4 throws
// instead of writing past the storage, and a copy carries exactly the points
// in use, field for field.
TEST(ContactPoints, HoldsAtMostFourAndCopiesThePointsInUse) {
  ContactPoints points;
  EXPECT_TRUE(points.empty());
  for (int i = 0; i < 4; ++i) {
    ContactPointState p{};
    p.applied_impulse = btScalar(i + 1);
    p.lifetime = 10 + i;
    points.push_back(p);
  }
  EXPECT_EQ(points.size(), 4u);
  EXPECT_THROW(points.push_back(ContactPointState{}), std::length_error);
  EXPECT_THROW(points.resize(5), std::length_error);
  EXPECT_EQ(points.size(), 4u);

  ManifoldState a{3, 7, points};
  a.points.pop_back();
  ManifoldState b = a;
  ASSERT_EQ(b.points.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(b.points[i].applied_impulse, btScalar(i + 1));
    EXPECT_EQ(b.points[i].lifetime, 10 + static_cast<int>(i));
  }
  EXPECT_TRUE(same_bits(a, b));
  b.points.resize(4);  // a new point is all zeros, not the old fourth
  EXPECT_EQ(b.points.back().applied_impulse, btScalar(0));
  EXPECT_EQ(b.points.back().lifetime, 0);
  EXPECT_FALSE(same_bits(a, b));

  b.points.clear();
  EXPECT_THROW(b.points.pop_back(), std::out_of_range);
  EXPECT_THROW((ContactPoints{ContactPointState{}, ContactPointState{}, ContactPointState{}, ContactPointState{},
                              ContactPointState{}}),
               std::length_error);
}

}  // namespace
}  // namespace soda

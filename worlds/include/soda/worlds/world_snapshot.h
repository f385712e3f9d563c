// worlds/ — one territory's physics. This header: the full state of a
// canonical world as plain values (no pointers), so that it can be restored
// into a fresh world, carried across a process boundary, or split into bodies
// and manifolds that migrate between worlds.
//
// What a snapshot captures (everything a step reads):
//  1. every body, statics included: its description (shape, mass, friction,
//     restitution) and its raw dynamic state (transform, interpolation
//     transform, velocities, interpolation velocities, activation state,
//     deactivation timer, hit fraction), in btScalar bits;
//  2. the contact state: every persistent manifold that holds contact points,
//     keyed by (id0, id1) = the ids of its body0/body1 (id0 < id1), with every
//     field of every point in cache order, warm-start impulses included.
// What it does not capture: manifolds without points and broadphase pairs
// (both depend on the broadphase's history, not on the physics: a step does
// not depend on them), solver scratch (rebuilt every step), forces (cleared
// at the end of every step). Bodies are sorted by id, manifolds by (id0, id1).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <vector>

#include <LinearMath/btScalar.h>

#include "soda/scene/scene.h"

namespace soda {

/// Raw dynamic state of one body: what Bullet holds, bit for bit.
struct BodyDynamicState {
  btScalar basis[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // row major, as btMatrix3x3
  btScalar origin[3] = {0, 0, 0};
  btScalar interpolation_basis[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  btScalar interpolation_origin[3] = {0, 0, 0};
  btScalar linear_velocity[3] = {0, 0, 0};
  btScalar angular_velocity[3] = {0, 0, 0};
  btScalar interpolation_linear_velocity[3] = {0, 0, 0};
  btScalar interpolation_angular_velocity[3] = {0, 0, 0};
  std::int32_t activation_state = 1;  // ACTIVE_TAG, ISLAND_SLEEPING, ...
  btScalar deactivation_time = 0;     // s; the sleep timer
  btScalar hit_fraction = 1;
};

/// One body: description (its pose/velocity fields are those it was created
/// with and are NOT used on restore) + raw state (used on restore).
struct BodySnapshot {
  Body description;
  BodyDynamicState state;
};

/// Every field of a btManifoldPoint that narrowphase or solver read.
struct ContactPointState {
  btScalar local_point_a[3], local_point_b[3];
  btScalar position_world_on_b[3], position_world_on_a[3];
  btScalar normal_world_on_b[3];
  btScalar distance;
  btScalar combined_friction, combined_rolling_friction, combined_spinning_friction;
  btScalar combined_restitution;
  std::int32_t part_id0, part_id1, index0, index1;
  std::int32_t contact_point_flags;
  btScalar applied_impulse, prev_rhs;
  btScalar applied_impulse_lateral1, applied_impulse_lateral2;
  btScalar contact_motion1, contact_motion2;
  btScalar contact_cfm, combined_contact_stiffness1;  // union in Bullet (cfm | stiffness)
  btScalar contact_erp, combined_contact_damping1;    // union in Bullet (erp | damping)
  btScalar friction_cfm;
  std::int32_t lifetime;  // steps
  btScalar lateral_friction_dir1[3], lateral_friction_dir2[3];
};

/// The points of one manifold, in cache order: at most kCapacity (Bullet's
/// MANIFOLD_CACHE_SIZE), held inline. A merged island's manifolds are copied
/// four times a step (fragment, the root's copy, the result, the holder), and
/// a heap allocation each was 4 % of a partitioned cube-pile's CPU
/// (docs/coloured-solve.md). A sequence of at most 4: resize or
/// push_back beyond that throws std::length_error, never overflows.
class ContactPoints {
 public:
  static constexpr std::size_t kCapacity = 4;
  using value_type = ContactPointState;
  using iterator = ContactPointState*;
  using const_iterator = const ContactPointState*;

  ContactPoints() = default;
  ContactPoints(std::initializer_list<ContactPointState> points) {
    check(points.size());
    for (const ContactPointState& p : points) points_[size_++] = p;
  }
  ContactPoints(const ContactPoints& other) : size_(other.size_) { copy_from(other); }
  ContactPoints& operator=(const ContactPoints& other) {
    size_ = other.size_;
    copy_from(other);
    return *this;
  }

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  static constexpr std::size_t capacity() { return kCapacity; }

  /// New points (growing) are value-initialised (all fields zero).
  void resize(std::size_t n) {
    check(n);
    for (std::size_t i = size_; i < n; ++i) points_[i] = ContactPointState{};
    size_ = static_cast<std::uint32_t>(n);
  }
  void push_back(const ContactPointState& p) {
    check(size_ + 1u);
    points_[size_++] = p;
  }
  void pop_back() {
    if (size_ == 0) throw std::out_of_range("ContactPoints::pop_back on no points");
    --size_;
  }
  void clear() { size_ = 0; }

  ContactPointState& operator[](std::size_t i) { return points_[i]; }
  const ContactPointState& operator[](std::size_t i) const { return points_[i]; }
  ContactPointState& front() { return points_[0]; }
  const ContactPointState& front() const { return points_[0]; }
  ContactPointState& back() { return points_[size_ - 1]; }
  const ContactPointState& back() const { return points_[size_ - 1]; }
  iterator begin() { return points_.data(); }
  iterator end() { return points_.data() + size_; }
  const_iterator begin() const { return points_.data(); }
  const_iterator end() const { return points_.data() + size_; }

 private:
  static void check(std::size_t n) {
    if (n > kCapacity) throw std::length_error("a manifold holds at most 4 contact points");
  }
  // Only the points in use: a copy of a one-point manifold moves one point.
  void copy_from(const ContactPoints& other) {
    for (std::size_t i = 0; i < size_; ++i) points_[i] = other.points_[i];
  }

  std::array<ContactPointState, kCapacity> points_;  // [size_, 4) unspecified
  std::uint32_t size_ = 0;
};

/// The contact state of one pair: a persistent manifold's points in cache
/// order (at most 4). id0 < id1 are the ids of Bullet's body0 and body1.
struct ManifoldState {
  /// No points, ids 0. User-provided on purpose: a `resize` of a vector of
  /// ManifoldState then leaves the unused point slots alone instead of
  /// zeroing all four (a merged island's fragment and result arrays were
  /// 1.2 % of a partitioned heap's instructions in memset, docs/coloured-solve.md).
  ManifoldState() {}
  ManifoldState(BodyId first, BodyId second, ContactPoints contact_points = {})
      : id0(first), id1(second), points(contact_points) {}

  BodyId id0 = 0;
  BodyId id1 = 0;
  ContactPoints points;
};

/// One joint: its description and whether it has broken, the only state a
/// joint carries from step to step (Bullet's solver does not warm-start
/// joint rows; worlds/src/joint_factory.h).
struct JointSnapshot {
  Joint description;
  bool broken = false;
};

struct WorldSnapshot {
  SceneSettings settings;
  std::int64_t steps_done = 0;
  std::vector<BodySnapshot> bodies;      // sorted by id
  std::vector<ManifoldState> manifolds;  // sorted by (id0, id1); every one has points
  std::vector<JointSnapshot> joints;     // sorted by id
};

/// Thrown by deserialize_snapshot for bytes that are not a valid snapshot of
/// this build's precision (truncated, corrupted, wrong magic or precision).
class SnapshotFormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Self-describing little-endian byte encoding (magic, version, btScalar
/// size, then every field). Round trip is bit-exact. A snapshot without
/// joints is written as version 1 (the bytes of every build before joints);
/// one with joints as version 2, which adds the joints after the manifolds.
/// Both are read.
std::vector<std::uint8_t> serialize(const WorldSnapshot& snapshot);

/// True if serialize(a) == serialize(b), without encoding either: settings,
/// steps done, every body (description and raw state) and every manifold,
/// bit for bit.
bool same_bits(const WorldSnapshot& a, const WorldSnapshot& b);

/// Inverse of serialize. Never undefined behaviour on bad input: throws
/// SnapshotFormatError with the reason and byte offset.
WorldSnapshot deserialize_snapshot(const std::vector<std::uint8_t>& bytes);

/// The snapshot's settings, body descriptions and joints as a Scene (ids,
/// shapes, masses, materials; poses and velocities as the bodies were
/// created, not as they are now: the raw states are in
/// snapshot.bodies[i].state; whether a joint broke is in snapshot.joints).
Scene scene_of(const WorldSnapshot& snapshot);

/// Canonical 64-bit hash (FNV-1a) of a contact state: manifolds in (id0, id1)
/// order, every field of every point. Input order does not matter.
std::uint64_t contact_hash(std::vector<ManifoldState> manifolds);

}  // namespace soda

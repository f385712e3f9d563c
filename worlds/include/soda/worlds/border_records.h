// worlds/ — one territory's physics. This header: the values a territory
// world hands to its neighbours and takes from them (docs/partitioned-step.md):
// ghosts with the contact state they carry, island fragments, migrants. Plain
// values, no pointers: the runtime wraps them into messages and may turn them
// into bytes and back (runtime/message_codec.h).
#pragma once

#include <cstdint>
#include <vector>

#include <LinearMath/btScalar.h>

#include "soda/grid/territory_map.h"
#include "soda/worlds/world_snapshot.h"

namespace soda {

/// One body as its owner holds it after predict at some step: everything a
/// ghost is built from and everything an island solve reads.
struct BodyRecord {
  BodySnapshot body;                  // description + raw state after predict
  btScalar total_force[3] = {0, 0, 0};   // N; gravity if the body was awake at predict
  btScalar total_torque[3] = {0, 0, 0};  // N m
};

/// A border body sent to a neighbour whose territory its halo overlaps.
struct GhostRecord {
  BodyRecord record;
  /// Every world the owner sends this body to at this step, ascending: with
  /// the owner, the worlds that "have" the body (pair holder rule).
  std::vector<WorldId> sent_to;
};

/// What a world sends one neighbour in exchange_ghosts (one per neighbour and
/// step, possibly empty).
struct GhostBatch {
  std::vector<GhostRecord> ghosts;      // ascending id
  /// Contact state the sender keeps for pairs whose key body is one of these
  /// ghosts (the pair's holder may be the receiver): seeds, by (id0, id1).
  std::vector<ManifoldState> kept_manifolds;
};

/// Island gluing (build_islands): "your body `body` lies in my island
/// fragment whose root is `fragment_root`".
struct GlueEntry {
  BodyId body = 0;
  BodyId fragment_root = 0;
  friend bool operator==(const GlueEntry&, const GlueEntry&) = default;
};
struct GlueBatch {
  std::vector<GlueEntry> entries;  // ascending body
};

/// A ghost in a fragment: the link to the fragment of its owner that holds it.
struct LinkOut {
  WorldId owner = kNoWorld;
  BodyId body = 0;
  friend bool operator==(const LinkOut&, const LinkOut&) = default;
  friend auto operator<=>(const LinkOut&, const LinkOut&) = default;
};
/// An owned body of a fragment that another world's fragment glued.
struct LinkIn {
  WorldId world = kNoWorld;
  BodyId fragment_root = 0;
  BodyId body = 0;
  friend bool operator==(const LinkIn&, const LinkIn&) = default;
  friend auto operator<=>(const LinkIn&, const LinkIn&) = default;
};

/// "No body": ids are below 2^31.
inline constexpr BodyId kNoBody = 0xffffffffu;

/// The part of a border island one world sees: a connected component of its
/// contact graph (owned bodies and ghosts joined by the manifolds it holds).
/// Identified by (world, root); root = smallest body id in it. Its header
/// (ids and links) is what merge_islands floods; its data (bodies,
/// manifolds) travels to the island's root only (its weight, in the header,
/// decides which world that is).
struct Fragment {
  WorldId world = kNoWorld;
  BodyId root = 0;
  BodyId first_body = kNoBody;            // smallest owned body (kNoBody: only ghosts)
  /// Owned bodies + manifolds held: this fragment's share of the island's
  /// copies and contact rows. The world whose fragments weigh most is the
  /// island's root (docs/partitioned-step.md).
  std::uint32_t weight = 0;
  std::vector<LinkOut> links_out;         // its ghosts, ascending
  std::vector<LinkIn> links_in;           // its glued owned bodies, ascending
  std::vector<BodyRecord> bodies;         // its owned bodies, ascending id
  std::vector<ManifoldState> manifolds;   // manifolds it holds with points, by (id0, id1)
  /// The joints between its owned bodies (and static ones) that have not
  /// broken, by id: island edges the merged solve builds on its bodies.
  /// Not in the weight.
  std::vector<Joint> joints;
};

/// The solve of one border island: what every involved world keeps of it.
struct BodyResult {
  BodyId id = 0;
  btScalar linear_velocity[3] = {0, 0, 0};
  btScalar angular_velocity[3] = {0, 0, 0};
  btScalar basis[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // world transform after the solve
  btScalar origin[3] = {0, 0, 0};                    // (split impulse may move it)
  std::int32_t activation_state = 1;
  btScalar deactivation_time = 0;
};
struct IslandResult {
  BodyId island = 0;                      // smallest body id of the island
  std::vector<BodyResult> bodies;         // every body of the island, ascending id
  std::vector<ManifoldState> manifolds;   // every manifold, after the solve, by (id0, id1)
  std::vector<JointId> broken_joints;     // the island's joints that broke in this solve, ascending
};

/// A body changing owner at a step boundary, with the contact state kept for
/// pairs whose key body it is.
struct Migrant {
  BodySnapshot body;                      // raw state at the end of the step
  std::vector<ManifoldState> kept_manifolds;
};
struct MigrantBatch {
  std::vector<Migrant> migrants;  // ascending id
  /// The joints of the migrants, by id, with whether each has broken: a
  /// joint's bodies always have one owner (a joint group, territory_world.h),
  /// so they and their joints move together.
  std::vector<JointSnapshot> joints;
};

}  // namespace soda

// worlds/ — one territory's physics. This header: the territory world, one
// Bullet world holding the dynamic bodies one world owns, read-only ghosts of
// its neighbours' border bodies and the static bodies its pairs may meet,
// stepped in stages between which the runtime exchanges messages. Why results
// are bit-identical to one CanonicalWorld: docs/partitioned-step.md.
//
// Stages of one step, in order (each is one member function; the runtime
// calls them, waiting for neighbours' values where marked <-):
//   predict            gravity, damping, predicted transform of owned bodies;
//                      halos; which neighbours get which ghosts
//   exchange_ghosts    ghost_batch_for(n) ->, <- apply_ghosts(batches)
//   collide            AABBs, pairs, narrowphase of the pairs held here
//   build_islands      local islands solved at once; glue_batch_for(n) ->
//   <- border_fragments(glue): fragments of border islands
//   solve              solve_border_island(all fragments of one island), then
//                      finish_islands()
//   integrate          owned bodies only; sleep timers
//   migrate            migrate() ->, <- absorb_migrants(batches)
//
// Invariants:
//  1. a dynamic body is owned here iff the territory map gives its home cell
//     (cell of its origin at the step boundary) to this world; a jointed
//     body's home cell is its joint group's (below);
//  2. ghosts are read-only: written only from a GhostRecord of this step,
//     never predicted, solved in place or integrated here; a ghost not sent
//     again at the next step is removed;
//  3. narrowphase runs here only for pairs this world holds (rule H); the
//     manifold of any other pair present here is kept empty;
//  4. contact state is never lost: every manifold with points whose key body is owned here is live
//     in this world (this world held the pair at the last step) or a value in the kept store;
//  5. every island is solved as one solveGroup with its bodies by id, its
//     manifolds by (id0, id1) and its joints by joint id: local islands in
//     place, border islands on copies built from their fragments;
//  6. a joint group (the dynamic bodies joints connect, broken or not) has its anchor's (smallest
//     id's) home cell, so one owner holds its joints and they migrate together; a merged island gets
//     them from that owner's fragment (docs/partitioned-step.md, "Joints").
//
// The world keeps the territory's state and the stage entry points; rooms of
// its own (worlds/src) do the island work: IslandBuilder (island_builder.h,
// islands in canonical order, shared with the canonical world),
// BorderIslandSolver (border_island_solver.h, the merged island path) and
// IslandReplay (island_replay.h, what set_replay installs).
//
// Thread safety: none; one world is used by one thread at a time. Distinct
// worlds share no writable state (each owns its Bullet objects).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <unordered_map>
#include <utility>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/scene/scene.h"
#include "soda/worlds/body_state.h"
#include "soda/worlds/border_records.h"
#include "soda/worlds/step_replay.h"
#include "soda/worlds/territory_errors.h"
#include "soda/worlds/territory_counters.h"
#include "soda/worlds/watchdog.h"

class btPersistentManifold;
namespace soda {
class SolverPool;
}
class btVector3;
class btRigidBody;
class btCollisionObject;

namespace soda {

class TerritoryWorld {
 public:
  /// Builds world `id` of `map` for a scene: the dynamic bodies whose home cell
  /// the map gives to `id`; of the statics, every kinematic body and the fixed
  /// ones its pairs may meet (worlds/src/static_catalog.h).
  TerritoryWorld(const Scene& scene, WorldId id, TerritoryMap map);
  /// Builds world `id` of `map` from the whole scene's state at a step boundary
  /// (PartitionedWorld::snapshot, CanonicalWorld::snapshot): statics as above,
  /// the dynamic bodies whose home cell (origin as held) the map gives to `id`,
  /// each with its raw state, and the contact state of every pair whose key
  /// body it owns (kept, seeded into whichever world holds the pair at the next
  /// step). Worlds rebuilt this way from one snapshot step exactly as the
  /// worlds the snapshot was taken from, for any map
  /// (tests/runtime/snapshot_restore_test.cpp). steps_done() is
  /// snapshot.steps_done * settings.substeps, or `internal_steps_done` if given
  /// (>= 0: a boundary between substeps, which the snapshot's scene step count
  /// cannot name). Throws as the scene constructor does.
  ///
  /// `share_pools_of`: a world this one replaces (a rollback). The two then
  /// share Bullet's collision configuration, whose manifold and algorithm pools
  /// cost about 1 ms to build (a rollback of every world rebuilt 8 of them at a
  /// time), and, for the same id and map, its interior cells; results do not
  /// depend on it. Both must then be used by one thread at a time between them;
  /// the shared pools live as long as either world.
  TerritoryWorld(const WorldSnapshot& snapshot, WorldId id, TerritoryMap map, std::int64_t internal_steps_done = -1,
                 const TerritoryWorld* share_pools_of = nullptr);
  ~TerritoryWorld();
  TerritoryWorld(const TerritoryWorld&) = delete;
  TerritoryWorld& operator=(const TerritoryWorld&) = delete;

  WorldId id() const { return id_; }
  const TerritoryMap& map() const { return map_; }
  /// Internal steps completed (absorb_migrants ends a step).
  std::int64_t steps_done() const { return steps_done_; }

  // --- stages (see the header comment) ---------------------------------

  /// predict. Throws PartitionError if an owned body's halo overlaps a cell
  /// of a world that is not a neighbour (neighbours: the map's, within its
  /// reach()).
  void predict();
  /// exchange_ghosts, sending half: the batch for one neighbour (possibly
  /// empty). Valid between predict() and apply_ghosts().
  GhostBatch ghost_batch_for(WorldId neighbour) const;
  /// True if the batch for `neighbour` holds at least one ghost.
  bool sends_ghosts_to(WorldId neighbour) const;
  /// exchange_ghosts, receiving half: one batch from every neighbour. A
  /// ghost of a body this world owns, or of one body from two worlds, is a
  /// PartitionError — unless `speculative`: then a neighbour may have sent
  /// it from a run it will take back (a re-run that rejoined its old run
  /// before a changed message reached it re-sends that run's messages), and
  /// the ghost is left out; the neighbour's Notice rolls this step back.
  void apply_ghosts(const std::vector<std::pair<WorldId, GhostBatch>>& batches, bool speculative = false);
  /// True if `neighbour`'s batch of this step held at least one ghost.
  bool received_ghosts_from(WorldId neighbour) const;
  /// collide.
  void collide();
  /// build_islands: solves every island that no other world can touch.
  void build_islands();
  /// Glue for a neighbour that sent ghosts this step.
  GlueBatch glue_batch_for(WorldId neighbour) const;
  /// The glue of every neighbour this world sent ghosts to; returns this
  /// world's fragments of border islands (ascending root) and solves the
  /// components that no neighbour glued.
  std::vector<Fragment> border_fragments(const std::vector<std::pair<WorldId, GlueBatch>>& glue);
  /// solve: one merged border island, given every fragment of it (from every
  /// world involved, this one included); a pure function of the fragments (any
  /// world computes the same result). This world's own fragments of this step's
  /// border_fragments() are solved in place, each at most once: their bodies
  /// and the manifolds held here take the result now (the other worlds' bodies
  /// and manifolds are solved on copies; a held manifold with a ghost at one
  /// end points at the copy of the ghost's body during the solve). Bit for bit
  /// as on copies: a copy is written from the state the fragment read from the
  /// original (docs/coloured-solve.md, "The root's own share in place").
  IslandResult solve_border_island(const std::vector<const Fragment*>& island);
  /// Keeps this world's part of an island's result: its owned bodies, the
  /// manifolds it holds, the manifolds it keeps that others hold (what this
  /// world solved in place is already there).
  void apply_island_result(const IslandResult& result);
  /// After the last border island of the step: the kept store now holds the
  /// step's contact state of pairs kept here and held elsewhere.
  void finish_islands();
  /// integrate.
  void integrate();
  /// migrate, sending half: one batch per neighbour (ascending), possibly
  /// empty; the migrants leave this world now. Throws PartitionError if a
  /// body's new home belongs to a world that is not a neighbour.
  std::vector<std::pair<WorldId, MigrantBatch>> migrate();
  /// migrate, receiving half: one batch from every neighbour. Ends the step.
  void absorb_migrants(const std::vector<std::pair<WorldId, MigrantBatch>>& batches);

  /// Rollback and Propagate, for the next step only (call before predict()):
  /// an island this world solves in place is *replayed* — not solved — if
  /// every body in it is clean (its raw state and every manifold with
  /// points it is in, at the step's start, equal `before`'s bit for bit;
  /// inputs applied before predict() count) and `islands` holds an island
  /// of exactly these bodies. An island's step being a pure function of its
  /// contents, its result is then the old run's: at the end of integrate()
  /// (or in place of the solve: StepReplay::mid_step) its bodies and
  /// manifolds take their states in `after`. Islands that
  /// hold a ghost or were glued by a neighbour are always solved; so is one
  /// with a body or manifold `after` lacks (a body that left the world).
  void set_replay(const StepReplay& replay);
  /// Idle territories (docs/skip.md): true if this world's next step can
  /// be skipped unless a neighbour sends it a ghost — every owned body is
  /// settled (ISLAND_SLEEPING, timer > 0, velocities and forces +0, hit
  /// fraction 1, interpolation transform what predict() would write), it
  /// holds no ghost, sent no ghost at its last step, keeps no contact state
  /// of pairs held elsewhere, no replay is set and Bullet's sleeping is on.
  /// Such a step with no ghost arriving changes nothing: no gravity, solve,
  /// integration, narrowphase (two inactive bodies) or migration.
  /// O(owned bodies) at the first call after a change, O(1) after it. Call
  /// at a step boundary (before predict() or begin_idle_step()).
  bool idle_ready() const;
  /// Begins an idle step in place of predict() (idle_ready() was true): the
  /// step's counters are reset, no stage of it touches Bullet. The step ends
  /// with absorb_migrants() as every step; if a neighbour's ghost arrives
  /// instead, predict() is called (it writes the bits a settled body holds)
  /// and the step goes on as a full one.
  void begin_idle_step();
  /// The islands solved (or replayed) in place in the last step.
  const LocalIslands& local_islands() const { return local_islands_; }

  /// Parking (docs/skip.md, worlds/src/parking.h): at the end of every step,
  /// each island this world solved in place whose bodies are all settled
  /// (settled.h), lie inside this world's cells (sent to no neighbour) and keep
  /// no contact state here for a pair held elsewhere leaves the Bullet world;
  /// its contact state is kept as values. It comes back in collide() when the
  /// AABB of an active owned body or ghost overlaps one of its bodies (before
  /// the pair pass, its manifolds after it), or at once when an input names one
  /// of its bodies. Parked bodies are still owned: every readout and snapshot
  /// includes them and their contacts. Exact: every state is the same on and
  /// off (tests/runtime/parking_test.cpp). Switched on in a world without
  /// contact state (built from a scene), every settled body inside its cells is
  /// parked at once, each its own island; switched off, every island comes
  /// back; a world built from a snapshot in which another world keeps contact
  /// state of one of its bodies parks nothing then. A world built with
  /// share_pools_of takes the other world's setting. Off by default; call at a
  /// step boundary.
  void set_parking(bool on);
  bool parking() const { return parking_; }
  /// Owned bodies parked now.
  std::size_t parked_count() const { return parked_.size(); }

  /// The pool that large islands solved here (in place or merged) share their
  /// colours on (docs/coloured-solve.md); null: this world's thread alone.
  /// Several worlds may share one pool (one job at a time; a world that finds
  /// it busy solves alone). Results never depend on it. A world rebuilt with
  /// share_pools_of takes the other world's pool. Not during a step.
  void set_solver_pool(std::shared_ptr<SolverPool> pool);
  std::shared_ptr<SolverPool> solver_pool() const;

  // --- readout -------------------------------------------------------------

  /// The worlds this one exchanges messages with: the map's neighbours of
  /// this world (within the map's reach()), ascending.
  const std::vector<WorldId>& neighbours() const;
  const TerritoryCounters& counters() const { return counters_; }
  /// Raw states of the owned dynamic bodies, ascending id.
  std::vector<BodyState> owned_states() const;
  std::vector<BodyState> static_states() const;  // every static, ascending id
  std::vector<BodyId> owned_ids() const;
  std::size_t owned_count() const;
  std::size_t ghost_count() const;
  /// The scene's statics, and those held in the Bullet world here.
  std::size_t static_count() const;
  std::size_t held_static_count() const;
  /// Collision objects in the Bullet world (owned + ghosts + held statics).
  std::size_t bullet_object_count() const;
  /// (id0, id1) of every live manifold with points, ascending: after a step,
  /// the pairs this world held.
  std::vector<std::pair<BodyId, BodyId>> held_contact_pairs() const;
  /// Every manifold with points held here plus the kept store, by (id0, id1).
  std::vector<ManifoldState> kept_contact_state() const;
  /// The key body of pair (id0, id1) (rule H, territory_collide.cpp): the
  /// dynamic body of a static-dynamic pair, else id0. Its owner keeps the
  /// pair's contact state (invariant 4), so exactly one world owns it.
  BodyId key_body(BodyId id0, BodyId id1) const { return key_of(id0, id1); }
  /// Sleeping owned bodies.
  std::size_t sleeping_count() const;
  /// Joints held here (of the groups owned here), and how many broke.
  std::size_t joint_count() const { return joints_.size(); }
  std::size_t broken_joint_count() const;
  /// This world's part of the scene's state at a step boundary (after
  /// absorb_migrants): its owned bodies (description + raw state, by id) and
  /// kept_contact_state(); settings as built, steps_done in scene steps.
  /// Statics are not included (static_snapshots()). The parts of every
  /// world, merged (PartitionedWorld::snapshot), are the whole scene's state.
  WorldSnapshot part_snapshot() const;
  /// The same into `out`, reusing its storage.
  void part_snapshot(WorldSnapshot& out) const;
  /// In the middle of a step, after its islands were solved and before
  /// integrate(): the islands solved in place so far, the owned bodies (as
  /// part_snapshot) and the manifolds with points this world holds, as
  /// solved — what StepReplay::mid_step replays. False (nothing written) if
  /// the step replays islands from an old run's end-of-step states, which
  /// integrate() has not written yet.
  bool solved_state(LocalIslands& islands, WorldSnapshot& out) const;
  std::vector<BodySnapshot> static_snapshots() const;  // every static (raw state), by id

  // --- watchdog and input --------------------------------------------------

  /// The watchdog's check (watchdog.h) of the owned bodies' state and the
  /// contacts held here; empty when all is well. Valid after integrate() (the
  /// runtime calls it before migrate()).
  std::vector<WatchdogFinding> watchdog_findings(const WatchdogLimits& limits) const;
  /// Sets an owned body's velocities and wakes it (active, sleep timer 0), as
  /// input or a test's fault does. False if the body is not owned here.
  bool set_velocity(BodyId id, const Vec3& linear, const Vec3& angular);
  /// Input at a step boundary: gives an owned body an impulse at its centre
  /// and wakes it. False if the body is not owned here.
  bool apply_impulse(BodyId id, const Vec3& impulse);
  /// Input at a step boundary, in every world: the scene's gravity from the
  /// next step on (every body here, parked ones too, and snapshots).
  void set_gravity(const Vec3& gravity);
  /// Input at a step boundary: an owned body's mass (its inertia from its
  /// shape), friction, restitution or user data, in its description (what
  /// ghosts, migrants and snapshots carry) and in Bullet. Does not wake it.
  /// False if the body is not owned here. The caller checks the value.
  bool set_mass(BodyId id, double mass);
  bool set_friction(BodyId id, double friction);
  bool set_restitution(BodyId id, double restitution);
  bool set_user_data(BodyId id, std::uint64_t user_data);
  /// Input at a step boundary, in every world: a dynamic body's collision
  /// filter. Its copy here (owned or ghost) re-enters the broadphase with it:
  /// its pairs and contacts end, kept ones too. False if no copy is here.
  bool set_collision_filter(BodyId id, std::uint32_t group, std::uint32_t mask);
  /// Input after scene step `command.step`, in every world: a kinematic
  /// body's command (docs/scene-format.md, "Kinematic bodies"), pose or
  /// collision filter, kept in its description, one per step (the later
  /// replaces). False if not kinematic.
  bool command_kinematic(BodyId id, const KinematicCommand& command);
  bool filter_kinematic(BodyId id, const FilterCommand& command);
  /// Input at a step boundary, set_pose of a dynamic body: its owner puts it
  /// at `pose` (transform and interpolation transform, inertia tensor),
  /// keeps its velocities and wakes it; the next steps ghost and migrate it
  /// from there (within the run's reach). False if not owned here.
  bool set_pose(BodyId id, const Pose& pose);
  /// Input at a step boundary: adds a dynamic body (as the scene constructor would) if the map gives
  /// its home cell (at `home`: a spawned group's anchor's; else its position) to this world; true if
  /// it did. Throws PartitionError if the id is present here.
  bool add_body(const Body& body, const Vec3* home = nullptr);
  /// Input at a step boundary, waking the dynamic bodies (territory_joints.cpp); false if not here: removes an
  /// owned body with its joints and contact state, or a held joint (its group regroups); sets a held joint's
  /// motor (constraint made anew); holds an added joint whose dynamic ends are owned (one only: PartitionError).
  bool remove_body(BodyId id);
  bool remove_joint(JointId id);
  bool add_joint(const Joint& joint);
  bool set_joint_motor(JointId id, const JointMotor& motor);

  struct Entry;  // internal types: worlds/src/territory_world_parts.h
  struct Parts;
  struct Component;
  struct BorderLink;
  struct Statics;
  class Dispatcher;
  struct ParkingLink;
  struct HeldJoint;

 private:
  using PairKey = std::pair<BodyId, BodyId>;

  void init_world(const TerritoryWorld* share_pools_of = nullptr);
  void init_interior();
  void insert_static(const Body& body);
  /// An island of this step (solve_local) touches a kinematic body moved by
  /// commands: never replayed (an old run may have had other commands).
  bool touches_commanded_kinematic(int island) const;
  Entry& insert_dynamic(const Body& description, const BodyDynamicState* state, bool owned, WorldId owner);
  void remove_entry(BodyId id);
  void sort_lists();
  WorldId owner_of_origin(const Entry& e) const;
  /// Owner of the home cell of a body whose origin Bullet holds as `origin`.
  WorldId owner_of_origin(const btVector3& origin) const;
  bool has(WorldId world, const Entry& e) const;
  WorldId holder_of(const Entry& a, const Entry& b, const void* pair) const;
  BodyId key_of(BodyId id0, BodyId id1) const;
  bool owns(BodyId id) const;
  // Joints (territory_joints.cpp).
  /// The anchor of a body's joint group (itself when it has no joint).
  BodyId anchor_of(BodyId id) const;
  /// The owner of an owned body's home cell: its anchor's (invariant 6).
  WorldId home_owner(const Entry& e) const;
  /// At construction: the owned dynamic bodies by their group's home cell,
  /// then the joints of the groups owned here.
  void insert_owned_and_joints(const std::vector<const Body*>& bodies,
                               const std::vector<const BodyDynamicState*>& states,
                               const std::vector<JointSnapshot>& joints);
  void hold_joint(const Joint& joint, bool broken);
  void drop_joints(BodyId member, JointId joint, bool all_of_member);  // remove_body (all), remove_joint
  /// Removes the joints of the leaving bodies from the Bullet world, into
  /// their destination's batch (before the bodies go).
  void export_joints(const std::map<BodyId, WorldId>& destination, std::map<WorldId, MigrantBatch>& out);
  void absorb_joints(const std::vector<std::pair<WorldId, MigrantBatch>>& batches);
  /// A joint that broke in a border island solved elsewhere.
  void break_joint(JointId id);
  void near_callback(void* pair);
  void seed_pair(void* pair, const ManifoldState& state);
  BodyRecord record_of(const Entry& e) const;
  void update_aabbs();
  // predict (territory_predict.cpp).
  void find_ghost_targets(Entry& e, bool cull);
  void move_kinematic_bodies();
  void attach_kept_contacts();
  void solve_local(const std::vector<int>& components);
  void snapshot_into(WorldSnapshot& out, bool with_kept) const;
  void mark_clean();
  void export_manifolds_involving(const std::vector<const Entry*>& leaving,
                                  std::map<BodyId, MigrantBatch*>* payload_by_key);
  // Parking (territory_parking.cpp).
  bool inside_own_cells(const Entry& e) const;
  void park_lone_settled();
  void park_settled_islands();
  void wake_parked();
  void unpark_for_input(Entry& e);
  /// The owned entry of `id` for a property input, back from parking (or null).
  Entry* owned_for_input(BodyId id);
  void return_parked(btRigidBody* body);  // ParkingLink
  void forget_parked();                   // ParkingLink
  /// owned_ and parked_, by id.
  std::vector<const Entry*> all_owned_by_id() const;

  WorldId id_;
  TerritoryMap map_;
  SceneSettings settings_;
  std::unordered_map<BodyId, std::unique_ptr<Entry>> entries_;
  std::unique_ptr<Parts> parts_;  // after entries_: destroyed first, while its bodies are alive
  std::vector<Entry*> owned_;    // ascending id once sort_lists() ran
  std::vector<Entry*> ghosts_;   // ascending id once sort_lists() ran
  std::vector<Entry*> statics_;  // held; ascending id once sort_lists() ran
  // Owned bodies parked outside the Bullet world (not in owned_), any order;
  // each Entry holds its index here.
  std::vector<Entry*> parked_;
  bool parking_ = false;
  bool lists_sorted_ = true;
  std::vector<std::uint64_t> interior_;  // bit per box cell: owned here with all 26 neighbours
  std::int64_t steps_done_ = 0;
  TerritoryCounters counters_;
  // idle_ready()'s cache: -1 unknown (a step ran or a body changed), else
  // its last answer about the owned bodies.
  mutable int quiet_ = -1;
  // Built from a snapshot in which another world keeps contact state of a
  // pair with a body owned here, until the first step ends: the pair comes
  // back here through a seed (the owner's ghost), so none of this world's
  // bodies may be parked as lone settled bodies before it does.
  bool contacts_kept_elsewhere_ = false;
  // An owned body came in (built, restored, added, migrated) since the last
  // predict(): its halo, hence whether it is a border body, is unknown.
  bool halos_unknown_ = true;
  std::size_t coloured_before_ = 0;  // the solver's coloured islands at predict()

  // Contact state kept here for pairs held elsewhere (or whose live manifold
  // was destroyed with a leaving body), by (id0, id1).
  std::map<PairKey, ManifoldState> kept_;
  std::map<PairKey, ManifoldState> kept_next_;  // built by solve_border_island
  // Values to write into held pairs before narrowphase: kept_ + attachments.
  std::map<PairKey, ManifoldState> seeds_;
  // Per step: ghost targets of owned bodies by neighbour, attachments by key.
  std::map<WorldId, std::vector<const Entry*>> outgoing_;
  std::map<BodyId, std::vector<ManifoldState>> attachments_;
  std::vector<WorldId> ghost_senders_;
  // Per step: the contact graph (Parts::islands, Parts::held): its nodes
  // and the objects of each island, in island order.
  std::vector<Entry*> nodes_;                  // owned + ghosts, ascending id
  std::vector<btCollisionObject*> component_objects_;  // by island (Parts::islands.begin), then id
  std::vector<int> pending_of_;                // component -> index in components_ or -1
  std::vector<Component> components_;          // pending components only
  std::map<WorldId, GlueBatch> glue_out_;
  LocalIslands local_islands_;
  // The joints held here, by id, and the anchor of every jointed owned body
  // (invariant 6). After parts_: destroyed before the Bullet world (the
  // destructor takes them out of it first).
  std::map<JointId, std::unique_ptr<HeldJoint>> joints_;
  std::unordered_map<BodyId, BodyId> anchor_;
};

}  // namespace soda

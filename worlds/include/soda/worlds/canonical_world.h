// worlds/ — one territory's physics. This header: the canonical world, a
// Bullet world whose step is a pure function of its bodies' states and
// contact state (docs/determinism.md).
//
// Invariants (each one is tested in tests/worlds/):
//  1. the result of step() does not depend on the order bodies were inserted
//     in, nor on bodies that share no island with a body (far-away bodies);
//  2. islands and sleeping are decided from manifolds that hold contact points
//     (never from broadphase pairs), per island, as Bullet decides them;
//  3. a world rebuilt from snapshot() (bodies inserted in any order) steps
//     exactly as the world the snapshot was taken from;
//  4. a world owns all its Bullet objects (collision configuration,
//     dispatcher, broadphase, solver): distinct worlds may step concurrently
//     on distinct threads. One world is not thread-safe.
//
// Joints (Scene::joints) are island edges like manifolds with points; an
// island's joints are solved in joint id order (docs/determinism.md,
// "Joints"); snapshots carry them and whether each has broken.
//
// Kinematic bodies (Body::kinematic) move along their paths: before each
// internal step every one is written at its next pose with the velocity of
// the move (write_kinematic_state, bullet_bodies.h), and again after it.
//
// Outside the contract: continuous collision detection (CCD motion clamping
// sweeps against the whole world; bodies are created with CCD off),
// constraints added through bullet() rather than the scene, compound shapes
// (several manifolds per pair).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "soda/scene/scene.h"
#include "soda/worlds/body_state.h"
#include "soda/worlds/watchdog.h"
#include "soda/worlds/world_snapshot.h"

class btDiscreteDynamicsWorld;
class btRigidBody;
class btCollisionShape;

namespace soda {

class CanonicalDynamicsWorld;
class SolverPool;
struct CanonicalWorldParts;

/// What the last step's island stage saw (IslandStage in docs/determinism.md).
struct StepStats {
  std::size_t islands = 0;           // islands of dynamic bodies, lone bodies included
  std::size_t awake_islands = 0;     // solved this step
  std::size_t sleeping_islands = 0;  // skipped: every body asleep
  std::size_t lone_bodies = 0;       // awake islands of one body without contacts
  std::size_t contact_manifolds = 0; // manifolds with points, all islands
  std::size_t solved_manifolds = 0;  // manifolds handed to the solver
  std::size_t solved_joints = 0;     // joints handed to the solver (not broken, in awake islands)
  std::size_t broadphase_pairs = 0;  // after the full stale-pair sweep
  std::size_t speculative_contacts = 0;  // pairs given a speculative point (fast bodies; docs/ccd.md)
  std::size_t coloured_islands = 0;  // islands solved coloured (docs/coloured-solve.md)
  std::size_t substepped_islands = 0;  // islands solved in substeps (island_substeps.h; docs/stress.md)
  int solver_threads = 0;            // most threads a coloured island could use, so far
  int stage_threads = 0;             // most threads a per-body or per-pair stage of the last step could use
  int substep_threads = 0;           // most threads the work between an island's substeps could use, last step
                                     // (0: no island substepped)
  int island_threads = 0;            // most threads the last step's small islands could be solved on (side by side)
};

/// The solver settings a CanonicalWorld steps with.
enum class SolverDefaults {
  /// The canonical defaults (docs/stress.md "The solver defaults"): two friction directions per contact point fixed by the normal,
  /// settings per island from its contents (worlds/src/island_solver_settings.h),
  /// speculative contacts for fast bodies (docs/ccd.md). Every world kind
  /// of the runtime (territory worlds too) uses these.
  Soda,
  /// Bullet's own solver settings (`--solver-defaults bullet`), for measuring what the defaults cost (`soda
  /// bench defaults`): Bullet's solver defaults (one friction row along the
  /// slip velocity; warm starting 0.85 and split-impulse threshold -0.04 m
  /// for every island), the scene's iterations for every island, no
  /// speculative contacts. One CanonicalWorld only: no territory world
  /// steps this way, so a run with it is not comparable with K > 1.
  Bullet,
};

class CanonicalWorld {
 public:
  /// Builds the world from a scene; bodies are inserted in `insertion_order`
  /// (indices into scene.bodies; empty = scene order). The result of every
  /// step is the same for every order.
  explicit CanonicalWorld(const Scene& scene, const std::vector<std::size_t>& insertion_order = {});

  /// Rebuilds a world from a snapshot (indices into snapshot.bodies; empty =
  /// id order). Steps exactly as the world the snapshot was taken from.
  explicit CanonicalWorld(const WorldSnapshot& snapshot,
                          const std::vector<std::size_t>& insertion_order = {});

  ~CanonicalWorld();
  CanonicalWorld(const CanonicalWorld&) = delete;
  CanonicalWorld& operator=(const CanonicalWorld&) = delete;

  /// The pool that large islands share their colours on
  /// (docs/coloured-solve.md); null (the default): the stepping thread
  /// alone. Results never depend on it. Not during a step.
  void set_solver_pool(std::shared_ptr<SolverPool> pool);

  /// The solver settings of the next steps (default SolverDefaults::Soda).
  /// Call before the first step: the contact points already held keep the
  /// friction directions they were given. Not during a step.
  void set_solver_defaults(SolverDefaults defaults);
  SolverDefaults solver_defaults() const { return solver_defaults_; }

  /// One fixed step of settings.dt (substeps as configured). With parking
  /// on, settled sleeping islands leave Bullet's world at its end.
  void step();

  /// Parking of sleeping islands (docs/skip.md; worlds/src/parking.h):
  /// on, every island that is asleep and settled after a step leaves
  /// Bullet's world (broadphase, body lists, dispatcher) with its contact
  /// state and costs nothing per step but one AABB query; it comes back, in
  /// the step, as soon as an active body's AABB touches one of its bodies'.
  /// Exact: every step's state (hash, snapshot, contact state) is the same
  /// on and off (tests/runtime/parking_test.cpp). Off (the default for this
  /// class; `soda run` and `soda bench` turn it on, --no-parking off) puts
  /// every parked island back. Call between steps. While parked, an
  /// island's manifolds are not in bullet()'s dispatcher (contact_state()
  /// and snapshot() include them) and the watchdog does not scan them again
  /// (they were scanned while in the world and have not changed).
  void set_parking(bool on);
  bool parking() const { return parking_; }
  /// Dynamic bodies parked now.
  std::size_t parked_count() const;
  std::int64_t steps_done() const { return steps_done_; }
  const StepStats& last_step_stats() const;

  /// Raw states of every body (statics included), sorted by id.
  std::vector<BodyState> body_states() const;
  /// soda::state_hash of body_states(); with include_contacts, the contact
  /// state (contact_hash of contact_state()) is mixed in.
  std::uint64_t state_hash(bool include_contacts = false) const;
  std::size_t body_count() const;
  std::size_t sleeping_count() const;
  std::size_t joint_count() const { return joints_.size(); }
  /// Joints that broke (their breaking impulse reached): they hold no more.
  std::size_t broken_joint_count() const;

  /// The full state as values. Cost: O(bodies + manifolds).
  WorldSnapshot snapshot() const;
  /// Every manifold that holds points, sorted by (id0, id1).
  std::vector<ManifoldState> contact_state() const;
  /// The watchdog's check (watchdog.h) of every dynamic body and every
  /// manifold after the last step; empty when all is well.
  std::vector<WatchdogFinding> watchdog_findings(const WatchdogLimits& limits) const;
  /// One body as a value (for migration and ghosts). Throws std::out_of_range.
  BodySnapshot export_body(BodyId id) const;

  /// Bullet's world, for inspection and for the stock-vs-canonical bench.
  /// Adding or removing objects through it breaks the invariants.
  btDiscreteDynamicsWorld& bullet();

 private:
  struct Entry;
  struct JointEntry;
  void build(const SceneSettings& settings);
  /// The joints' constraints, in joint id order; `broken` (null: none) per
  /// joint of `joints`. Throws std::invalid_argument for a joint whose body
  /// is not in the world.
  void insert_joints(const std::vector<Joint>& joints, const std::vector<bool>* broken);
  void insert_body(const Body& description, const BodyDynamicState* state);
  void import_manifolds(const std::vector<ManifoldState>& manifolds);

  SceneSettings settings_;
  std::vector<std::unique_ptr<Entry>> entries_;  // sorted by id after construction
  std::vector<const Entry*> kinematic_;          // the kinematic bodies' entries, any order
  std::vector<std::unique_ptr<JointEntry>> joints_;  // sorted by joint id
  // After entries_: destroyed first, while the bodies it holds are alive.
  std::unique_ptr<CanonicalWorldParts> parts_;
  std::int64_t steps_done_ = 0;
  bool parking_ = false;
  SolverDefaults solver_defaults_ = SolverDefaults::Soda;
};

}  // namespace soda

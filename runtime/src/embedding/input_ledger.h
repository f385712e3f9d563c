// Internal: what the runtime knows of each body's life while user inputs
// arrive (runtime/user_input.h): when it was added, when removed, the
// newest input naming it. It checks an input against that (an unknown or
// static body, an id in use, a body not in the scene at the input's step,
// an input after a removal, a bad added body; a joint that is not there at
// the input's step, an added joint that is bad or joins two joint groups, a
// removal that splits a group an added joint closes a loop in, a motor that
// does not fit its joint) before the input is queued. It knows the joint
// groups at every step from the scene and the inputs alone, so what it takes
// does not depend on the worlds.
// Used by a Simulation's engine (inputs as the API calls come) and by a
// PartitionedWorld (PartitionedOptions::inputs, all before the run).
// Not thread-safe: its owner serialises the calls.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "soda/runtime/user_input.h"
#include "soda/scene/scene.h"

namespace soda {

class InputLedger {
 public:
  /// The bodies of `scene` are present from the start.
  explicit InputLedger(const Scene& scene);
  /// Throws std::invalid_argument naming the input (describe()) and what is
  /// wrong; the ledger is unchanged.
  void check(const UserInput& input) const;
  /// Takes a checked input into account.
  void record(const UserInput& input);
  /// Marks `id` as used by a body removed before a snapshot this run was
  /// restored from: never used again, named by no input.
  void retire(BodyId id);
  /// Ids of every body removed at a boundary before `step` (retired ones
  /// included), ascending: what a snapshot at `step` must keep from reuse.
  std::vector<BodyId> removed_before(std::int64_t step) const;
  /// The same for joints: `id` was removed before the snapshot (a joint's
  /// id is never used again), and the ids removed before `step`.
  void retire_joint(JointId id);
  std::vector<JointId> joints_removed_before(std::int64_t step) const;

 private:
  // An input's place in the order the worlds apply them: its step, then the
  // order the ledger recorded it (the sequence of the calls).
  struct Place {
    std::int64_t step = 0;
    std::uint64_t order = 0;
    bool operator<(const Place& o) const { return step != o.step ? step < o.step : order < o.order; }
  };
  struct Life {
    bool is_static = false;
    bool kinematic = false;
    std::int64_t added = 0;                // present from this boundary on
    std::int64_t removed = INT64_MAX;      // gone from this boundary on
    std::uint64_t removed_order = 0;       // ... applied in this place among that boundary's inputs
    std::int64_t last_input = -1;          // newest step of an input naming it
    bool retired = false;                  // removed before the snapshot this run was restored from
    bool by_input = false;                 // added by an input (at `added`)
  };
  struct JointLife {
    BodyId body_a = 0, body_b = 0;
    JointKind kind = JointKind::PointToPoint;
    Place added{-1, 0};                  // the scene's (or the snapshot's): before every input
    Place removed{INT64_MAX, 0};         // removed by input
    bool closes_loop = false;            // added by input between two dynamic bodies (of one group)
    std::int64_t last_motor = -1;        // newest step of a motor input naming it
    bool retired = false;                // removed before the snapshot this run was restored from
  };
  // A removal the joint groups are tested without: a joint's or a body's.
  struct Without {
    const JointId* joint = nullptr;
    const BodyId* body = nullptr;
  };
  void check_joint(const UserInput& input, const std::string& what) const;
  void check_added_joint(const UserInput& input, const std::string& what) const;
  void check_loops_kept(const UserInput& removal, const std::string& what) const;
  bool dynamic(BodyId id) const;
  bool newborn(BodyId id, std::int64_t step) const;  // added by an input at `step`
  /// Each body of a joint group just before `at` (the joints there then,
  /// broken or not, less `without`'s) with its group's anchor (smallest id).
  std::map<BodyId, BodyId> groups(Place at, Without without) const;
  /// The anchor of `id`'s group in `groups`, kNoGroup for a body in none.
  static constexpr BodyId kNoGroup = ~BodyId{0};
  static BodyId anchor_in(const std::map<BodyId, BodyId>& groups, BodyId id);
  std::map<BodyId, Life> lives_;
  std::map<JointId, JointLife> joints_;
  std::uint64_t order_ = 0;  // inputs recorded so far
  SceneSettings settings_;
};

}  // namespace soda

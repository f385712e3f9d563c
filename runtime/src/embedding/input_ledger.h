// Internal: what the runtime knows of each body's life while user inputs
// arrive (runtime/user_input.h): when it was added, when removed, the
// newest input naming it. It checks an input against that (an unknown or
// static body, an id in use, a body not in the scene at the input's step,
// an input after a removal, a bad added body; a joint that is not there at
// the input's step) before the input is queued.
// Used by a Simulation's engine (inputs as the API calls come) and by a
// PartitionedWorld (PartitionedOptions::inputs, all before the run).
// Not thread-safe: its owner serialises the calls.
#pragma once

#include <cstdint>
#include <map>
#include <string>
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

 private:
  struct Life {
    bool is_static = false;
    bool kinematic = false;
    std::int64_t added = 0;                // present from this boundary on
    std::int64_t removed = INT64_MAX;      // gone from this boundary on
    std::int64_t last_input = -1;          // newest step of an input naming it
    bool retired = false;                  // removed before the snapshot this run was restored from
  };
  struct JointLife {
    BodyId body_a = 0, body_b = 0;
    std::int64_t removed = INT64_MAX;  // removed by input at this boundary
  };
  void check_joint(const UserInput& input, const std::string& what) const;
  std::map<BodyId, Life> lives_;
  std::map<JointId, JointLife> joints_;
  SceneSettings settings_;
};

}  // namespace soda

// Internal: what the runtime knows of each body's life while user inputs
// arrive (runtime/user_input.h): when it was added, when removed, the
// newest input naming it. It checks an input against that (an unknown or
// static body, an id in use, a body not in the scene at the input's step,
// an input after a removal, a bad added body) before the input is queued.
// Used by a Simulation's engine (inputs as the API calls come) and by a
// PartitionedWorld (PartitionedOptions::inputs, all before the run).
// Not thread-safe: its owner serialises the calls.
#pragma once

#include <cstdint>
#include <map>

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

 private:
  struct Life {
    bool is_static = false;
    std::int64_t added = 0;                // present from this boundary on
    std::int64_t removed = INT64_MAX;      // gone from this boundary on
    std::int64_t last_input = -1;          // newest step of an input naming it
  };
  std::map<BodyId, Life> lives_;
  SceneSettings settings_;
};

}  // namespace soda

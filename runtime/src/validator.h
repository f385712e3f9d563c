// Internal: the validation mode. After each step every world reports what it
// holds; when the last report of a step arrives, the reports are checked
// together (no barrier: the reporting world that completes a step checks it):
//  1. per world, Bullet objects = owned + ghosts + statics, statics = the
//     scene's;
//  2. every dynamic body has exactly one owner;
//  3. every pair's live contact state has exactly one holder.
// A failure throws ValidationError naming the step, ids and worlds.
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <utility>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/scene/scene.h"

namespace soda {

struct WorldStepReport {
  WorldId world = 0;
  std::int64_t step = 0;                // internal steps done
  std::vector<BodyId> owned;            // ascending
  std::size_t ghosts = 0;
  std::size_t statics = 0;
  std::size_t bullet_objects = 0;
  std::vector<std::pair<BodyId, BodyId>> held_pairs;  // ascending
};

class Validator {
 public:
  Validator(const Scene& scene, int world_count);
  /// Thread-safe. Throws ValidationError when the step it completes is wrong.
  void report(WorldStepReport report);
  std::int64_t steps_checked() const;

 private:
  void check(std::int64_t step, const std::vector<WorldStepReport>& reports) const;

  int world_count_;
  std::vector<BodyId> dynamic_ids_;  // ascending
  std::size_t static_count_ = 0;
  mutable std::mutex mutex_;
  std::map<std::int64_t, std::vector<WorldStepReport>> pending_;
  std::int64_t checked_ = 0;
};

}  // namespace soda

// Internal: the validation mode. After each step every world reports what it
// holds; when the last report of a step arrives, the reports are checked
// together (no barrier: the reporting world that completes a step checks it):
//  1. per world, Bullet objects = owned + ghosts + statics, statics = the
//     scene's;
//  2. every dynamic body in the scene at that step has exactly one owner,
//     and nothing else is owned: the expected bodies are the scene's
//     dynamic ones, plus those added and minus those removed by the user
//     inputs the validator was told of (expect()) — a body an input added
//     is expected after its step, one it removed is not, and a body lost
//     or owned twice is a failure;
//  3. every pair's live contact state has exactly one holder.
// A failure throws ValidationError naming the step, ids and worlds.
//
// Over MPI ranks (`gathered`), a rank's validator holds its own worlds'
// reports (report() never checks), the run takes them (take_pending()),
// gathers every rank's, and each rank checks the same union
// (check_gathered()): every rank checks, and fails, alike.
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <utility>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/runtime/user_input.h"
#include "soda/scene/scene.h"

namespace soda {

struct WorldStepReport {
  WorldId world = 0;
  std::int64_t step = 0;                // internal steps done
  std::vector<BodyId> owned;            // ascending
  std::size_t ghosts = 0;
  std::size_t statics = 0;               // held in the Bullet world (at most the scene's)
  std::size_t bullet_objects = 0;
  std::vector<std::pair<BodyId, BodyId>> held_pairs;  // ascending
  std::size_t parked = 0;               // owned bodies parked outside the Bullet world
};

class Validator {
 public:
  /// `gathered`: the reports come together over ranks (above).
  Validator(const Scene& scene, int world_count, bool gathered = false);
  /// Dynamic bodies of the scene the constructor's did not have (over ranks
  /// it is built from the rank's share). Thread-safe.
  void expect_bodies(const std::vector<BodyId>& ids);
  /// An input that will be applied at scene step boundary input.step
  /// (`substeps` internal steps per scene step): AddBody makes its body
  /// expected in the reports of later steps, RemoveBody unexpected; other
  /// kinds change nothing. Before any world reports a step after that
  /// boundary. Thread-safe.
  void expect(const UserInput& input, int substeps);
  /// Thread-safe. Throws ValidationError when the step it completes is wrong.
  void report(WorldStepReport report);
  std::int64_t steps_checked() const;
  /// The reports not checked yet, taken out (gathered mode). Thread-safe.
  std::vector<WorldStepReport> take_pending();
  /// Every rank's taken reports: checks each step all worlds have reported,
  /// in order, and keeps the rest for the next call. Throws as report().
  void check_gathered(std::vector<WorldStepReport> reports);

 private:
  void check(std::int64_t step, const std::vector<WorldStepReport>& reports) const;
  // A dynamic body is expected in the report of internal step r (steps
  // done) iff added < r <= removed (internal step boundaries).
  struct Life {
    std::int64_t added = -1;
    std::int64_t removed = INT64_MAX;
  };
  bool expected(const Life& life, std::int64_t step) const { return life.added < step && step <= life.removed; }

  int world_count_;
  bool gathered_;
  std::map<std::int64_t, std::vector<WorldStepReport>> incomplete_;  // gathered mode: steps some world owes
  mutable std::mutex lives_mutex_;
  std::map<BodyId, Life> lives_;  // every dynamic body of the scene or of an input
  std::size_t static_count_ = 0;
  mutable std::mutex mutex_;
  std::map<std::int64_t, std::vector<WorldStepReport>> pending_;
  std::int64_t checked_ = 0;
};

}  // namespace soda

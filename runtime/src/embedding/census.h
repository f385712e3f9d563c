// Internal: which dynamic bodies the frame of each scene step holds while
// inputs add and remove bodies — what a SceneReader checks every frame
// against (every body alive at that step, exactly once).
//
// An input at boundary s applies after the entry of step s is published and
// before step s + 1 begins (world_process.cpp, predict), so:
//  1. a body of the scene is in every frame from step 0 until it is removed;
//  2. a body added at boundary s is in frames s + 1 onwards;
//  3. a body removed at boundary s is in frames up to s, and in none after.
// The engine records an input here before any world can see it (before it
// is queued), so no frame can hold a body the census does not know yet.
// Inputs are never taken back, so the census only grows. It also keeps
// what each body is (its description), for the queries.
//
// Thread safety: every member, any thread (one mutex; readers check frames
// while the API thread records inputs).
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <vector>

#include "soda/scene/input_file.h"
#include "soda/scene/scene.h"
#include "soda/worlds/body_state.h"

namespace soda {

class Census {
 public:
  /// The scene's dynamic bodies are in every frame from step 0.
  explicit Census(const Scene& scene);
  /// Takes an accepted input into account: AddBody and RemoveBody change
  /// presence, SetMass, SetFriction, SetRestitution and SetUserData a body's
  /// properties, SetPose and SetKinematicTarget a kinematic body's commands
  /// and SetCollisionFilter its filter commands (as every world records
  /// them); other kinds are ignored.
  void record(const UserInput& input);
  /// Number of dynamic bodies in the frame of `step`.
  std::size_t count_at(std::int64_t step) const;
  /// Throws std::logic_error naming the step and a body, unless `ids`
  /// (ascending, no duplicates) are exactly the bodies of the frame of
  /// `step`.
  void check(std::int64_t step, const std::vector<BodyId>& ids) const;
  /// What each body is: its description as the scene or the input that
  /// added it gave it (shape, mass, ...; not its state). Null for an
  /// unknown id. The pointer stays valid for the census' life.
  const Body* description(BodyId id) const;
  /// The scene's static bodies, kinematic ones included, ascending id, as
  /// the scene gave them (without the commands inputs gave kinematic ones).
  const std::vector<Body>& statics() const { return statics_; }
  /// Every kinematic body's state at the end of scene step `step`, bit for
  /// bit what every world writes (kinematic_state: its path, then the
  /// commands of inputs at boundaries before `step`), ascending id.
  std::vector<BodyState> kinematic_states(std::int64_t step) const;
  /// Body `id` as the frame of `step` holds it: its description with the
  /// mass, friction, restitution, user data and collision filter that
  /// inputs at boundaries before `step` gave it, in (step, sequence) order
  /// (a kinematic body: the filter). Null (false) for an
  /// unknown id. Presence at `step` is not checked.
  bool properties(BodyId id, std::int64_t step, Body& out) const;

 private:
  struct Span {
    std::int64_t first = 0;          // first frame holding the body
    std::int64_t end = INT64_MAX;    // first frame without it
    bool holds(std::int64_t step) const { return first <= step && step < end; }
  };
  bool holds_locked(BodyId id, std::int64_t step) const;
  std::size_t count_at_locked(std::int64_t step) const;

  mutable std::mutex mutex_;
  std::vector<BodyId> scene_;            // the scene's dynamic bodies, ascending
  std::map<BodyId, Span> changed_;       // bodies an input added or removed
  std::vector<Body> statics_;
  SceneSettings settings_;
  std::map<BodyId, Body> kinematic_;     // kinematic bodies with their commands
  std::map<BodyId, Body> dynamics_;      // every dynamic body ever, by id (node-stable)
  // Property inputs (set_mass, ..., set_user_data) by body, each list in
  // (step, sequence) order.
  std::map<BodyId, std::vector<UserInput>> property_changes_;
};

}  // namespace soda

// runtime/ — the public embedding API. This header: queries of the whole
// scene at a simulated time τ — ray casts, shape sweeps, overlaps — answered
// from the committed frame of τ's step. Include soda/runtime/simulation.h,
// which brings it.
//
// A SceneQuery reads the frame of τ's step as a SceneReader does (it waits
// until every world has published it and it is final: no rollback can
// change it), places every body of that frame and every static body in a
// collision world of its own (kinematic bodies where the frame has them:
// SceneFrame::kinematic), and asks Bullet. Each body's answer is a
// function of its shape and pose alone, and the answers are sorted (by
// fraction, then body id; overlaps by id), so a query at a step gives the
// same ids and bits for any number of territories, any schedule and any
// speculation, and never an answer from a step that may still be rolled
// back. docs/embedding.md, "Queries".
//
//   soda::SceneQuery query = sim.add_query();            // any thread
//   std::thread picking([&] {                            // a thread of its own
//     auto hit = query.ray_cast(t, camera, camera + 100.0 * dir);  // closest hit
//     if (hit && !hit->hits.empty()) select(hit->hits[0].id);
//   });
//
// Thread safety: one thread at a time per SceneQuery; queries and readers on
// other threads and the Simulation's calls run concurrently. Queries go
// forward in time, as reads do (a query at an earlier, freed step returns
// nullopt).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "soda/runtime/scene_reader.h"
#include "soda/scene/scene.h"

namespace soda {

/// What a query considers.
struct QueryFilter {
  bool statics = true;          // static bodies, kinematic ones included
  bool dynamics = true;         // dynamic bodies
  std::vector<BodyId> ignore;   // never these bodies (e.g. the caster itself)
  /// Only bodies whose Body::collision_group shares a bit with this mask
  /// (every body by default).
  std::uint32_t mask = kAllCollisionGroups;
  /// Sensors (Body::sensor) too: off by default, as a trigger volume should
  /// not stop a pick or a line of sight.
  bool sensors = false;
};

/// One body a ray or a sweep hits.
struct QueryHit {
  BodyId id = 0;
  /// Along the ray or sweep, 0 at its start, 1 at its end.
  double fraction = 0;
  Vec3 point = Vec3::Zero();   // world frame, m: on the body's surface
  Vec3 normal = Vec3::Zero();  // world frame, unit: the body's surface normal there
};

/// A query's answer and the scene step it was answered at.
template <class T>
struct QueryResult {
  std::int64_t step = 0;
  std::vector<T> items;  // hits by (fraction, id); overlaps by id
};

struct SimulationCore;  // internal, shared by a Simulation and its readers

/// Queries at a time; made by Simulation::add_query(). Holds a SceneReader
/// (its cursors pin frames as a reader's do: destroy a query you no longer
/// use) and a collision world of its own, updated to each step queried.
class SceneQuery {
 public:
  SceneQuery(SceneQuery&&) noexcept;
  SceneQuery& operator=(SceneQuery&&) noexcept;
  SceneQuery(const SceneQuery&) = delete;
  SceneQuery& operator=(const SceneQuery&) = delete;
  ~SceneQuery();

  /// Every body the segment from `from` to `to` (world frame, m) enters, by
  /// (fraction, id). Waits for τ's step as SceneReader::read_at does;
  /// nullopt when read_at would return nullopt (the step freed, or the
  /// Simulation stopped first). Throws as read_at, and std::invalid_argument
  /// for non-finite points.
  std::optional<QueryResult<QueryHit>> ray_cast_all(double time, const Vec3& from, const Vec3& to,
                                                    const QueryFilter& filter = {});
  /// The first body the segment enters (items: at most one; ties in
  /// fraction go to the smaller id).
  std::optional<QueryResult<QueryHit>> ray_cast(double time, const Vec3& from, const Vec3& to,
                                                const QueryFilter& filter = {});
  /// Every body a convex `shape` (box, sphere, capsule, cylinder, convex
  /// hull), turned by `orientation`, touches as it moves from `from` to `to`
  /// without turning, by (fraction, id): QueryHit::point and normal where it
  /// first touches each.
  std::optional<QueryResult<QueryHit>> sweep(double time, const Shape& shape, const Vec3& from, const Vec3& to,
                                             const Quat& orientation = Quat::Identity(),
                                             const QueryFilter& filter = {});
  /// Every body `shape`, placed at `position` turned by `orientation`,
  /// overlaps (touching or penetrating), by id.
  std::optional<QueryResult<BodyId>> overlap(double time, const Shape& shape, const Vec3& position,
                                             const Quat& orientation = Quat::Identity(),
                                             const QueryFilter& filter = {});
  /// Every body whose shape's AABB overlaps the box [lo, hi] (world frame,
  /// closed), by id.
  std::optional<QueryResult<BodyId>> overlap_aabb(double time, const Vec3& lo, const Vec3& hi,
                                                  const QueryFilter& filter = {});

  /// The step of the last answer; -1 before the first.
  std::int64_t last_step() const;

 private:
  friend class Simulation;
  friend class SensorReader;
  struct World;  // the collision world (scene_query.cpp)
  explicit SceneQuery(std::shared_ptr<SimulationCore> core, SceneReader reader);
  /// The collision world at τ's step; null when read_at (try_read_at if not
  /// `wait`) would give nullopt.
  World* at(double time, bool wait = true);
  /// Every (sensor, body) pair overlapping at `step`, ascending
  /// (sensor_reader.h says which pairs); nullopt as at().
  std::optional<std::vector<std::pair<BodyId, BodyId>>> sensor_overlaps(std::int64_t step, bool wait);

  std::shared_ptr<SimulationCore> core_;
  SceneReader reader_;
  std::unique_ptr<World> world_;
};

}  // namespace soda

// Reach (reach.h).
#include "soda/worlds/reach.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <queue>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/worlds/bullet_bodies.h"

namespace soda {
namespace {

double step_length(const Scene& scene) { return scene.settings.dt / std::max(1, scene.settings.substeps); }

// Largest distance from a dynamic body's origin to a point of its Bullet
// AABB at any orientation: its bounding radius, plus the collision margin
// for a hull (Bullet adds it around the points; spheres, capsules, boxes and
// cylinders hold it inside their dimensions).
// A compound's: its farthest child's, from the body's origin.
double reach_radius(const Shape& shape) {
  if (shape.kind == ShapeKind::Compound) {
    double r = 0;
    for (const CompoundChild& c : shape.children) r = std::max(r, c.position.norm() + reach_radius(c.shape));
    return r;
  }
  const double margin =
      shape.kind == ShapeKind::ConvexHull ? double(make_collision_shape(shape)->getMargin()) : 0.0;
  return shape.bounding_radius() + margin;
}

// A joint group (the dynamic bodies joints connect) has one owner and
// moves with its anchor, its smallest body id (territory_world.h, invariant
// 6): a member's halo is reached from the anchor's home cell, so the group
// counts as one body whose radius is the largest, over its members, of the
// distance from the anchor's origin along the joints plus the member's own
// radius. A joint adds the sum of its two frame offsets (where its pivots
// meet) or its bodies' distance in the scene, whichever is larger (a slider
// or a 6-DoF joint may hold them apart). Shortest paths (Dijkstra).
double largest_group_radius(const Scene& scene) {
  if (scene.joints.empty()) return 0;
  std::unordered_map<BodyId, const Body*> body;
  for (const Body& b : scene.bodies) body.emplace(b.id, &b);
  std::unordered_map<BodyId, std::vector<std::pair<BodyId, double>>> edges;
  for (const Joint& j : scene.joints) {
    auto a = body.find(j.body_a), b = body.find(j.body_b);
    if (a == body.end() || b == body.end() || a->second->is_static || b->second->is_static) continue;
    const double length = std::max(j.frame_a.position.norm() + j.frame_b.position.norm(),
                                   (a->second->position - b->second->position).norm());
    edges[j.body_a].emplace_back(j.body_b, length);
    edges[j.body_b].emplace_back(j.body_a, length);
  }
  std::vector<BodyId> ids;
  for (const auto& [id, e] : edges) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  std::unordered_map<BodyId, double> distance;
  double r = 0;
  for (BodyId anchor : ids) {  // ascending: an anchor is met before the rest of its group
    if (distance.count(anchor)) continue;
    std::priority_queue<std::pair<double, BodyId>, std::vector<std::pair<double, BodyId>>, std::greater<>> queue;
    distance[anchor] = 0;
    queue.emplace(0.0, anchor);
    while (!queue.empty()) {
      const auto [d, id] = queue.top();
      queue.pop();
      if (d > distance[id]) continue;
      r = std::max(r, d + reach_radius(body.at(id)->shape));
      for (const auto& [next, length] : edges[id]) {
        auto it = distance.find(next);
        if (it == distance.end() || d + length < it->second) {
          distance[next] = d + length;
          queue.emplace(d + length, next);
        }
      }
    }
  }
  return r;
}

double largest_reach_radius(const Scene& scene) {
  double r = 0;
  for (const Body& b : scene.bodies)
    if (!b.is_static) r = std::max(r, reach_radius(b.shape));
  return std::max(r, largest_group_radius(scene));
}

// Everything a halo adds to the travel v·h, in metres.
double halo_slack(const Scene& scene) { return largest_reach_radius(scene) + double(gContactBreakingThreshold); }

}  // namespace

double scene_reach_speed(const Scene& scene) {
  double fastest = 0;
  for (const Body& b : scene.bodies)
    if (!b.is_static) fastest = std::max(fastest, b.linear_velocity.norm());
  const double g = scene.settings.gravity.norm();
  if (g == 0) return fastest;
  const Vec3 up = -scene.settings.gravity / g;
  double low = INFINITY, high = -INFINITY;
  for (const Body& b : scene.bodies) {
    const double h = b.position.dot(up);
    const double half = b.aabb_half_extents().cwiseProduct(up.cwiseAbs()).sum();  // AABB along `up`
    low = std::min(low, h - half);
    if (!b.is_static) high = std::max(high, h + b.shape.bounding_radius());
  }
  const double fall = high > low ? std::sqrt(2 * g * (high - low)) : 0.0;
  return fastest + fall;
}

int reach_cells(const Scene& scene, double cell_size, double speed) {
  if (!(speed >= 0) || !std::isfinite(speed))
    throw std::invalid_argument("reach speed " + std::to_string(speed) + " m/s: must be finite and >= 0");
  if (!(cell_size > 0)) throw std::invalid_argument("reach: cell size must be > 0");
  const double cells = std::floor((halo_slack(scene) + speed * step_length(scene)) / cell_size) + 1;
  return static_cast<int>(std::clamp(cells, 1.0, double(kMaxReachCells)));
}

double reach_speed_of(const Scene& scene, double cell_size, int cells) {
  // reach_cells(v) <= cells  <=>  slack + v h < cells * cell_size.
  const double v = (cells * cell_size - halo_slack(scene)) / step_length(scene);
  return std::max(0.0, v);
}

}  // namespace soda

#include "soda/scene/scene.h"

#include <algorithm>
#include <cmath>

namespace soda {

const char* shape_kind_name(ShapeKind kind) {
  switch (kind) {
    case ShapeKind::Box: return "box";
    case ShapeKind::Sphere: return "sphere";
    case ShapeKind::Capsule: return "capsule";
    case ShapeKind::Cylinder: return "cylinder";
    case ShapeKind::ConvexHull: return "convex_hull";
    case ShapeKind::Compound: return "compound";
    case ShapeKind::TriangleMesh: return "triangle_mesh";
    case ShapeKind::Heightfield: return "heightfield";
  }
  return "unknown";
}

const char* joint_kind_name(JointKind kind) {
  switch (kind) {
    case JointKind::PointToPoint: return "point-to-point";
    case JointKind::Hinge: return "hinge";
    case JointKind::Slider: return "slider";
    case JointKind::ConeTwist: return "cone-twist";
    case JointKind::Fixed: return "fixed";
    case JointKind::Spring6Dof: return "spring-6dof";
  }
  return "unknown";
}

Shape Shape::box(const Vec3& half_extents) {
  Shape s;
  s.kind = ShapeKind::Box;
  s.half_extents = half_extents;
  return s;
}

Shape Shape::sphere(double radius) {
  Shape s;
  s.kind = ShapeKind::Sphere;
  s.radius = radius;
  return s;
}

Shape Shape::capsule(double radius, double height) {
  Shape s;
  s.kind = ShapeKind::Capsule;
  s.radius = radius;
  s.height = height;
  return s;
}

Shape Shape::cylinder(const Vec3& half_extents) {
  Shape s;
  s.kind = ShapeKind::Cylinder;
  s.half_extents = half_extents;
  return s;
}

Shape Shape::convex_hull(std::vector<Vec3> points) {
  Shape s;
  s.kind = ShapeKind::ConvexHull;
  s.points = std::move(points);
  return s;
}

Shape Shape::compound(std::vector<CompoundChild> children) {
  Shape s;
  s.kind = ShapeKind::Compound;
  s.children = std::move(children);
  return s;
}

Shape Shape::triangle_mesh(std::shared_ptr<const TriangleMeshData> mesh) {
  Shape s;
  s.kind = ShapeKind::TriangleMesh;
  s.mesh = std::move(mesh);
  return s;
}

Shape Shape::heightfield_of(std::shared_ptr<const HeightfieldData> heightfield) {
  Shape s;
  s.kind = ShapeKind::Heightfield;
  s.heightfield = std::move(heightfield);
  return s;
}

double HeightfieldData::max_abs_height() const {
  if (window.columns != 0) return std::abs(window.max_abs * spacing.y());
  double m = 0.0;
  for (double h : heights) m = std::max(m, std::abs(h * spacing.y()));
  return m;
}

double HeightfieldData::max_abs_raw_height() const {
  if (window.columns != 0) return window.max_abs;
  double m = 0.0;
  for (double h : heights) m = std::max(m, std::abs(h));
  return m;
}

Vec3 Shape::local_half_extents() const {
  switch (kind) {
    case ShapeKind::Box:
    case ShapeKind::Cylinder:
      return half_extents;
    case ShapeKind::Sphere:
      return Vec3::Constant(radius);
    case ShapeKind::Capsule:
      return Vec3(radius, radius + 0.5 * height, radius);
    case ShapeKind::ConvexHull: {
      Vec3 h = Vec3::Zero();
      for (const Vec3& p : points) h = h.cwiseMax(p.cwiseAbs());
      return h;
    }
    case ShapeKind::Compound: {
      // Each child's box at its pose (|R| h bounds the rotated box), about
      // the body's origin.
      Vec3 h = Vec3::Zero();
      for (const CompoundChild& c : children) {
        const Eigen::Matrix3d abs_r = c.orientation.normalized().toRotationMatrix().cwiseAbs();
        h = h.cwiseMax(c.position.cwiseAbs() + abs_r * c.shape.local_half_extents());
      }
      return h;
    }
    case ShapeKind::TriangleMesh: {
      Vec3 h = Vec3::Zero();
      if (mesh && mesh->cut) return h.cwiseMax(mesh->cut->lo.cwiseAbs()).cwiseMax(mesh->cut->hi.cwiseAbs());
      if (mesh)
        for (const Vec3& p : mesh->vertices) h = h.cwiseMax(p.cwiseAbs());
      return h;
    }
    case ShapeKind::Heightfield:
      if (!heightfield) return Vec3::Zero();
      return Vec3(0.5 * (heightfield->columns - 1) * std::abs(heightfield->spacing.x()), heightfield->max_abs_height(),
                  0.5 * (heightfield->rows - 1) * std::abs(heightfield->spacing.z()));
  }
  return Vec3::Zero();
}

double Shape::bounding_radius() const {
  switch (kind) {
    case ShapeKind::Box:
      return half_extents.norm();
    case ShapeKind::Cylinder:
      return std::hypot(std::max(half_extents.x(), half_extents.z()), half_extents.y());
    case ShapeKind::Sphere:
      return radius;
    case ShapeKind::Capsule:
      return radius + 0.5 * height;
    case ShapeKind::ConvexHull: {
      double r = 0.0;
      for (const Vec3& p : points) r = std::max(r, p.norm());
      return r;
    }
    case ShapeKind::Compound: {
      double r = 0.0;
      for (const CompoundChild& c : children) r = std::max(r, c.position.norm() + c.shape.bounding_radius());
      return r;
    }
    case ShapeKind::TriangleMesh: {
      double r = 0.0;
      if (mesh && mesh->cut) return mesh->cut->radius;
      if (mesh)
        for (const Vec3& p : mesh->vertices) r = std::max(r, p.norm());
      return r;
    }
    case ShapeKind::Heightfield:
      return local_half_extents().norm();
  }
  return 0.0;
}

Vec3 Body::aabb_half_extents() const {
  // |R| * h bounds the rotated local box; exact for boxes.
  const Eigen::Matrix3d abs_r = orientation.normalized().toRotationMatrix().cwiseAbs();
  return abs_r * shape.local_half_extents();
}

std::size_t Scene::dynamic_count() const {
  return static_cast<std::size_t>(
      std::count_if(bodies.begin(), bodies.end(), [](const Body& b) { return !b.is_static; }));
}

std::size_t Scene::static_count() const { return bodies.size() - dynamic_count(); }

double Scene::largest_dynamic_extent() const {
  // Orientation-independent: the extent is the bounding sphere's diameter, so
  // that a body cannot outgrow its cell by rotating.
  double e = 0.0;
  for (const Body& b : bodies)
    if (!b.is_static) e = std::max(e, 2.0 * b.shape.bounding_radius());
  return e;
}

double internal_step_time(const SceneSettings& settings, std::int64_t internal_steps) {
  return static_cast<double>(internal_steps) * (settings.dt / static_cast<double>(settings.substeps));
}

// Plain double arithmetic, one operation at a time (the build has
// -ffp-contract=off): the same bits in every world and thread.
Pose interpolate_pose(const Pose& a, const Pose& b, double u) {
  const double w = 1.0 - u;
  Pose p;
  for (int k = 0; k < 3; ++k) p.position[k] = a.position[k] * w + b.position[k] * u;
  const Eigen::Vector4d qa = a.orientation.normalized().coeffs();
  Eigen::Vector4d qb = b.orientation.normalized().coeffs();
  double dot = 0.0;
  for (int k = 0; k < 4; ++k) dot += qa[k] * qb[k];
  if (dot < 0.0) qb = -qb;  // the shorter way round
  Eigen::Vector4d q;
  for (int k = 0; k < 4; ++k) q[k] = qa[k] * w + qb[k] * u;
  double n2 = 0.0;
  for (int k = 0; k < 4; ++k) n2 += q[k] * q[k];
  const double n = std::sqrt(n2);
  p.orientation = Quat(q[3] / n, q[0] / n, q[1] / n, q[2] / n);
  return p;
}

Pose kinematic_pose(const Body& body, double time) {
  const std::vector<PathKey>& keys = body.path.keys;
  if (keys.empty()) return Pose{body.position, body.orientation.normalized()};
  double t = time;
  const double period = keys.back().time;
  if (body.path.loop && period > 0.0) {
    t = std::fmod(time, period);  // exact
    if (t < 0.0) t += period;
  }
  if (!(t > keys.front().time)) return Pose{keys.front().position, keys.front().orientation.normalized()};
  if (!(t < keys.back().time)) return Pose{keys.back().position, keys.back().orientation.normalized()};
  // The first key later than t: keys[i - 1].time <= t < keys[i].time.
  const auto later = std::upper_bound(keys.begin(), keys.end(), t,
                                      [](double x, const PathKey& k) { return x < k.time; });
  const PathKey& a = *(later - 1);
  const PathKey& b = *later;
  const double u = (t - a.time) / (b.time - a.time);
  return interpolate_pose(Pose{a.position, a.orientation}, Pose{b.position, b.orientation}, u);
}

KinematicPlace kinematic_place(const Body& body, const SceneSettings& settings, std::int64_t n) {
  const std::int64_t s = settings.substeps;
  const std::vector<KinematicCommand>& cs = body.commands;
  // The last command in effect at n: the last with step * s < n.
  const auto after = std::partition_point(cs.begin(), cs.end(),
                                          [&](const KinematicCommand& c) { return c.step * s < n; });
  if (after == cs.begin()) return KinematicPlace{kinematic_pose(body, internal_step_time(settings, n)), false};
  const KinematicCommand& c = *(after - 1);
  const std::int64_t begin = c.step * s;
  if (c.teleport) return KinematicPlace{Pose{c.pose.position, c.pose.orientation.normalized()}, n == begin + 1};
  if (n >= begin + s) return KinematicPlace{Pose{c.pose.position, c.pose.orientation.normalized()}, false};
  // On the way: from where the body was at the command's boundary (an
  // earlier command's end or the path: never this command again).
  const Pose from = kinematic_place(body, settings, begin).pose;
  const double u = static_cast<double>(n - begin) / static_cast<double>(s);
  return KinematicPlace{interpolate_pose(from, c.pose, u), false};
}

}  // namespace soda

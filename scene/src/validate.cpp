#include "soda/scene/validate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <unordered_map>

namespace soda {
namespace {

std::string body_prefix(const std::string& source, std::size_t index, BodyId id) {
  std::ostringstream s;
  s << source << ": body #" << index << " (id " << id << ")";
  return s.str();
}

[[noreturn]] void fail(const std::string& where, const std::string& field, const std::string& what) {
  throw SceneError(where + ": field '" + field + "': " + what);
}

void check_finite(const std::string& where, const std::string& field, double v) {
  if (!std::isfinite(v)) fail(where, field, "must be a finite number");
}

void check_finite(const std::string& where, const std::string& field, const Vec3& v) {
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(v[i])) fail(where, field, "must be finite numbers");
}

void check_positive(const std::string& where, const std::string& field, double v) {
  check_finite(where, field, v);
  if (!(v > 0.0)) fail(where, field, "must be > 0");
}

// Every vertex finite, every index in range, no triangle without area
// (Bullet's contact normals come from the triangle's cross product).
void check_mesh(const std::string& where, const TriangleMeshData* mesh, const std::string& at) {
  if (!mesh) fail(where, at + ".vertices", "missing (a triangle mesh needs vertices and indices, or a file)");
  const std::string from = mesh->file.empty() ? "" : " (from " + mesh->file + ")";
  if (mesh->vertices.empty()) fail(where, at + ".vertices", "empty: a triangle mesh needs at least 3 vertices" + from);
  if (mesh->triangles.empty()) fail(where, at + ".indices", "empty: a triangle mesh needs at least one triangle" + from);
  if (mesh->vertices.size() > kMaxMeshVertices)
    fail(where, at + ".vertices", std::to_string(mesh->vertices.size()) + " vertices: at most 2^31 - 1" + from);
  for (std::size_t i = 0; i < mesh->vertices.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(mesh->vertices[i][k]))
        fail(where, at + ".vertices[" + std::to_string(i) + "]", "must be finite numbers" + from);
  for (std::size_t t = 0; t < mesh->triangles.size(); ++t) {
    const auto& tri = mesh->triangles[t];
    const std::string field = at + ".indices[" + std::to_string(t) + "]";
    for (std::uint32_t v : tri)
      if (v >= mesh->vertices.size())
        fail(where, field,
             "vertex index " + std::to_string(v) + " out of range (the mesh has " +
                 std::to_string(mesh->vertices.size()) + " vertices)" + from);
    const Vec3 &a = mesh->vertices[tri[0]], &b = mesh->vertices[tri[1]], &c = mesh->vertices[tri[2]];
    const Vec3 n = (b - a).cross(c - a);
    if (!(n.norm() > 0.0) || !std::isfinite(n.norm()))
      fail(where, field,
           "degenerate triangle (vertices " + std::to_string(tri[0]) + ", " + std::to_string(tri[1]) + ", " +
               std::to_string(tri[2]) + " have no area)" + from);
  }
}

void check_heightfield(const std::string& where, const HeightfieldData* hf, const std::string& at) {
  if (!hf) fail(where, at + ".heights", "missing (a heightfield needs columns, rows, spacing and heights)");
  if (hf->columns < 2) fail(where, at + ".columns", "must be >= 2 (samples along x)");
  if (hf->rows < 2) fail(where, at + ".rows", "must be >= 2 (samples along z)");
  if (static_cast<std::int64_t>(hf->columns) * hf->rows > kMaxHeightfieldSamples)
    fail(where, at + ".rows", "columns * rows must be at most 2^31 - 1 samples");
  const auto n = static_cast<std::size_t>(hf->columns) * static_cast<std::size_t>(hf->rows);
  if (hf->heights.size() != n)
    fail(where, at + ".heights",
         "holds " + std::to_string(hf->heights.size()) + " heights, columns * rows = " + std::to_string(n));
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(hf->heights[i])) fail(where, at + ".heights[" + std::to_string(i) + "]", "must be a finite number");
  for (int k = 0; k < 3; ++k) check_positive(where, at + ".spacing", hf->spacing[k]);
  if (!std::isfinite(hf->max_abs_height())) fail(where, at + ".heights", "heights times spacing[1] overflow");
}

// `at` names the shape's field: "shape", or "shape.children[i].shape" in a
// compound.
void check_shape(const std::string& where, const Shape& shape, const std::string& at = "shape") {
  switch (shape.kind) {
    case ShapeKind::Box:
    case ShapeKind::Cylinder:
      for (int i = 0; i < 3; ++i) check_positive(where, at + ".half_extents", shape.half_extents[i]);
      break;
    case ShapeKind::Sphere:
      check_positive(where, at + ".radius", shape.radius);
      break;
    case ShapeKind::Capsule:
      check_positive(where, at + ".radius", shape.radius);
      check_positive(where, at + ".height", shape.height);
      break;
    case ShapeKind::ConvexHull: {
      if (shape.points.size() < 4) fail(where, at + ".points", "a convex hull needs at least 4 points");
      for (const Vec3& p : shape.points) check_finite(where, at + ".points", p);
      // Not all coplanar: some triple of edges from point 0 spans volume.
      const Vec3 extent = shape.local_half_extents();
      bool spans = false;
      for (std::size_t i = 1; i < shape.points.size() && !spans; ++i)
        for (std::size_t j = i + 1; j < shape.points.size() && !spans; ++j)
          for (std::size_t k = j + 1; k < shape.points.size() && !spans; ++k) {
            const Vec3 a = shape.points[i] - shape.points[0];
            const Vec3 b = shape.points[j] - shape.points[0];
            const Vec3 c = shape.points[k] - shape.points[0];
            spans = std::abs(a.cross(b).dot(c)) > 1e-12 * std::pow(extent.maxCoeff(), 3);
          }
      if (!spans) fail(where, at + ".points", "points are coplanar: the hull has no volume");
      break;
    }
    case ShapeKind::Compound: {
      if (shape.children.empty()) fail(where, at + ".children", "a compound needs at least one child shape");
      for (std::size_t i = 0; i < shape.children.size(); ++i) {
        const CompoundChild& c = shape.children[i];
        const std::string child = at + ".children[" + std::to_string(i) + "]";
        if (c.shape.kind == ShapeKind::Compound || c.shape.is_concave())
          fail(where, child + ".shape",
               std::string(c.shape.kind == ShapeKind::Compound ? "nested compounds are not supported"
                                                               : "a compound's child cannot be concave") +
                   ": a compound's children are convex shapes (box, sphere, capsule, cylinder, convex_hull)");
        check_finite(where, child + ".position", c.position);
        const Eigen::Vector4d q = c.orientation.coeffs();
        for (int k = 0; k < 4; ++k)
          if (!std::isfinite(q[k])) fail(where, child + ".orientation", "must be finite numbers");
        if (q.norm() == 0.0) fail(where, child + ".orientation", "must not be the zero quaternion");
        check_shape(where, c.shape, child + ".shape");
      }
      break;
    }
    case ShapeKind::TriangleMesh:
      check_mesh(where, shape.mesh.get(), at);
      break;
    case ShapeKind::Heightfield:
      check_heightfield(where, shape.heightfield.get(), at);
      break;
  }
}

// Bullet's own test (btDiscreteDynamicsWorld::updateSingleAabb): a dynamic
// body whose AABB over one step (current union predicted transform) has
// length^2 >= 1e12 is silently disabled. The AABB is computed here the way a
// float world computes it (bounds rounded to float), which also catches
// coordinates so large that float rounding alone blows the AABB up; a double
// world is at least as lenient.
void check_bullet_aabb(const std::string& where, const Body& b, double dt) {
  const Vec3 h = b.aabb_half_extents();
  const Vec3 next = b.position + b.linear_velocity * dt;
  double len2 = 0.0;
  constexpr double kFloatMax = 3.4028234663852886e38;
  for (int k = 0; k < 3; ++k) {
    if (!(std::abs(b.position[k]) + h[k] < kFloatMax && std::abs(next[k]) + h[k] < kFloatMax)) {
      len2 = HUGE_VAL;  // the bounds overflow a float: infinite AABB
      break;
    }
    const auto pk = static_cast<float>(b.position[k]), nk = static_cast<float>(next[k]);
    const auto hk = static_cast<float>(h[k]);
    const float lo = std::min(pk - hk, nk - hk), hi = std::max(pk + hk, nk + hk);
    const double len = static_cast<double>(hi) - static_cast<double>(lo);
    len2 += len * len;
  }
  if (!(len2 < kBulletMaxAabbLength2)) {
    std::ostringstream msg;
    msg << "body too large, too fast or too far from the origin: its one-step AABB has length^2 "
        << len2 << " >= 1e12, which Bullet silently disables";
    fail(where, "position/shape/linear_velocity", msg.str());
  }
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// " (float build, step 0.0167 s)": which envelope a message speaks of.
std::string in_envelope(const PrecisionEnvelope& e) {
  return std::string(" (") + precision_name(e.precision) + " build, internal step " + num(e.step) +
         " s; docs/scene-format.md, \"Precision envelope\")";
}

// The step: neither rounded away nor so long that gravity alone makes
// Bullet disable a body in the first step.
void check_step_envelope(const std::string& where, const SceneSettings& st, const PrecisionEnvelope& e) {
  if (!(e.step >= e.min_step))
    fail(where, "dt",
         "a step (dt / substeps) of " + num(e.step) + " s is too short: at least " + num(e.min_step) +
             " s, so that a body at " + num(kSlowestSpeed) + " m/s one metre from the origin still moves (x + v dt != x)" +
             in_envelope(e));
  if (!(e.step < e.max_finite)) fail(where, "dt", "the step overflows" + in_envelope(e));
  for (int k = 0; k < 3; ++k)
    if (!(std::abs(st.gravity[k]) < e.max_finite)) fail(where, "gravity", "overflows" + in_envelope(e));
  const double fall = st.gravity.norm() * e.step * e.step;
  if (!(fall * fall < kBulletMaxAabbLength2))
    fail(where, "gravity",
         "gravity alone moves a body " + num(fall) + " m in one step: Bullet disables a body whose one-step AABB "
         "has length^2 >= 1e12 (shorten dt)" + in_envelope(e));
}

// Position, size, mass and spin of one body inside the envelope.
void check_body_envelope(const std::string& where, const Body& b, const PrecisionEnvelope& e) {
  const Vec3 h = b.aabb_half_extents();
  const Vec3 local = b.shape.local_half_extents();
  const double coordinate = b.position.cwiseAbs().maxCoeff();
  for (int k = 0; k < 3; ++k)
    if (!(std::abs(b.position[k]) + h[k] < e.max_finite))
      fail(where, "position/shape", "the body reaches beyond the largest finite number" + in_envelope(e));
  if (!b.is_static && coordinate > e.max_position)
    fail(where, "position",
         "coordinate " + num(coordinate) + " m is too far from the origin: at most " + num(e.max_position) +
             " m, beyond which a body at " + num(kSlowestSpeed) + " m/s moves less than one ulp per step (x + v dt == x)" +
             in_envelope(e));
  const double smallest = local.minCoeff();
  // A mesh or heightfield may be flat (its triangles have no thickness).
  if (!b.shape.is_concave() && smallest < e.min_half_extent(coordinate))
    fail(where, "shape",
         "smallest half extent " + num(smallest) + " m is below " + num(kMinSizeInUlps) + " ulps of its position (" +
             num(e.min_half_extent(coordinate)) + " m at " + num(coordinate) + " m from the origin)" + in_envelope(e));
  if (b.is_static) return;
  if (!(b.mass >= e.min_mass && b.mass <= e.max_mass))
    fail(where, "mass",
         num(b.mass) + " kg is outside [" + num(e.min_mass) + ", " + num(e.max_mass) +
             "] kg: the mass, its inverse and their products must stay finite, non-zero numbers" + in_envelope(e));
  const double inertia_lo = b.mass * smallest * smallest, inertia_hi = b.mass * local.squaredNorm();
  if (!(inertia_lo >= e.min_mass && inertia_hi <= e.max_mass))
    fail(where, "mass/shape",
         "moment of inertia of the order of " + num(inertia_lo < e.min_mass ? inertia_lo : inertia_hi) +
             " kg m^2 is outside [" + num(e.min_mass) + ", " + num(e.max_mass) + "]" + in_envelope(e));
  const double spin = b.angular_velocity.norm();
  if (spin > e.max_angular_speed)
    fail(where, "angular_velocity",
         num(spin) + " rad/s turns the body more than pi/4 per step, which Bullet silently clamps: at most " +
             num(e.max_angular_speed) + " rad/s" + in_envelope(e));
}

std::string joint_prefix(const std::string& source, std::size_t index, JointId id) {
  std::ostringstream s;
  s << source << ": joint #" << index << " (id " << id << ")";
  return s.str();
}

void check_frame(const std::string& where, const std::string& field, const JointFrame& f) {
  check_finite(where, field + ".position", f.position);
  const Eigen::Vector4d q = f.orientation.coeffs();
  for (int k = 0; k < 4; ++k)
    if (!std::isfinite(q[k])) fail(where, field + ".orientation", "must be finite numbers");
  if (!(q.norm() > 1e-6)) fail(where, field + ".orientation", "must be a non-zero quaternion");
}

// A limit [lower, upper] on an angle: lower <= upper, both in [-bound, bound].
void check_angle_limit(const std::string& where, const std::string& field, double lower, double upper, double bound) {
  check_finite(where, field, lower);
  check_finite(where, field, upper);
  if (!(lower <= upper)) fail(where, field, "lower " + std::to_string(lower) + " is above upper " + std::to_string(upper));
  if (lower < -bound || upper > bound)
    fail(where, field, "angles must lie in [-" + std::to_string(bound) + ", " + std::to_string(bound) + "] rad");
}

void check_joint_values(const Joint& j, const std::string& where) {
  check_frame(where, "frame_a", j.frame_a);
  check_frame(where, "frame_b", j.frame_b);
  if (!(j.breaking_impulse > 0.0)) fail(where, "breaking_impulse", "must be > 0 (infinity or absent: never breaks)");
  constexpr double kPi = 3.14159265358979323846;
  switch (j.kind) {
    case JointKind::Hinge:
    case JointKind::Slider:
      if (j.kind == JointKind::Hinge && j.limited) check_angle_limit(where, "limit", j.lower, j.upper, kPi);
      if (j.kind == JointKind::Slider) {
        check_finite(where, "limit", j.lower);
        check_finite(where, "limit", j.upper);
        if (j.limited && !(j.lower <= j.upper))
          fail(where, "limit", "lower " + std::to_string(j.lower) + " is above upper " + std::to_string(j.upper));
        check_angle_limit(where, "angular_limit", j.angular_lower, j.angular_upper, kPi);
      }
      if (j.motor) {
        check_finite(where, "motor.velocity", j.motor_velocity);
        check_finite(where, "motor.max_impulse", j.motor_max_impulse);
        if (j.motor_max_impulse < 0.0) fail(where, "motor.max_impulse", "must be >= 0");
      }
      break;
    case JointKind::ConeTwist:
      for (double span : {j.swing_span1, j.swing_span2, j.twist_span}) {
        check_finite(where, "spans", span);
        if (!(span >= 0.0 && span <= kPi)) fail(where, "spans", "each span must lie in [0, pi] rad");
      }
      break;
    case JointKind::Spring6Dof:
      for (std::size_t a = 0; a < 6; ++a) {
        const std::string axis = "[" + std::to_string(a) + "]";
        for (double v : {j.axis_lower[a], j.axis_upper[a], j.stiffness[a], j.damping[a], j.motor_velocities[a],
                         j.motor_max_forces[a]})
          check_finite(where, "axes" + axis, v);
        if (j.stiffness[a] < 0.0) fail(where, "axes.stiffness" + axis, "must be >= 0");
        if (j.damping[a] < 0.0) fail(where, "axes.damping" + axis, "must be >= 0");
        if (j.motor_max_forces[a] < 0.0) fail(where, "axes.motor_max_force" + axis, "must be >= 0");
        // Angular axes: Bullet's Euler angles (order xyz) keep y within
        // [-pi/2, pi/2], x and z within [-pi, pi]; lower > upper is free.
        if (a >= 3 && j.axis_lower[a] <= j.axis_upper[a])
          check_angle_limit(where, "axes.lower/upper" + axis, j.axis_lower[a], j.axis_upper[a],
                            a == 4 ? kPi / 2 : kPi);
      }
      break;
    case JointKind::PointToPoint:
    case JointKind::Fixed: break;
  }
}

}  // namespace

void validate_joint(const Joint& joint, const std::string& where, const BodyLookup& body) {
  if (joint.id > kMaxJointId) fail(where, "id", "must be below 2^31");
  if (joint.body_a == joint.body_b) fail(where, "body_b", "joins body " + std::to_string(joint.body_a) + " to itself");
  const Body* a = body(joint.body_a);
  if (!a) fail(where, "body_a", "no body with id " + std::to_string(joint.body_a));
  const Body* b = body(joint.body_b);
  if (!b) fail(where, "body_b", "no body with id " + std::to_string(joint.body_b));
  if (a->is_static && b->is_static)
    fail(where, "body_b", "both bodies (" + std::to_string(joint.body_a) + ", " + std::to_string(joint.body_b) +
                              ") are static: a joint needs a dynamic body");
  for (const Body* k : {a, b})
    if (k->kinematic)
      fail(where, k == a ? "body_a" : "body_b",
           "body " + std::to_string(k->id) + " is kinematic: joints to kinematic bodies are not supported");
  check_joint_values(joint, where);
}

void validate_body(const Body& b, const std::string& where) {
  check_shape(where, b.shape);
  // The path first: a body with a path starts at its first key's pose.
  const std::vector<PathKey>& keys = b.path.keys;
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const std::string at = "path.keys[" + std::to_string(i) + "]";
    check_finite(where, at + ".time", keys[i].time);
    if (keys[i].time < 0.0) fail(where, at + ".time", "must be >= 0");
    if (i > 0 && !(keys[i].time > keys[i - 1].time))
      fail(where, at + ".time", "must be later than the key before it (times ascend)");
    check_finite(where, at + ".position", keys[i].position);
    const Eigen::Vector4d kq = keys[i].orientation.coeffs();
    for (int k = 0; k < 4; ++k)
      if (!std::isfinite(kq[k])) fail(where, at + ".orientation", "must be finite numbers");
    if (!(kq.norm() > 1e-6)) fail(where, at + ".orientation", "must be a non-zero quaternion");
  }

  check_finite(where, "position", b.position);
  check_finite(where, "linear_velocity", b.linear_velocity);
  check_finite(where, "angular_velocity", b.angular_velocity);
  check_finite(where, "friction", b.friction);
  check_finite(where, "restitution", b.restitution);
  if (b.friction < 0.0) fail(where, "friction", "must be >= 0");
  if (b.restitution < 0.0) fail(where, "restitution", "must be >= 0");
  const Eigen::Vector4d q = b.orientation.coeffs();
  for (int k = 0; k < 4; ++k)
    if (!std::isfinite(q[k])) fail(where, "orientation", "must be finite numbers");
  if (!(q.norm() > 1e-6)) fail(where, "orientation", "must be a non-zero quaternion");
  if (!b.is_static && b.shape.is_concave())
    fail(where, "shape.type",
         std::string("a dynamic body cannot be a ") + shape_kind_name(b.shape.kind) +
             ": it is concave, and Bullet collides concave shapes only as static geometry; make the body static, or "
             "build it as a compound of convex hulls");
  if (!b.is_static) {
    check_finite(where, "mass", b.mass);
    if (!(b.mass > 0.0)) fail(where, "mass", "must be > 0 for a dynamic body");
  }
  if (b.asleep && b.is_static)
    fail(where, "asleep", std::string("a ") + (b.kinematic ? "kinematic" : "static") +
                              " body cannot be asleep (only dynamic bodies sleep)");
  if (b.asleep && (!b.linear_velocity.isZero(0.0) || !b.angular_velocity.isZero(0.0)))
    fail(where, "asleep", "a body created asleep must have zero linear_velocity and angular_velocity");
  if (b.kinematic && !b.is_static) fail(where, "type", "a kinematic body is static too (is_static): it has no mass");
  if (b.kinematic && b.shape.is_concave())
    fail(where, "shape.type", std::string("a kinematic body's shape is convex or a compound (a ") +
                                  shape_kind_name(b.shape.kind) + " is for static bodies only)");
  if (!b.kinematic && !b.path.keys.empty()) fail(where, "path", "only kinematic bodies have a path");
  if (b.is_static && (!b.linear_velocity.isZero(0.0) || !b.angular_velocity.isZero(0.0)))
    fail(where, "linear_velocity", b.kinematic ? "a kinematic body's velocities come from its path"
                                                : "a static body cannot move");
  if (b.path.loop) {
    if (keys.size() < 2) fail(where, "path.loop", "a looping path needs at least two keys");
    if (keys.front().time != 0.0) fail(where, "path.keys[0].time", "a looping path starts at time 0");
  }
}

void validate_scene(const Scene& scene, const std::string& source, Precision precision) {
  const SceneSettings& st = scene.settings;
  const std::string settings = source + ": settings";
  check_positive(settings, "dt", st.dt);
  check_finite(settings, "gravity", st.gravity);
  if (st.substeps < 1) fail(settings, "substeps", "must be >= 1");
  const PrecisionEnvelope envelope = PrecisionEnvelope::of(precision, st.dt, st.substeps);
  check_step_envelope(settings, st, envelope);
  if (st.iterations < 1) fail(settings, "iterations", "must be >= 1");
  if (st.steps < 0) fail(settings, "steps", "must be >= 0");

  std::unordered_map<BodyId, std::size_t> seen;
  seen.reserve(scene.bodies.size());
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    const Body& b = scene.bodies[i];
    const std::string where = body_prefix(source, i, b.id);
    if (b.id > kMaxBodyId) fail(where, "id", "must be below 2^31");
    auto [it, inserted] = seen.emplace(b.id, i);
    if (!inserted)
      fail(where, "id", "duplicate id, also used by body #" + std::to_string(it->second));
    validate_body(b, where);
    if (!b.is_static) check_bullet_aabb(where, b, st.dt);
    check_body_envelope(where, b, envelope);
    for (const PathKey& k : b.path.keys) {  // the body wherever its path takes it
      Body at = b;
      at.position = k.position;
      at.orientation = k.orientation;
      check_body_envelope(where, at, envelope);
    }
  }
  if (scene.joints.empty()) return;
  const BodyLookup body = [&](BodyId id) -> const Body* {
    auto it = seen.find(id);
    return it == seen.end() ? nullptr : &scene.bodies[it->second];
  };
  std::unordered_map<JointId, std::size_t> joint_ids;
  for (std::size_t i = 0; i < scene.joints.size(); ++i) {
    const Joint& j = scene.joints[i];
    const std::string where = joint_prefix(source, i, j.id);
    auto [it, inserted] = joint_ids.emplace(j.id, i);
    if (!inserted) fail(where, "id", "duplicate joint id, also used by joint #" + std::to_string(it->second));
    validate_joint(j, where, body);
  }
}

}  // namespace soda

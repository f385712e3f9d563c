// scene/ — the scene model: what is simulated, independent of how.
//
// A Scene is plain data (double precision, no Bullet types) so that it can be
// written to JSON, generated from a seed, validated, partitioned and handed to
// worlds of either precision.
//
// Invariants (checked by validate_scene, see validate.h):
//  1. every body has a unique id below 2^31 (BodyId), statics included; ids are
//     never reused within a run;
//  2. every number is finite; dynamic bodies have mass > 0; shape extents > 0;
//     a kinematic body is a static body that moves (is_static and kinematic),
//     its path's times ascending;
//  3. no body is so large or fast that Bullet would silently disable it
//     (its one-step swept AABB has length^2 >= 1e12, see kBulletMaxAabbLength2).
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace soda {

/// Stable global body id, statics included. Valid ids are 0 .. kMaxBodyId.
using BodyId = std::uint32_t;
inline constexpr BodyId kMaxBodyId = (BodyId{1} << 31) - 1;

using Vec3 = Eigen::Vector3d;
using Quat = Eigen::Quaterniond;

enum class ShapeKind { Box, Sphere, Capsule, Cylinder, ConvexHull, Compound, TriangleMesh, Heightfield };

/// Name used in scene files and messages ("box", "sphere", ...).
const char* shape_kind_name(ShapeKind kind);

struct CompoundChild;

/// What a part of a triangle mesh keeps of the whole mesh it was cut from
/// (an MPI rank holds the triangles near its worlds: scene_share.h).
struct MeshCut {
  /// The whole mesh's index of each of the part's triangles, ascending.
  std::vector<std::uint32_t> whole_index;
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();  // the whole mesh's vertex bounds
  double radius = 0.0;  // the largest distance of a whole mesh's vertex from the origin
};

/// The triangles of a static triangle mesh, in the body's frame (metres).
/// Immutable once made: shapes share it (Shape::mesh), so a scene's copies
/// (every world's, every snapshot's) hold one pointer, never the triangles.
struct TriangleMeshData {
  std::vector<Vec3> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;  // indices into vertices, counter-clockwise seen from outside
  /// The OBJ file the mesh was read from, as the scene file names it
  /// (relative to the scene file's folder); empty: the triangles are inline.
  std::string file;
  /// Set on a part cut from a larger mesh: its triangles are some of the
  /// whole's, and its bounds are the whole's. Null: the whole mesh.
  std::shared_ptr<const MeshCut> cut;
};

/// The heights of a static heightfield: a grid of `columns` samples along x
/// by `rows` samples along z, heights along y, centred on the body's
/// origin: sample (i, j) lies at x = (i - (columns - 1) / 2) * spacing.x(),
/// z = (j - (rows - 1) / 2) * spacing.z(), y = heights[j * columns + i] *
/// spacing.y(). Immutable once made (shared as TriangleMeshData is).
struct HeightfieldData {
  int columns = 0;              // samples along x, >= 2
  int rows = 0;                 // samples along z, >= 2
  std::vector<double> heights;  // rows * columns, row by row (z), each row along x
  Vec3 spacing = Vec3(1.0, 1.0, 1.0);  // m between samples along x and z; y scales the heights
  /// A window cut from the whole grid (an MPI rank holds the samples near
  /// its worlds: scene_share.h): `heights` then holds `rows` x `columns`
  /// samples from sample (column, row) of the whole, row by row, and
  /// `max_abs` is the whole's largest |height|. columns == 0: every sample.
  struct Window {
    int column = 0, row = 0, columns = 0, rows = 0;
    double max_abs = 0.0;
  } window;
  /// Largest |height| * spacing.y() (the local AABB's half height).
  double max_abs_height() const;
  /// Largest |height| of the whole grid.
  double max_abs_raw_height() const;
  /// Sample (i, j) of the whole grid (i along x, j along z); a window
  /// holds only its own.
  double height(int i, int j) const {
    if (window.columns == 0) return heights[static_cast<std::size_t>(j) * columns + i];
    return heights[static_cast<std::size_t>(j - window.row) * window.columns + (i - window.column)];
  }
};

/// Collision shape in the body's local frame. Units: metres.
/// - Box:        half_extents (x, y, z).
/// - Sphere:     radius.
/// - Capsule:    radius and height (length of the cylindrical part, along y,
///               as btCapsuleShape).
/// - Cylinder:   half_extents (x = radius, y = half height, z = radius),
///               along y, as btCylinderShape.
/// - ConvexHull: points (at least 4, not all coplanar).
/// - Compound:   children (at least one): convex shapes (any kind above)
///               at poses in the body's frame, as btCompoundShape. Its mass
///               properties: docs/scene-format.md, "Compound shapes".
/// - TriangleMesh: mesh (static bodies only; docs/scene-format.md,
///               "Triangle meshes and heightfields").
/// - Heightfield:  heightfield (static bodies only).
struct Shape {
  ShapeKind kind = ShapeKind::Box;
  Vec3 half_extents = Vec3(0.5, 0.5, 0.5);
  double radius = 0.5;
  double height = 1.0;
  std::vector<Vec3> points;
  std::vector<CompoundChild> children;  // Compound only, in order (a child's index is its place)
  std::shared_ptr<const TriangleMeshData> mesh;        // TriangleMesh only
  std::shared_ptr<const HeightfieldData> heightfield;  // Heightfield only

  static Shape box(const Vec3& half_extents);
  static Shape sphere(double radius);
  static Shape capsule(double radius, double height);
  static Shape cylinder(const Vec3& half_extents);
  static Shape convex_hull(std::vector<Vec3> points);
  static Shape compound(std::vector<CompoundChild> children);
  static Shape triangle_mesh(std::shared_ptr<const TriangleMeshData> mesh);
  static Shape heightfield_of(std::shared_ptr<const HeightfieldData> heightfield);

  /// TriangleMesh and Heightfield: concave, for static bodies only.
  bool is_concave() const { return kind == ShapeKind::TriangleMesh || kind == ShapeKind::Heightfield; }

  /// Radius of a sphere around the local origin that holds the whole shape.
  double bounding_radius() const;
  /// Half extents of the local-frame AABB of the shape (around the local
  /// origin: for a compound, the box centred there that holds every child).
  Vec3 local_half_extents() const;
};

/// One child of a compound shape: a convex shape at a pose in the body's
/// frame.
struct CompoundChild {
  Shape shape;
  Vec3 position = Vec3::Zero();         // m, in the body's frame
  Quat orientation = Quat::Identity();  // unit quaternion (normalised on use)
};

/// The collision group a body belongs to unless its scene says otherwise
/// (Bullet's btBroadphaseProxy::DefaultFilter).
inline constexpr std::uint32_t kDefaultCollisionGroup = 1;
/// Every group: the default mask (collide with every body).
inline constexpr std::uint32_t kAllCollisionGroups = 0xffffffffu;

/// One pose of a kinematic body's path: where it is at `time`.
struct PathKey {
  double time = 0.0;                    // s since step 0
  Vec3 position = Vec3::Zero();         // m, world frame
  Quat orientation = Quat::Identity();  // unit quaternion (normalised on use)
};

/// The motion of a kinematic body (docs/scene-format.md, "Kinematic
/// bodies"): piecewise-linear poses over time. Between two keys the position
/// is interpolated linearly and the orientation by normalised linear
/// interpolation (the shorter way round); before the first key the body is
/// at the first, after the last at the last, unless `loop`: then the path
/// repeats with the last key's time as its period (the first key's time is
/// 0 and its pose is where each period starts).
struct KinematicPath {
  std::vector<PathKey> keys;  // ascending time; empty: no path
  bool loop = false;
};

/// A pose in the world frame.
struct Pose {
  Vec3 position = Vec3::Zero();
  Quat orientation = Quat::Identity();
};

/// An input that moved a kinematic body (Simulation::set_kinematic_target,
/// Simulation::set_pose; docs/scene-format.md, "Kinematic bodies"), at the
/// boundary after scene step `step`.
struct KinematicCommand {
  std::int64_t step = 0;
  /// set_pose: at `pose` from the next internal step on, with zero
  /// velocity. Else a target: reached at the end of step + 1, moving
  /// there over that step (every substep a part), velocity from the move.
  bool teleport = false;
  Pose pose;
};

/// A collision filter input of a kinematic body
/// (Simulation::set_collision_filter; docs/scene-format.md, "Kinematic
/// bodies"), at the boundary after scene step `step`: from the next step on
/// the body's filter is this one.
struct FilterCommand {
  std::int64_t step = 0;
  std::uint32_t group = 0;
  std::uint32_t mask = 0;
};

/// One rigid body. Static bodies have mass 0 and never move, but for
/// kinematic ones.
struct Body {
  BodyId id = 0;
  bool is_static = false;
  /// A kinematic body is a static body that moves (is_static is true too):
  /// infinite mass, it pushes dynamic bodies and is never pushed; every
  /// world holds it, as every static, and its pose at each step is a pure
  /// function of its path (docs/scene-format.md, "Kinematic bodies"). Its
  /// velocities are derived from the pose change over each step, so
  /// contacts carry and push what it touches.
  bool kinematic = false;
  /// Kinematic bodies only: the path; empty, the body stays at
  /// position/orientation.
  KinematicPath path;
  /// Kinematic bodies only: the inputs that moved it, ascending step, one
  /// per step (the last input of a step). The first ends the path: from
  /// then on the body holds the pose of the last command it reached.
  /// Written to snapshots and checkpoints, never to scene files.
  std::vector<KinematicCommand> commands;
  /// Kinematic bodies only: the collision filter inputs it got, ascending
  /// step, one per step (the last input of a step). Its filter at a step is
  /// the last command's before it, else collision_group / collision_mask
  /// (which stay the scene's). Written to snapshots and checkpoints, never
  /// to scene files.
  std::vector<FilterCommand> filter_commands;
  Shape shape;
  double mass = 1.0;         // kg; > 0 for dynamic bodies, ignored for statics
  double friction = 0.5;     // Bullet's friction coefficient
  double restitution = 0.0;  // Bullet's restitution coefficient
  Vec3 position = Vec3::Zero();                  // m, world frame
  Quat orientation = Quat::Identity();           // unit quaternion
  Vec3 linear_velocity = Vec3::Zero();           // m/s
  Vec3 angular_velocity = Vec3::Zero();          // rad/s
  /// Dynamic bodies only: created asleep, exactly as a body that has just
  /// fallen asleep (docs/scene-format.md, "asleep"): Bullet's activation
  /// state ISLAND_SLEEPING, sleep timer kAsleepTimer, velocities zero (a body
  /// created asleep must have zero velocities). It wakes as any sleeper does:
  /// when a contact joins it to an awake body, or by user input.
  bool asleep = false;
  /// Collision filter (docs/scene-format.md, "Collision filtering"): two
  /// bodies a and b may touch iff (a.collision_group & b.collision_mask) != 0
  /// and (b.collision_group & a.collision_mask) != 0. Two static bodies never
  /// touch. The defaults let a body touch every other one.
  std::uint32_t collision_group = kDefaultCollisionGroup;
  std::uint32_t collision_mask = kAllCollisionGroups;
  /// The application's own tag for the body (an entity handle, an index):
  /// carried with the body wherever it goes (ghosts, migrations, snapshots,
  /// checkpoints) and readable at any step (SceneReader::body_at); no physics
  /// reads it and the state hash does not cover it. Set at creation or by
  /// input (Simulation::set_user_data).
  std::uint64_t user_data = 0;
  /// A sensor (docs/contact-events.md, "Sensors"): it never touches any body
  /// (no contact, no push, no island edge: every world filters its pairs
  /// out), and a SensorReader reports the bodies its shape overlaps at each
  /// committed step. A static sensor stays where it is, a dynamic one moves
  /// as any body does (gravity, inputs) but passes through everything.
  bool sensor = false;

  /// Half extents of the world-frame AABB of the body at its initial pose.
  Vec3 aabb_half_extents() const;
};


/// The sleep timer (seconds) of a body created asleep: Bullet's
/// gDeactivationTime, the time below the sleeping thresholds after which a
/// body wants to sleep. Any value > 0 keeps a sleeper asleep (Bullet wakes
/// an ISLAND_SLEEPING body whose timer is 0); this one is what a body that
/// has just fallen asleep carries at least.
inline constexpr double kAsleepTimer = 2.0;

/// Stable joint id, unique among a scene's joints. Valid ids are 0 ..
/// kMaxJointId; joints are created and solved in id order.
using JointId = std::uint32_t;
inline constexpr JointId kMaxJointId = (JointId{1} << 31) - 1;

/// Bullet's constraint types (docs/scene-format.md, "Joints").
enum class JointKind {
  PointToPoint,  // btPoint2PointConstraint: the frames' origins coincide
  Hinge,         // btHingeConstraint: rotation about the frames' z axes
  Slider,        // btSliderConstraint: motion along and about the frames' x axes
  ConeTwist,     // btConeTwistConstraint: twist about x, swing inside a cone
  Fixed,         // btFixedConstraint: the frames coincide
  Spring6Dof,    // btGeneric6DofSpring2Constraint: six axes, limits, springs, motors
};

/// Name used in scene files and messages ("point-to-point", "hinge", ...).
const char* joint_kind_name(JointKind kind);

/// A rigid frame in a body's local space (metres, unit quaternion).
struct JointFrame {
  Vec3 position = Vec3::Zero();
  Quat orientation = Quat::Identity();
};

/// One joint between two bodies (at most one of them static). Which fields a
/// kind reads (the others are ignored and not written to files):
/// - every kind: frame_a, frame_b (point-to-point: their positions only),
///   collide_connected, breaking_impulse;
/// - Hinge: limited/lower/upper (angle about z, rad), motor/motor_velocity
///   (rad/s)/motor_max_impulse (N m s);
/// - Slider: lower/upper (along x, m; lower > upper: free),
///   angular_lower/angular_upper (about x, rad), motor/motor_velocity
///   (m/s)/motor_max_impulse (as Bullet's max linear motor force times the
///   step);
/// - ConeTwist: swing_span1, swing_span2, twist_span (rad);
/// - Spring6Dof: per axis (x, y, z linear in m, then x, y, z angular in rad)
///   axis_lower/axis_upper (lower == upper: locked; lower > upper: free),
///   stiffness/damping (a spring where stiffness > 0), motor_velocities and
///   motor_max_forces (a motor where max force > 0).
struct Joint {
  JointId id = 0;
  JointKind kind = JointKind::PointToPoint;
  BodyId body_a = 0, body_b = 0;
  JointFrame frame_a, frame_b;  // in body_a's and body_b's local space
  /// Whether the two bodies collide with each other (default: they do not).
  bool collide_connected = false;
  /// The impulse (N s) at which the joint breaks for good; infinity: never.
  double breaking_impulse = std::numeric_limits<double>::infinity();
  bool limited = false;
  double lower = 1.0, upper = -1.0;
  double angular_lower = 0.0, angular_upper = 0.0;
  bool motor = false;
  double motor_velocity = 0.0, motor_max_impulse = 0.0;
  double swing_span1 = 1.0, swing_span2 = 1.0, twist_span = 1.0;
  std::array<double, 6> axis_lower{}, axis_upper{}, stiffness{}, damping{}, motor_velocities{}, motor_max_forces{};
};

/// A setting of a joint's motor (a set_joint_motor input,
/// soda/scene/joint_motor.h): a hinge's or slider's one motor, or that of
/// one axis of a 6-DoF spring joint.
struct JointMotor {
  bool on = false;
  double velocity = 0.0;     // target: rad/s (hinge, angular axis), m/s (slider, linear axis)
  double max_impulse = 0.0;  // >= 0: hinge, slider (Joint::motor_max_impulse); 6-DoF: the axis's max force
  int axis = -1;             // 6-DoF spring: 0..5 (x, y, z linear, then angular); other kinds: -1
};

/// Stepping settings of a scene. Units: seconds, m/s^2.
struct SceneSettings {
  double dt = 1.0 / 60.0;     // fixed step
  int substeps = 1;           // internal substeps per step (Bullet maxSubSteps)
  int iterations = 10;        // constraint solver iterations
  Vec3 gravity = Vec3(0.0, -9.81, 0.0);
  int steps = 600;            // default number of steps for a run
};

struct Scene {
  std::string name;           // registry name or file stem
  std::uint64_t seed = 0;     // seed it was generated from (0 for files)
  SceneSettings settings;
  std::vector<Body> bodies;   // any order; ids are what identify bodies
  std::vector<Joint> joints;  // any order; created and solved in id order

  std::size_t dynamic_count() const;
  std::size_t static_count() const;
  /// Largest extent (AABB edge length) over dynamic bodies, 0 if none.
  double largest_dynamic_extent() const;
};

/// The time (s) of the state after `internal_steps` internal steps of
/// dt / substeps: the one expression every world uses.
double internal_step_time(const SceneSettings& settings, std::int64_t internal_steps);

/// The pose of a kinematic body at `time` (s): its path's, or its
/// position/orientation without a path. A pure function of the description
/// and the time, the same in every world (docs/scene-format.md, "Kinematic
/// bodies").
Pose kinematic_pose(const Body& body, double time);

/// Where a kinematic body is after `internal_steps` internal steps: its
/// path's pose (kinematic_pose at internal_step_time) until its first
/// command takes effect, then its commands' (KinematicCommand). `teleported`:
/// a set_pose lands at this very internal step (the move into it has zero
/// velocity). A pure function of the description, settings and step.
struct KinematicPlace {
  Pose pose;
  bool teleported = false;
};
KinematicPlace kinematic_place(const Body& body, const SceneSettings& settings, std::int64_t internal_steps);

/// The pose a fraction u in [0, 1] of the way from a to b: positions
/// linearly, orientations by normalised linear interpolation the shorter way
/// round (docs/scene-format.md, "Kinematic bodies").
Pose interpolate_pose(const Pose& a, const Pose& b, double u);

}  // namespace soda

// Byte encoding of bodies and manifolds (value_codec.h); joints are in
// joint_codec.cpp.
#include "soda/worlds/value_codec.h"

#include <bit>
#include <cmath>
#include <cstring>
#include <memory>

namespace soda {

static_assert(std::endian::native == std::endian::little, "value bytes are written in host order");

namespace {

// Every encoded field of one or more points, in encoding order: io(field)
// to write or read one, io(field_a, field_b) to compare two.
template <class Io, class... P>
void visit_point(Io& io, P&... p) {
  io(p.local_point_a...), io(p.local_point_b...), io(p.position_world_on_b...), io(p.position_world_on_a...);
  io(p.normal_world_on_b...), io(p.distance...), io(p.combined_friction...), io(p.combined_rolling_friction...);
  io(p.combined_spinning_friction...), io(p.combined_restitution...), io(p.part_id0...), io(p.part_id1...);
  io(p.index0...), io(p.index1...), io(p.contact_point_flags...), io(p.applied_impulse...), io(p.prev_rhs...);
  io(p.applied_impulse_lateral1...), io(p.applied_impulse_lateral2...), io(p.contact_motion1...);
  io(p.contact_motion2...), io(p.contact_cfm...), io(p.combined_contact_stiffness1...), io(p.contact_erp...);
  io(p.combined_contact_damping1...), io(p.friction_cfm...), io(p.lifetime...), io(p.lateral_friction_dir1...);
  io(p.lateral_friction_dir2...);
}

// Every field of one or more raw states, in encoding order.
template <class Io, class... S>
void visit_state(Io& io, S&... s) {
  io(s.basis...), io(s.origin...), io(s.interpolation_basis...), io(s.interpolation_origin...);
  io(s.linear_velocity...), io(s.angular_velocity...);
  io(s.interpolation_linear_velocity...), io(s.interpolation_angular_velocity...);
  io(s.activation_state...), io(s.deactivation_time...), io(s.hit_fraction...);
}

// Compares field by field (the structs have padding, which memcmp of the
// whole would read).
struct SameBits {
  bool equal = true;
  template <class T>
  void operator()(const T& a, const T& b) {
    equal = equal && std::memcmp(&a, &b, sizeof(T)) == 0;
  }
};

}  // namespace

void ByteReader::fail(const std::string& what) const {
  raise_(context_ + ": " + what + " at byte " + std::to_string(pos_) + " of " + std::to_string(bytes_.size()));
  throw std::logic_error("ByteReader: raise function returned");  // raise must throw
}

double ByteReader::finite() {
  const double v = get<double>();
  if (!std::isfinite(v)) fail("non-finite number");
  return v;
}

Vec3 ByteReader::vec3() {
  const double x = finite(), y = finite(), z = finite();
  return Vec3(x, y, z);
}

std::uint32_t ByteReader::count(std::size_t min_bytes_each) {
  const auto n = get<std::uint32_t>();
  if (min_bytes_each && n > (bytes_.size() - pos_) / min_bytes_each) fail("count larger than the data");
  return n;
}

void write_header(ByteWriter& w, const char (&magic)[8], std::uint32_t version) {
  w.put(magic);
  w.put(version);
  w.put(static_cast<std::uint32_t>(sizeof(btScalar)));
}

void read_header(ByteReader& r, const char (&magic)[8], std::uint32_t version, const std::string& what) {
  char got[8];
  r.get(got);
  if (std::memcmp(got, magic, sizeof got) != 0) r.fail("not a SODA " + what + " (bad magic)");
  if (r.get<std::uint32_t>() != version) r.fail("unsupported " + what + " version");
  if (r.get<std::uint32_t>() != sizeof(btScalar))
    r.fail(what + " precision differs from this build's (" + (sizeof(btScalar) == 8 ? "double" : "float") + ")");
}

namespace {

void write_quat(ByteWriter& w, const Quat& q) { w.put(q.w()), w.put(q.x()), w.put(q.y()), w.put(q.z()); }

Quat read_quat(ByteReader& r) {
  const double qw = r.finite(), qx = r.finite(), qy = r.finite(), qz = r.finite();
  return Quat(qw, qx, qy, qz);
}

// Kind, dimensions, hull points and (formats from WithoutUserData on)
// compound children.
void write_shape(ByteWriter& w, const Shape& s, BodyFormat format) {
  w.put(static_cast<std::uint8_t>(s.kind));
  w.vec3(s.half_extents);
  w.put(s.radius);
  w.put(s.height);
  w.put(static_cast<std::uint32_t>(s.points.size()));
  for (const Vec3& p : s.points) w.vec3(p);
  if (format < BodyFormat::WithoutUserData) return;
  w.put(static_cast<std::uint32_t>(s.children.size()));
  for (const CompoundChild& c : s.children) {
    write_shape(w, c.shape, format);
    w.vec3(c.position);
    write_quat(w, c.orientation);
  }
  if (format < BodyFormat::WithoutSensor) return;
  if (s.kind == ShapeKind::TriangleMesh) {
    w.count(s.mesh->file.size());
    for (char c : s.mesh->file) w.put(c);
    w.count(s.mesh->vertices.size());
    for (const Vec3& v : s.mesh->vertices) w.vec3(v);
    w.count(s.mesh->triangles.size());
    for (const auto& t : s.mesh->triangles) w.put(t[0]), w.put(t[1]), w.put(t[2]);
  } else if (s.kind == ShapeKind::Heightfield) {
    w.put(static_cast<std::int32_t>(s.heightfield->columns));
    w.put(static_cast<std::int32_t>(s.heightfield->rows));
    w.vec3(s.heightfield->spacing);
    w.count(s.heightfield->heights.size());
    for (double h : s.heightfield->heights) w.put(h);
  }
}

// A mesh's or heightfield's data as write_shape writes it (values checked
// by validation when a world is made, as every shape's).
void read_concave(ByteReader& r, Shape& s) {
  if (s.kind == ShapeKind::TriangleMesh) {
    auto mesh = std::make_shared<TriangleMeshData>();
    mesh->file.resize(r.count(1));
    for (char& c : mesh->file) c = r.get<char>();
    mesh->vertices.resize(r.count(24));
    for (Vec3& v : mesh->vertices) v = r.vec3();
    mesh->triangles.resize(r.count(12));
    for (auto& t : mesh->triangles) {
      for (std::uint32_t& i : t) i = r.get<std::uint32_t>();
      for (std::uint32_t i : t)
        if (i >= mesh->vertices.size()) r.fail("triangle index out of range");
    }
    if (mesh->triangles.empty()) r.fail("a triangle mesh without triangles");
    s.mesh = std::move(mesh);
  } else if (s.kind == ShapeKind::Heightfield) {
    auto hf = std::make_shared<HeightfieldData>();
    hf->columns = r.get<std::int32_t>();
    hf->rows = r.get<std::int32_t>();
    if (hf->columns < 2 || hf->rows < 2) r.fail("heightfield dimensions below 2");
    hf->spacing = r.vec3();
    hf->heights.resize(r.count(8));
    if (hf->heights.size() != static_cast<std::size_t>(hf->columns) * static_cast<std::size_t>(hf->rows))
      r.fail("heightfield heights do not match its dimensions");
    for (double& h : hf->heights) h = r.finite();
    s.heightfield = std::move(hf);
  }
}

Shape read_shape(ByteReader& r, BodyFormat format, bool in_compound) {
  Shape s;
  const auto kind = r.get<std::uint8_t>();
  if (kind > static_cast<std::uint8_t>(ShapeKind::Heightfield)) r.fail("unknown shape kind");
  s.kind = static_cast<ShapeKind>(kind);
  if (s.is_concave() && (in_compound || format < BodyFormat::WithoutSensor))
    r.fail(in_compound ? "a concave shape inside a compound" : "a mesh or heightfield in a format without them");
  if (s.kind == ShapeKind::Compound && (in_compound || format < BodyFormat::WithoutUserData))
    r.fail(in_compound ? "a compound inside a compound" : "a compound shape in a format without compounds");
  s.half_extents = r.vec3();
  s.radius = r.finite();
  s.height = r.finite();
  const std::uint32_t np = r.count(24);
  s.points.resize(np);
  for (Vec3& p : s.points) p = r.vec3();
  if (format < BodyFormat::WithoutUserData) return s;
  const std::uint32_t nc = r.count(kMinChildBytes);
  if (nc > 0 && s.kind != ShapeKind::Compound) r.fail("children in a shape that is not a compound");
  if (s.kind == ShapeKind::Compound && nc == 0) r.fail("a compound without children");
  s.children.resize(nc);
  for (CompoundChild& c : s.children) {
    c.shape = read_shape(r, format, true);
    c.position = r.vec3();
    c.orientation = read_quat(r);
  }
  if (format >= BodyFormat::WithoutSensor) read_concave(r, s);
  return s;
}

}  // namespace

std::string body_format_loss(const Body& d, BodyFormat format) {
  if (format < BodyFormat::WithoutCompounds &&
      (d.collision_group != kDefaultCollisionGroup || d.collision_mask != kAllCollisionGroups))
    return "its collision filter";
  if (format < BodyFormat::WithoutUserData && d.shape.kind == ShapeKind::Compound) return "its compound shape";
  if (format < BodyFormat::WithoutMeshes && d.user_data != 0) return "its user data";
  if (format < BodyFormat::WithoutSensor && d.shape.is_concave()) return std::string("its ") + shape_kind_name(d.shape.kind);
  if (format < BodyFormat::WithoutKinematic && d.sensor) return "its sensor flag";
  if (format < BodyFormat::WithoutFilterCommands && d.kinematic) return "its kinematic motion";
  if (format < BodyFormat::Current && !d.filter_commands.empty()) return "its collision filter inputs";
  return "";
}

void write_body(ByteWriter& w, const BodySnapshot& b, BodyFormat format) {
  const Body& d = b.description;
  w.put(d.id);
  // 0 dynamic, 1 static, 2 kinematic (a static that moves) followed by its
  // path: files and messages without kinematic bodies are as they were.
  w.put(static_cast<std::uint8_t>(d.kinematic ? 2 : d.is_static ? 1 : 0));
  if (d.kinematic) {
    w.put(static_cast<std::uint8_t>(d.path.loop));
    w.count(d.path.keys.size());
    for (const PathKey& k : d.path.keys) {
      w.put(k.time);
      w.vec3(k.position);
      w.put(k.orientation.w()), w.put(k.orientation.x()), w.put(k.orientation.y()), w.put(k.orientation.z());
    }
    w.count(d.commands.size());
    for (const KinematicCommand& c : d.commands) {
      w.put(c.step);
      w.put(static_cast<std::uint8_t>(c.teleport));
      w.vec3(c.pose.position);
      const Quat& q = c.pose.orientation;
      w.put(q.w()), w.put(q.x()), w.put(q.y()), w.put(q.z());
    }
    if (format >= BodyFormat::Current) {
      w.count(d.filter_commands.size());
      for (const FilterCommand& c : d.filter_commands) w.put(c.step), w.put(c.group), w.put(c.mask);
    }
  }
  write_shape(w, d.shape, format);
  w.put(d.mass), w.put(d.friction), w.put(d.restitution);
  w.vec3(d.position);
  w.put(d.orientation.w()), w.put(d.orientation.x()), w.put(d.orientation.y()), w.put(d.orientation.z());
  w.vec3(d.linear_velocity);
  w.vec3(d.angular_velocity);
  if (format >= BodyFormat::WithoutCompounds) w.put(d.collision_group), w.put(d.collision_mask);
  if (format >= BodyFormat::WithoutMeshes) w.put(d.user_data);
  if (format >= BodyFormat::WithoutKinematic) w.put(static_cast<std::uint8_t>(d.sensor));
  auto io = [&w](const auto& field) { w.put(field); };
  visit_state(io, b.state);
}

BodySnapshot read_body(ByteReader& r, BodyFormat format) {
  BodySnapshot b;
  Body& d = b.description;
  d.id = r.get<BodyId>();
  if (d.id > kMaxBodyId) r.fail("body id above kMaxBodyId");
  const auto is_static = r.get<std::uint8_t>();
  if (is_static > (format >= BodyFormat::WithoutFilterCommands ? 2 : 1)) r.fail("bad static flag");
  d.is_static = is_static >= 1;
  d.kinematic = is_static == 2;
  if (d.kinematic) {
    const auto loop = r.get<std::uint8_t>();
    if (loop > 1) r.fail("bad path loop flag");
    d.path.loop = loop == 1;
    const std::uint32_t nk = r.count(64);  // time, position, orientation: 8 doubles
    d.path.keys.resize(nk);
    for (PathKey& k : d.path.keys) {
      k.time = r.finite();
      k.position = r.vec3();
      const double kw = r.finite(), kx = r.finite(), ky = r.finite(), kz = r.finite();
      k.orientation = Quat(kw, kx, ky, kz);
    }
    for (std::size_t i = 1; i < d.path.keys.size(); ++i)
      if (!(d.path.keys[i].time > d.path.keys[i - 1].time)) r.fail("path times not ascending");
    const std::uint32_t nc = r.count(65);  // step, flag, position, orientation
    d.commands.resize(nc);
    for (KinematicCommand& c : d.commands) {
      c.step = r.get<std::int64_t>();
      const auto teleport = r.get<std::uint8_t>();
      if (teleport > 1) r.fail("bad kinematic command flag");
      c.teleport = teleport == 1;
      c.pose.position = r.vec3();
      const double cw = r.finite(), cx = r.finite(), cy = r.finite(), cz = r.finite();
      c.pose.orientation = Quat(cw, cx, cy, cz);
    }
    for (std::size_t i = 1; i < d.commands.size(); ++i)
      if (!(d.commands[i].step > d.commands[i - 1].step)) r.fail("kinematic command steps not ascending");
    if (format >= BodyFormat::Current) {
      const std::uint32_t nf = r.count(16);  // step, group, mask
      d.filter_commands.resize(nf);
      for (FilterCommand& c : d.filter_commands) {
        c.step = r.get<std::int64_t>();
        c.group = r.get<std::uint32_t>();
        c.mask = r.get<std::uint32_t>();
      }
      for (std::size_t i = 1; i < d.filter_commands.size(); ++i)
        if (!(d.filter_commands[i].step > d.filter_commands[i - 1].step))
          r.fail("kinematic filter command steps not ascending");
    }
  }
  d.shape = read_shape(r, format, false);
  d.mass = r.finite(), d.friction = r.finite(), d.restitution = r.finite();
  d.position = r.vec3();
  const double qw = r.finite(), qx = r.finite(), qy = r.finite(), qz = r.finite();
  d.orientation = Quat(qw, qx, qy, qz);
  d.linear_velocity = r.vec3();
  d.angular_velocity = r.vec3();
  if (format >= BodyFormat::WithoutCompounds) {
    d.collision_group = r.get<std::uint32_t>();
    d.collision_mask = r.get<std::uint32_t>();
  }
  if (format >= BodyFormat::WithoutMeshes) d.user_data = r.get<std::uint64_t>();
  if (format >= BodyFormat::WithoutKinematic) {
    const auto sensor = r.get<std::uint8_t>();
    if (sensor > 1) r.fail("bad sensor flag");
    d.sensor = sensor == 1;
  }
  if (!d.is_static && !(d.mass > 0)) r.fail("dynamic body without positive mass");
  BodyDynamicState& s = b.state;
  r.get(s.basis), r.get(s.origin), r.get(s.interpolation_basis), r.get(s.interpolation_origin);
  r.get(s.linear_velocity), r.get(s.angular_velocity);
  r.get(s.interpolation_linear_velocity), r.get(s.interpolation_angular_velocity);
  s.activation_state = r.get<std::int32_t>();
  if (s.activation_state < 1 || s.activation_state > 5) r.fail("bad activation state");
  s.deactivation_time = r.get<btScalar>();
  s.hit_fraction = r.get<btScalar>();
  return b;
}

void write_manifold(ByteWriter& w, const ManifoldState& m) {
  w.put(m.id0), w.put(m.id1);
  w.count(m.points.size());
  auto io = [&w](const auto& field) { w.put(field); };
  for (const ContactPointState& p : m.points) visit_point(io, p);
}

ManifoldState read_manifold(ByteReader& r) {
  ManifoldState m;
  m.id0 = r.get<BodyId>();
  m.id1 = r.get<BodyId>();
  if (!(m.id0 < m.id1) || m.id1 > kMaxBodyId) r.fail("manifold with bad body ids");
  const std::uint32_t np = r.get<std::uint32_t>();
  // 0: a border island solved in substeps can leave a manifold empty
  // (island_substeps.h); its holder must clear its own.
  if (np > 4) r.fail("manifold point count above 4");
  m.points.resize(np);
  auto io = [&r](auto& field) { r.get(field); };
  for (ContactPointState& p : m.points) visit_point(io, p);
  return m;
}

bool same_bits(const BodyDynamicState& a, const BodyDynamicState& b) {
  SameBits same;
  visit_state(same, a, b);
  return same.equal;
}

namespace {

void same_vec(SameBits& same, const Vec3& x, const Vec3& y) {
  same(x.x(), y.x()), same(x.y(), y.y()), same(x.z(), y.z());
}

bool same_shape(SameBits& same, const Shape& a, const Shape& b) {
  same(a.kind, b.kind);
  same_vec(same, a.half_extents, b.half_extents);
  same(a.radius, b.radius), same(a.height, b.height);
  if (a.points.size() != b.points.size() || a.children.size() != b.children.size()) return false;
  for (std::size_t i = 0; i < a.points.size(); ++i) same_vec(same, a.points[i], b.points[i]);
  for (std::size_t i = 0; i < a.children.size(); ++i) {
    const CompoundChild &x = a.children[i], &y = b.children[i];
    if (!same_shape(same, x.shape, y.shape)) return false;
    same_vec(same, x.position, y.position);
    same(x.orientation.w(), y.orientation.w()), same(x.orientation.x(), y.orientation.x());
    same(x.orientation.y(), y.orientation.y()), same(x.orientation.z(), y.orientation.z());
  }
  if (a.mesh != b.mesh) {  // shared data: the same pointer is the same mesh
    if (!a.mesh || !b.mesh || a.mesh->file != b.mesh->file || a.mesh->vertices.size() != b.mesh->vertices.size() ||
        a.mesh->triangles != b.mesh->triangles)
      return false;
    for (std::size_t i = 0; i < a.mesh->vertices.size(); ++i) same_vec(same, a.mesh->vertices[i], b.mesh->vertices[i]);
  }
  if (a.heightfield != b.heightfield) {
    if (!a.heightfield || !b.heightfield || a.heightfield->columns != b.heightfield->columns ||
        a.heightfield->rows != b.heightfield->rows || a.heightfield->heights.size() != b.heightfield->heights.size())
      return false;
    same_vec(same, a.heightfield->spacing, b.heightfield->spacing);
    for (std::size_t i = 0; i < a.heightfield->heights.size(); ++i) same(a.heightfield->heights[i], b.heightfield->heights[i]);
  }
  return same.equal;
}

}  // namespace

bool same_bits(const Body& a, const Body& b) {
  SameBits same;
  auto vec = [&](const Vec3& x, const Vec3& y) { same_vec(same, x, y); };
  same(a.id, b.id), same(a.is_static, b.is_static), same(a.kinematic, b.kinematic), same(a.path.loop, b.path.loop);
  if (a.path.keys.size() != b.path.keys.size()) return false;
  for (std::size_t i = 0; i < a.path.keys.size(); ++i) {
    const PathKey &x = a.path.keys[i], &y = b.path.keys[i];
    same(x.time, y.time);
    same_vec(same, x.position, y.position);
    same(x.orientation.w(), y.orientation.w()), same(x.orientation.x(), y.orientation.x());
    same(x.orientation.y(), y.orientation.y()), same(x.orientation.z(), y.orientation.z());
  }
  if (a.commands.size() != b.commands.size()) return false;
  for (std::size_t i = 0; i < a.commands.size(); ++i) {
    const KinematicCommand &x = a.commands[i], &y = b.commands[i];
    same(x.step, y.step), same(x.teleport, y.teleport);
    same_vec(same, x.pose.position, y.pose.position);
    same(x.pose.orientation.w(), y.pose.orientation.w()), same(x.pose.orientation.x(), y.pose.orientation.x());
    same(x.pose.orientation.y(), y.pose.orientation.y()), same(x.pose.orientation.z(), y.pose.orientation.z());
  }
  if (a.filter_commands.size() != b.filter_commands.size()) return false;
  for (std::size_t i = 0; i < a.filter_commands.size(); ++i) {
    const FilterCommand &x = a.filter_commands[i], &y = b.filter_commands[i];
    same(x.step, y.step), same(x.group, y.group), same(x.mask, y.mask);
  }
  if (!same_shape(same, a.shape, b.shape)) return false;
  same(a.mass, b.mass), same(a.friction, b.friction), same(a.restitution, b.restitution);
  vec(a.position, b.position);
  same(a.orientation.w(), b.orientation.w()), same(a.orientation.x(), b.orientation.x());
  same(a.orientation.y(), b.orientation.y()), same(a.orientation.z(), b.orientation.z());
  vec(a.linear_velocity, b.linear_velocity);
  vec(a.angular_velocity, b.angular_velocity);
  same(a.collision_group, b.collision_group), same(a.collision_mask, b.collision_mask);
  same(a.user_data, b.user_data), same(a.sensor, b.sensor);
  return same.equal;
}

bool same_bits(const ManifoldState& a, const ManifoldState& b) {
  if (a.id0 != b.id0 || a.id1 != b.id1 || a.points.size() != b.points.size()) return false;
  SameBits same;
  for (std::size_t i = 0; i < a.points.size() && same.equal; ++i) visit_point(same, a.points[i], b.points[i]);
  return same.equal;
}

}  // namespace soda

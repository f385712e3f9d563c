// WorldSnapshot <-> bytes, and the contact hash.
//
// Layout (little-endian, no padding): "SODAWSN1", u32 version, u32
// sizeof(btScalar), settings, i64 steps_done, u32 body count, bodies, u32
// manifold count, manifolds. Every read is bounds-checked; counts are checked
// against the bytes left before anything is allocated.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>
#include <type_traits>
#include <utility>

#include "soda/worlds/world_snapshot.h"

namespace soda {
namespace {

static_assert(std::endian::native == std::endian::little, "snapshot bytes are written in host order");

constexpr char kMagic[8] = {'S', 'O', 'D', 'A', 'W', 'S', 'N', '1'};
constexpr std::uint32_t kVersion = 1;
constexpr std::size_t kMinBodyBytes = 4 + 1 + 1 + 8 * 5 + 4;  // lower bound, for count checks
constexpr std::size_t kMinManifoldBytes = 4 + 4 + 4;

class Writer {
 public:
  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
    bytes.insert(bytes.end(), p, p + sizeof(T));
  }
  template <class T, std::size_t N>
  void put(const T (&a)[N]) {
    for (const T& v : a) put(v);
  }
  void vec3(const Vec3& v) { put(v.x()), put(v.y()), put(v.z()); }
  std::vector<std::uint8_t> bytes;
};

class Reader {
 public:
  explicit Reader(const std::vector<std::uint8_t>& b) : bytes_(b) {}
  [[noreturn]] void fail(const std::string& what) const {
    throw SnapshotFormatError("deserialize_snapshot: " + what + " at byte " + std::to_string(pos_) + " of " +
                              std::to_string(bytes_.size()));
  }
  template <class T>
  T get() {
    if (bytes_.size() - pos_ < sizeof(T)) fail("truncated");
    T v;
    std::memcpy(&v, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  template <class T, std::size_t N>
  void get(T (&a)[N]) {
    for (T& v : a) v = get<T>();
  }
  template <class T>
  void get(T& v) {
    v = get<T>();
  }
  double finite() {
    const double v = get<double>();
    if (!std::isfinite(v)) fail("non-finite number");
    return v;
  }
  Vec3 vec3() {
    const double x = finite(), y = finite(), z = finite();
    return Vec3(x, y, z);
  }
  std::uint32_t count(std::size_t min_bytes_each) {
    const auto n = get<std::uint32_t>();
    if (min_bytes_each && n > (bytes_.size() - pos_) / min_bytes_each) fail("count larger than the data");
    return n;
  }
  bool done() const { return pos_ == bytes_.size(); }

 private:
  const std::vector<std::uint8_t>& bytes_;
  std::size_t pos_ = 0;
};

void write_body(Writer& w, const BodySnapshot& b) {
  const Body& d = b.description;
  w.put(d.id);
  w.put(static_cast<std::uint8_t>(d.is_static));
  w.put(static_cast<std::uint8_t>(d.shape.kind));
  w.vec3(d.shape.half_extents);
  w.put(d.shape.radius);
  w.put(d.shape.height);
  w.put(static_cast<std::uint32_t>(d.shape.points.size()));
  for (const Vec3& p : d.shape.points) w.vec3(p);
  w.put(d.mass), w.put(d.friction), w.put(d.restitution);
  w.vec3(d.position);
  w.put(d.orientation.w()), w.put(d.orientation.x()), w.put(d.orientation.y()), w.put(d.orientation.z());
  w.vec3(d.linear_velocity);
  w.vec3(d.angular_velocity);
  const BodyDynamicState& s = b.state;
  w.put(s.basis), w.put(s.origin), w.put(s.interpolation_basis), w.put(s.interpolation_origin);
  w.put(s.linear_velocity), w.put(s.angular_velocity);
  w.put(s.interpolation_linear_velocity), w.put(s.interpolation_angular_velocity);
  w.put(s.activation_state), w.put(s.deactivation_time), w.put(s.hit_fraction);
}

BodySnapshot read_body(Reader& r) {
  BodySnapshot b;
  Body& d = b.description;
  d.id = r.get<BodyId>();
  if (d.id > kMaxBodyId) r.fail("body id above kMaxBodyId");
  const auto is_static = r.get<std::uint8_t>();
  if (is_static > 1) r.fail("bad static flag");
  d.is_static = is_static == 1;
  const auto kind = r.get<std::uint8_t>();
  if (kind > static_cast<std::uint8_t>(ShapeKind::ConvexHull)) r.fail("unknown shape kind");
  d.shape.kind = static_cast<ShapeKind>(kind);
  d.shape.half_extents = r.vec3();
  d.shape.radius = r.finite();
  d.shape.height = r.finite();
  const std::uint32_t np = r.count(24);
  d.shape.points.resize(np);
  for (Vec3& p : d.shape.points) p = r.vec3();
  d.mass = r.finite(), d.friction = r.finite(), d.restitution = r.finite();
  d.position = r.vec3();
  const double qw = r.finite(), qx = r.finite(), qy = r.finite(), qz = r.finite();
  d.orientation = Quat(qw, qx, qy, qz);
  d.linear_velocity = r.vec3();
  d.angular_velocity = r.vec3();
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

template <class Io, class P>
void visit_point(Io& io, P& p) {
  io(p.local_point_a), io(p.local_point_b), io(p.position_world_on_b), io(p.position_world_on_a);
  io(p.normal_world_on_b), io(p.distance), io(p.combined_friction), io(p.combined_rolling_friction);
  io(p.combined_spinning_friction), io(p.combined_restitution), io(p.part_id0), io(p.part_id1);
  io(p.index0), io(p.index1), io(p.contact_point_flags), io(p.applied_impulse), io(p.prev_rhs);
  io(p.applied_impulse_lateral1), io(p.applied_impulse_lateral2), io(p.contact_motion1);
  io(p.contact_motion2), io(p.contact_cfm), io(p.combined_contact_stiffness1), io(p.contact_erp);
  io(p.combined_contact_damping1), io(p.friction_cfm), io(p.lifetime), io(p.lateral_friction_dir1);
  io(p.lateral_friction_dir2);
}

}  // namespace

std::vector<std::uint8_t> serialize(const WorldSnapshot& s) {
  Writer w;
  w.put(kMagic);
  w.put(kVersion);
  w.put(static_cast<std::uint32_t>(sizeof(btScalar)));
  w.put(s.settings.dt), w.put(s.settings.substeps), w.put(s.settings.iterations);
  w.vec3(s.settings.gravity);
  w.put(s.settings.steps);
  w.put(s.steps_done);
  w.put(static_cast<std::uint32_t>(s.bodies.size()));
  for (const BodySnapshot& b : s.bodies) write_body(w, b);
  w.put(static_cast<std::uint32_t>(s.manifolds.size()));
  for (const ManifoldState& m : s.manifolds) {
    w.put(m.id0), w.put(m.id1);
    w.put(static_cast<std::uint32_t>(m.points.size()));
    auto io = [&w](const auto& field) { w.put(field); };
    for (const ContactPointState& p : m.points) visit_point(io, p);
  }
  return std::move(w.bytes);
}

WorldSnapshot deserialize_snapshot(const std::vector<std::uint8_t>& bytes) {
  Reader r(bytes);
  char magic[8];
  r.get(magic);
  if (std::memcmp(magic, kMagic, sizeof magic) != 0) r.fail("not a SODA world snapshot (bad magic)");
  if (r.get<std::uint32_t>() != kVersion) r.fail("unsupported snapshot version");
  if (r.get<std::uint32_t>() != sizeof(btScalar))
    r.fail(std::string("snapshot precision differs from this build's (") + (sizeof(btScalar) == 8 ? "double" : "float") + ")");
  WorldSnapshot s;
  s.settings.dt = r.finite();
  s.settings.substeps = r.get<int>();
  s.settings.iterations = r.get<int>();
  s.settings.gravity = r.vec3();
  s.settings.steps = r.get<int>();
  if (!(s.settings.dt > 0) || s.settings.substeps < 1 || s.settings.iterations < 1) r.fail("bad settings");
  s.steps_done = r.get<std::int64_t>();
  const std::uint32_t nb = r.count(kMinBodyBytes);
  s.bodies.reserve(nb);
  for (std::uint32_t i = 0; i < nb; ++i) {
    s.bodies.push_back(read_body(r));
    if (i > 0 && s.bodies[i].description.id <= s.bodies[i - 1].description.id)
      r.fail("bodies not sorted by id or duplicate id");
  }
  auto has_body = [&s](BodyId id) {
    auto it = std::lower_bound(s.bodies.begin(), s.bodies.end(), id,
                               [](const BodySnapshot& b, BodyId x) { return b.description.id < x; });
    return it != s.bodies.end() && it->description.id == id;
  };
  const std::uint32_t nm = r.count(kMinManifoldBytes);
  s.manifolds.reserve(nm);
  for (std::uint32_t i = 0; i < nm; ++i) {
    ManifoldState m;
    m.id0 = r.get<BodyId>();
    m.id1 = r.get<BodyId>();
    if (!(m.id0 < m.id1) || !has_body(m.id0) || !has_body(m.id1)) r.fail("manifold with bad body ids");
    if (i > 0 && !(std::make_pair(s.manifolds.back().id0, s.manifolds.back().id1) < std::make_pair(m.id0, m.id1)))
      r.fail("manifolds not sorted by (id0, id1)");
    const std::uint32_t np = r.get<std::uint32_t>();
    if (np < 1 || np > 4) r.fail("manifold point count not in 1..4");
    m.points.resize(np);
    auto io = [&r](auto& field) { r.get(field); };
    for (ContactPointState& p : m.points) visit_point(io, p);
    s.manifolds.push_back(std::move(m));
  }
  if (!r.done()) r.fail("trailing bytes");
  return s;
}

std::uint64_t contact_hash(std::vector<ManifoldState> manifolds) {
  std::sort(manifolds.begin(), manifolds.end(), [](const ManifoldState& a, const ManifoldState& b) {
    return a.id0 != b.id0 ? a.id0 < b.id0 : a.id1 < b.id1;
  });
  // FNV-1a over the same bytes serialize() writes.
  Writer w;
  std::uint64_t h = 1469598103934665603ull;
  for (const ManifoldState& m : manifolds) {
    w.bytes.clear();
    w.put(m.id0), w.put(m.id1);
    w.put(static_cast<std::uint32_t>(m.points.size()));
    auto io = [&w](const auto& field) { w.put(field); };
    for (const ContactPointState& p : m.points) visit_point(io, p);
    for (std::uint8_t byte : w.bytes) {
      h ^= byte;
      h *= 1099511628211ull;
    }
  }
  return h;
}

}  // namespace soda

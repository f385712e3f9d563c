// WorldSnapshot <-> bytes, and the contact hash.
//
// Layout (little-endian, no padding): "SODAWSN1", u32 version, u32
// sizeof(btScalar), settings, i64 steps_done, u32 body count, bodies, u32
// manifold count, manifolds; version 12 (written only for a snapshot with
// joints) then u32 joint count, joints. Bodies as write_body writes them
// (collision filter, compound children, user data). Every read is bounds-checked; counts are checked
// against the bytes left before anything is allocated.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>
#include <type_traits>
#include <utility>

#include "soda/scene/fnv1a.h"
#include "soda/worlds/snapshot_parts.h"
#include "soda/worlds/value_codec.h"
#include "soda/worlds/world_snapshot.h"

namespace soda {
namespace {

constexpr char kMagic[8] = {'S', 'O', 'D', 'A', 'W', 'S', 'N', '1'};
// 3 and 4: bodies carry their collision filter and compound children (1
// and 2 before); 5 and 6: and their user data; 7 and 8: and triangle mesh
// and heightfield data; 9 and 10: and their sensor flag; 11 and 12: and a
// kinematic body's collision filter inputs. Only these two are read.
constexpr std::uint32_t kVersion = 11;        // no joints
constexpr std::uint32_t kJointsVersion = 12;  // with joints
std::vector<std::uint8_t> joint_bytes(const JointSnapshot& j) {
  ByteWriter w;
  write_joint(w, j);
  return std::move(w.bytes);
}

[[noreturn]] void raise_snapshot_error(const std::string& message) { throw SnapshotFormatError(message); }

}  // namespace

bool same_bits(const WorldSnapshot& a, const WorldSnapshot& b) {
  const SceneSettings &x = a.settings, &y = b.settings;
  auto eq = [](const auto& u, const auto& v) { return std::memcmp(&u, &v, sizeof u) == 0; };
  if (!eq(x.dt, y.dt) || x.substeps != y.substeps || x.iterations != y.iterations || !eq(x.gravity.x(), y.gravity.x()) ||
      !eq(x.gravity.y(), y.gravity.y()) || !eq(x.gravity.z(), y.gravity.z()) || x.steps != y.steps ||
      a.steps_done != b.steps_done || a.bodies.size() != b.bodies.size() || a.manifolds.size() != b.manifolds.size())
    return false;
  for (std::size_t i = 0; i < a.bodies.size(); ++i)
    if (!same_bits(a.bodies[i].state, b.bodies[i].state) || !same_bits(a.bodies[i].description, b.bodies[i].description))
      return false;
  for (std::size_t i = 0; i < a.manifolds.size(); ++i)
    if (!same_bits(a.manifolds[i], b.manifolds[i])) return false;
  if (a.joints.size() != b.joints.size()) return false;
  for (std::size_t i = 0; i < a.joints.size(); ++i)
    if (joint_bytes(a.joints[i]) != joint_bytes(b.joints[i])) return false;
  return true;
}

std::vector<std::uint8_t> serialize(const WorldSnapshot& s) {
  ByteWriter w;
  write_header(w, kMagic, s.joints.empty() ? kVersion : kJointsVersion);
  w.put(s.settings.dt), w.put(s.settings.substeps), w.put(s.settings.iterations);
  w.vec3(s.settings.gravity);
  w.put(s.settings.steps);
  w.put(s.steps_done);
  w.put(static_cast<std::uint32_t>(s.bodies.size()));
  for (const BodySnapshot& b : s.bodies) write_body(w, b);
  w.put(static_cast<std::uint32_t>(s.manifolds.size()));
  for (const ManifoldState& m : s.manifolds) write_manifold(w, m);
  if (!s.joints.empty()) {
    w.put(static_cast<std::uint32_t>(s.joints.size()));
    for (const JointSnapshot& j : s.joints) write_joint(w, j);
  }
  return std::move(w.bytes);
}

namespace {

// whole: every manifold and joint names bodies the snapshot holds, and
// manifolds are strictly ordered; else a world's part (snapshot_parts.h).
WorldSnapshot read_snapshot(const std::vector<std::uint8_t>& bytes, bool whole, const char* what) {
  ByteReader r(bytes, what, raise_snapshot_error);
  // The header, kVersion or kJointsVersion (read_header takes one version).
  char magic[8];
  r.get(magic);
  if (std::memcmp(magic, kMagic, sizeof magic) != 0) r.fail("not a SODA world snapshot (bad magic)");
  const auto version = r.get<std::uint32_t>();
  if (version != kVersion && version != kJointsVersion) r.fail("unsupported world snapshot version");
  if (r.get<std::uint32_t>() != sizeof(btScalar))
    r.fail(std::string("world snapshot precision differs from this build's (") +
           (sizeof(btScalar) == 8 ? "double" : "float") + ")");
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
    ManifoldState m = read_manifold(r);
    if (whole && (!has_body(m.id0) || !has_body(m.id1))) r.fail("manifold with bad body ids");
    if (i > 0) {
      const auto before = std::make_pair(s.manifolds.back().id0, s.manifolds.back().id1);
      const auto here = std::make_pair(m.id0, m.id1);
      if (whole ? !(before < here) : here < before) r.fail("manifolds not sorted by (id0, id1)");
    }
    s.manifolds.push_back(std::move(m));
  }
  if (version == kJointsVersion) {
    const std::uint32_t nj = r.count(kMinJointBytes);
    if (nj == 0) r.fail("a version " + std::to_string(kJointsVersion) + " snapshot without joints");
    s.joints.reserve(nj);
    for (std::uint32_t i = 0; i < nj; ++i) {
      JointSnapshot j = read_joint(r);
      if (whole && (!has_body(j.description.body_a) || !has_body(j.description.body_b)))
        r.fail("joint with bad body ids");
      if (i > 0 && !(s.joints.back().description.id < j.description.id)) r.fail("joints not sorted by id");
      s.joints.push_back(std::move(j));
    }
  }
  if (!r.done()) r.fail("trailing bytes");
  return s;
}

}  // namespace

WorldSnapshot deserialize_snapshot(const std::vector<std::uint8_t>& bytes) {
  return read_snapshot(bytes, true, "deserialize_snapshot");
}

WorldSnapshot deserialize_part_snapshot(const std::vector<std::uint8_t>& bytes) {
  return read_snapshot(bytes, false, "deserialize_part_snapshot");
}

Scene scene_of(const WorldSnapshot& snapshot) {
  Scene scene;
  scene.settings = snapshot.settings;
  scene.bodies.reserve(snapshot.bodies.size());
  for (const BodySnapshot& b : snapshot.bodies) scene.bodies.push_back(b.description);
  for (const JointSnapshot& j : snapshot.joints) scene.joints.push_back(j.description);
  return scene;
}

std::uint64_t contact_hash(std::vector<ManifoldState> manifolds) {
  std::sort(manifolds.begin(), manifolds.end(), [](const ManifoldState& a, const ManifoldState& b) {
    return a.id0 != b.id0 ? a.id0 < b.id0 : a.id1 < b.id1;
  });
  // FNV-1a over the same bytes serialize() writes.
  ByteWriter w;
  std::uint64_t h = kFnv1aOffset;
  for (const ManifoldState& m : manifolds) {
    w.bytes.clear();
    write_manifold(w, m);
    fnv1a_mix(h, w.bytes.data(), w.bytes.size());
  }
  return h;
}

}  // namespace soda

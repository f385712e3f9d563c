// Checkpoint files (checkpoint.h, docs/checkpoints.md).
//
// Layout (little-endian, no padding):
//   header   magic "SODACKPT", u32 version, u32 sizeof(btScalar), i64 step,
//            u32 bodies, u32 manifolds, u32 inputs, u32 retired ids,
//            u64 body length L                                  (48 bytes)
//   body     settings, body records, manifold records, input records,
//            retired ids, from version 8 joints                 (L bytes)
//   trailer  u64 FNV-1a of the 48 + L bytes before it
// The first 16 bytes (magic, version, precision) keep their place in every
// version, so that any version is recognised and refused by name.
#include "soda/runtime/checkpoint.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "soda/runtime/simulation.h"
#include "soda/scene/fnv1a.h"
#include "soda/runtime/user_input.h"
#include "soda/worlds/value_codec.h"

namespace soda {
namespace {

constexpr char kCheckpointMagic[8] = {'S', 'O', 'D', 'A', 'C', 'K', 'P', 'T'};
constexpr std::size_t kIdentityBytes = 16;  // magic, version, precision: the same in every version
constexpr std::size_t kHeaderBytes = 48;
constexpr std::size_t kChecksumBytes = 8;

const char* precision_name(std::uint32_t scalar_bytes) {
  return scalar_bytes == 8 ? "double" : scalar_bytes == 4 ? "float" : "unknown";
}

template <class T>
T load(const std::vector<std::uint8_t>& bytes, std::size_t at) {
  T v;
  std::memcpy(&v, bytes.data() + at, sizeof v);
  return v;
}

[[noreturn]] void raise_checkpoint_error(const std::string& message) { throw CheckpointError(message); }

[[noreturn]] void refuse(const std::string& source, const std::string& why) {
  throw CheckpointError("checkpoint " + source + ": " + why);
}

// The first version whose inputs have a value and user data, and kinds
// after apply_impulse.
constexpr std::uint32_t kSettersVersion = 4;

// The first version with kinematic bodies (body records of type 2, their
// commands) and the pose inputs (an orientation in every input record).
constexpr std::uint32_t kKinematicVersion = 7;

// The first version with joints (a joint count and joint records after the
// retired ids).
constexpr std::uint32_t kJointsVersion = 8;

// The first version with joint inputs (kind 11, a joint id in every input
// record).
constexpr std::uint32_t kJointInputsVersion = 9;

// The first version with added joints (kind 12, a joint record after the
// input record) and joint motor inputs (kind 13, a motor in every input
// record).
constexpr std::uint32_t kAddJointVersion = 10;

// The first version with collision filter inputs (kind 14, its group and
// mask after the input record) and retired joint ids (after the joints).
constexpr std::uint32_t kFilterInputVersion = 11;

// The first version whose kinematic body records carry their collision
// filter inputs (after their commands).
constexpr std::uint32_t kKinematicFilterVersion = 12;

// The newest input kind a version knows.
UserInput::Kind last_kind(std::uint32_t version) {
  if (version >= kFilterInputVersion) return UserInput::Kind::SetCollisionFilter;
  if (version >= kAddJointVersion) return UserInput::Kind::SetJointMotor;
  if (version >= kJointInputsVersion) return UserInput::Kind::RemoveJoint;
  if (version >= kKinematicVersion) return UserInput::Kind::SetKinematicTarget;
  return version >= kSettersVersion ? UserInput::Kind::SetUserData : UserInput::Kind::ApplyImpulse;
}

// How a version writes a body record: 1 without a collision filter, 2
// without compound children, 3 without user data, 4 without triangle mesh
// and heightfield data, 5 without the sensor flag, 6 without kinematic
// bodies, 7 to 11 without a kinematic body's filter inputs.
BodyFormat body_format(std::uint32_t version) {
  if (version >= kKinematicFilterVersion) return BodyFormat::Current;
  if (version >= kKinematicVersion) return BodyFormat::WithoutFilterCommands;
  switch (version) {
    case 1: return BodyFormat::WithoutFilter;
    case 2: return BodyFormat::WithoutCompounds;
    case 3: return BodyFormat::WithoutUserData;
    case 4: return BodyFormat::WithoutMeshes;
    case 5: return BodyFormat::WithoutSensor;
    default: return BodyFormat::WithoutKinematic;
  }
}

// Input records: u8 kind, i64 step, u32 id, linear and angular as 3 f64 each;
// from version 4: f64 value, u64 user data; from version 7: the
// orientation as 4 f64 (w, x, y, z); from version 9: u32 joint; from
// version 10: the motor as u8 on, f64 velocity, f64 max impulse, i32 axis;
// an added body's record (write_body, its raw state unused) or, from
// version 10, an added joint's (write_joint, not broken) follows; from
// version 11, a collision filter input's u32 group and u32 mask.
void write_input(ByteWriter& w, const UserInput& in, std::uint32_t version) {
  w.put(static_cast<std::uint8_t>(in.kind));
  w.put(in.step);
  w.put(in.id);
  w.vec3(in.linear);
  w.vec3(in.angular);
  if (version >= kSettersVersion) w.put(in.value), w.put(in.user_data);
  if (version >= kKinematicVersion)
    w.put(in.orientation.w()), w.put(in.orientation.x()), w.put(in.orientation.y()), w.put(in.orientation.z());
  if (version >= kJointInputsVersion) w.put(in.joint);
  if (version >= kAddJointVersion) {
    w.put(static_cast<std::uint8_t>(in.motor.on));
    w.put(in.motor.velocity), w.put(in.motor.max_impulse);
    w.put(static_cast<std::int32_t>(in.motor.axis));
  }
  if (in.kind == UserInput::Kind::AddBody)
    write_body(w, BodySnapshot{in.body, BodyDynamicState{}}, body_format(version));
  if (in.kind == UserInput::Kind::AddJoint) write_joint(w, JointSnapshot{in.added_joint, false});
  if (in.kind == UserInput::Kind::SetCollisionFilter) w.put(in.collision_group), w.put(in.collision_mask);
}

UserInput read_input(ByteReader& r, std::uint32_t version) {
  UserInput in;
  const auto kind = r.get<std::uint8_t>();
  if (kind > static_cast<std::uint8_t>(last_kind(version)) ||
      std::string(input_kind_name(static_cast<UserInput::Kind>(kind))) == "unknown")
    r.fail("unknown input kind " + std::to_string(kind) + " for version " + std::to_string(version));
  in.kind = static_cast<UserInput::Kind>(kind);
  in.step = r.get<std::int64_t>();
  in.id = r.get<BodyId>();
  if (in.id > kMaxBodyId) r.fail("input naming a body id above kMaxBodyId");
  in.linear = r.vec3();
  in.angular = r.vec3();
  if (version >= kSettersVersion) {
    in.value = r.get<double>();
    in.user_data = r.get<std::uint64_t>();
    if (version >= kKinematicVersion) {
      const double qw = r.get<double>(), qx = r.get<double>(), qy = r.get<double>(), qz = r.get<double>();
      in.orientation = Quat(qw, qx, qy, qz);
    }
    if (version >= kJointInputsVersion) {
      in.joint = r.get<JointId>();
      if (in.joint > kMaxJointId) r.fail("input naming a joint id above kMaxJointId");
    }
    if (version >= kAddJointVersion) {
      const auto on = r.get<std::uint8_t>();
      if (on > 1) r.fail("bad motor flag");
      in.motor.on = on == 1;
      in.motor.velocity = r.get<double>(), in.motor.max_impulse = r.get<double>();
      in.motor.axis = r.get<std::int32_t>();
    }
    if (const std::string why = check_input_value(in); !why.empty())
      r.fail("an input to " + describe(in) + ": " + why);
  }
  if (in.kind == UserInput::Kind::AddBody) {
    in.body = read_body(r, body_format(version)).description;
    if (in.body.is_static) r.fail("an input adding a static body");
  }
  if (in.kind == UserInput::Kind::AddJoint) {
    const JointSnapshot j = read_joint(r);
    if (j.broken || j.description.id != in.joint) r.fail("an input adding joint " + std::to_string(in.joint) +
                                                         " with a broken joint record or another id");
    in.added_joint = j.description;
  }
  if (in.kind == UserInput::Kind::SetCollisionFilter) {
    in.collision_group = r.get<std::uint32_t>();
    in.collision_mask = r.get<std::uint32_t>();
  }
  return in;
}

// Checks the header and the trailer (everything but the body's fields).
CheckpointHeader check_frame(const std::vector<std::uint8_t>& bytes, const std::string& source) {
  const std::size_t size = bytes.size();
  const std::size_t compared = std::min(size, sizeof kCheckpointMagic);
  if (size == 0 || std::memcmp(bytes.data(), kCheckpointMagic, compared) != 0)
    refuse(source, size == 0 ? "empty (0 bytes)" : "not a SODA checkpoint (its first bytes are not \"SODACKPT\")");
  if (size < kIdentityBytes)
    refuse(source, "truncated: " + std::to_string(size) + " bytes, a checkpoint header takes " +
                       std::to_string(kHeaderBytes));
  CheckpointHeader h;
  h.version = load<std::uint32_t>(bytes, 8);
  h.scalar_bytes = load<std::uint32_t>(bytes, 12);
  if (h.version < kOldestCheckpointVersion || h.version > kCheckpointVersion)
    refuse(source, "format version " + std::to_string(h.version) + "; this build reads versions " +
                       std::to_string(kOldestCheckpointVersion) + " to " + std::to_string(kCheckpointVersion));
  if (h.scalar_bytes != sizeof(btScalar))
    refuse(source, std::string("written by a ") + precision_name(h.scalar_bytes) + "-precision build (btScalar of " +
                       std::to_string(h.scalar_bytes) + " bytes); this is the " + precision_name(sizeof(btScalar)) +
                       "-precision build, and a checkpoint holds btScalar bits: resume it with the build that "
                       "wrote it (soda" + (h.scalar_bytes == 8 ? "-double" : "") + ")");
  if (size < kHeaderBytes + kChecksumBytes)
    refuse(source, "truncated: " + std::to_string(size) + " bytes, a checkpoint takes at least " +
                       std::to_string(kHeaderBytes + kChecksumBytes));
  h.step = load<std::int64_t>(bytes, 16);
  h.bodies = load<std::uint32_t>(bytes, 24);
  h.manifolds = load<std::uint32_t>(bytes, 28);
  h.inputs = load<std::uint32_t>(bytes, 32);
  h.retired_ids = load<std::uint32_t>(bytes, 36);
  const auto length = load<std::uint64_t>(bytes, 40);
  const std::uint64_t expected = length + kHeaderBytes + kChecksumBytes;
  if (length > size || expected != size)
    refuse(source, (size < expected || length > size ? "truncated: " : "trailing bytes: ") + std::to_string(size) +
                       " bytes, its header announces " +
                       (length > size ? "a body of " + std::to_string(length) + " bytes" : std::to_string(expected)));
  const std::uint64_t stored = load<std::uint64_t>(bytes, size - kChecksumBytes);
  const std::uint64_t computed = fnv1a(bytes.data(), size - kChecksumBytes);
  if (stored != computed) {
    char why[160];
    std::snprintf(why, sizeof why, "damaged: the checksum of its bytes is %016llx, the file says %016llx",
                  static_cast<unsigned long long>(computed), static_cast<unsigned long long>(stored));
    refuse(source, why);
  }
  if (h.step < 0) refuse(source, "negative step " + std::to_string(h.step));
  return h;
}

}  // namespace

std::vector<std::uint8_t> encode_checkpoint(const SimulationSnapshot& snapshot) {
  return encode_checkpoint(snapshot, kCheckpointVersion);
}

std::vector<std::uint8_t> encode_checkpoint(const SimulationSnapshot& snapshot, std::uint32_t version) {
  if (version < kOldestCheckpointVersion || version > kCheckpointVersion)
    throw CheckpointError("encode_checkpoint: no checkpoint format version " + std::to_string(version));
  const WorldSnapshot& s = snapshot.state;
  const BodyFormat format = body_format(version);
  const std::string cannot = "encode_checkpoint: version " + std::to_string(version) + " cannot hold ";
  for (const BodySnapshot& b : s.bodies)
    if (const std::string what = body_format_loss(b.description, format); !what.empty())
      throw CheckpointError(cannot + "body " + std::to_string(b.description.id) + " (" + what + ")");
  for (const UserInput& in : snapshot.inputs)
    if (in.kind > last_kind(version) ||
        (in.kind == UserInput::Kind::AddBody && !body_format_loss(in.body, format).empty()))
      throw CheckpointError(cannot + "the input to " + describe(in));
  if (version < kFilterInputVersion && !snapshot.retired_joint_ids.empty())
    throw CheckpointError(cannot + "the ids of joints removed before its step (joint " +
                          std::to_string(snapshot.retired_joint_ids.front()) + "; from version " +
                          std::to_string(kFilterInputVersion) + ")");
  if (version < kJointsVersion && !s.joints.empty())
    throw CheckpointError(cannot + "joint " + std::to_string(s.joints.front().description.id) + " (" +
                          std::to_string(s.joints.size()) + " joints; joints from version " +
                          std::to_string(kJointsVersion) + ")");
  ByteWriter w;
  write_header(w, kCheckpointMagic, version);
  w.put(s.steps_done);
  w.count(s.bodies.size());
  w.count(s.manifolds.size());
  w.count(snapshot.inputs.size());
  w.count(snapshot.retired_ids.size());
  w.put(std::uint64_t{0});  // the body's length, below
  w.put(s.settings.dt), w.put(s.settings.substeps), w.put(s.settings.iterations);
  w.vec3(s.settings.gravity);
  w.put(s.settings.steps);
  for (const BodySnapshot& b : s.bodies) write_body(w, b, format);
  for (const ManifoldState& m : s.manifolds) write_manifold(w, m);
  for (const UserInput& in : snapshot.inputs) write_input(w, in, version);
  for (BodyId id : snapshot.retired_ids) w.put(id);
  if (version >= kJointsVersion) {
    w.count(s.joints.size());
    for (const JointSnapshot& j : s.joints) write_joint(w, j);
  }
  if (version >= kFilterInputVersion) {
    w.count(snapshot.retired_joint_ids.size());
    for (JointId id : snapshot.retired_joint_ids) w.put(id);
  }
  const std::uint64_t length = w.bytes.size() - kHeaderBytes;
  std::memcpy(w.bytes.data() + 40, &length, sizeof length);
  w.put(fnv1a(w.bytes.data(), w.bytes.size()));
  return std::move(w.bytes);
}

CheckpointHeader checkpoint_header(const std::vector<std::uint8_t>& bytes, const std::string& source) {
  return check_frame(bytes, source);
}

SimulationSnapshot decode_checkpoint(const std::vector<std::uint8_t>& bytes, const std::string& source) {
  const CheckpointHeader h = check_frame(bytes, source);
  ByteReader r(bytes, "checkpoint " + source, raise_checkpoint_error);
  for (std::size_t i = 0; i < kHeaderBytes; ++i) r.get<std::uint8_t>();  // checked above
  const BodyFormat format = body_format(h.version);
  SimulationSnapshot out;
  WorldSnapshot& s = out.state;
  s.steps_done = h.step;
  s.settings.dt = r.finite();
  s.settings.substeps = r.get<int>();
  s.settings.iterations = r.get<int>();
  s.settings.gravity = r.vec3();
  s.settings.steps = r.get<int>();
  if (!(s.settings.dt > 0) || s.settings.substeps < 1 || s.settings.iterations < 1) r.fail("bad settings");
  // No reserve from the header's counts: every element read is bytes the
  // file has, so memory follows the file's size.
  for (std::uint32_t i = 0; i < h.bodies; ++i) {
    s.bodies.push_back(read_body(r, format));
    if (i > 0 && s.bodies[i].description.id <= s.bodies[i - 1].description.id)
      r.fail("bodies not sorted by id or a duplicate id");
  }
  auto has_body = [&s](BodyId id) {
    auto it = std::lower_bound(s.bodies.begin(), s.bodies.end(), id,
                               [](const BodySnapshot& b, BodyId x) { return b.description.id < x; });
    return it != s.bodies.end() && it->description.id == id;
  };
  for (std::uint32_t i = 0; i < h.manifolds; ++i) {
    ManifoldState m = read_manifold(r);
    if (!has_body(m.id0) || !has_body(m.id1)) r.fail("a manifold naming a body not in the checkpoint");
    if (i > 0 && !(std::make_pair(s.manifolds.back().id0, s.manifolds.back().id1) < std::make_pair(m.id0, m.id1)))
      r.fail("manifolds not sorted by (id0, id1)");
    s.manifolds.push_back(std::move(m));
  }
  for (std::uint32_t i = 0; i < h.inputs; ++i) {
    UserInput in = read_input(r, h.version);
    if (in.step < h.step) r.fail("an input at step " + std::to_string(in.step) + ", before the checkpoint's step");
    if (!out.inputs.empty() && in.step < out.inputs.back().step) r.fail("inputs not in step order");
    in.sequence = i;
    out.inputs.push_back(std::move(in));
  }
  for (std::uint32_t i = 0; i < h.retired_ids; ++i) {
    const BodyId id = r.get<BodyId>();
    if (id > kMaxBodyId) r.fail("a retired id above kMaxBodyId");
    if (!out.retired_ids.empty() && id <= out.retired_ids.back()) r.fail("retired ids not ascending");
    out.retired_ids.push_back(id);
  }
  if (h.version >= kJointsVersion) {
    const std::uint32_t joints = r.count(kMinJointBytes);
    for (std::uint32_t i = 0; i < joints; ++i) {
      JointSnapshot j = read_joint(r);
      if (!has_body(j.description.body_a) || !has_body(j.description.body_b) ||
          j.description.body_a == j.description.body_b)
        r.fail("joint " + std::to_string(j.description.id) + " naming a body not in the checkpoint");
      if (!s.joints.empty() && !(s.joints.back().description.id < j.description.id))
        r.fail("joints not sorted by id or a duplicate id");
      s.joints.push_back(std::move(j));
    }
  }
  if (h.version >= kFilterInputVersion) {
    const std::uint32_t retired = r.count(sizeof(JointId));
    for (std::uint32_t i = 0; i < retired; ++i) {
      const JointId id = r.get<JointId>();
      if (id > kMaxJointId) r.fail("a retired joint id above kMaxJointId");
      if (!out.retired_joint_ids.empty() && id <= out.retired_joint_ids.back())
        r.fail("retired joint ids not ascending");
      auto held = std::lower_bound(s.joints.begin(), s.joints.end(), id,  // joints: ascending ids (above)
                                   [](const JointSnapshot& j, JointId x) { return j.description.id < x; });
      if (held != s.joints.end() && held->description.id == id)
        r.fail("joint " + std::to_string(id) + " both held and retired");
      out.retired_joint_ids.push_back(id);
    }
  }
  r.get<std::uint64_t>();  // the checksum, checked above
  if (!r.done()) r.fail("bytes left after the last field");
  return out;
}

std::uint64_t write_checkpoint(const SimulationSnapshot& snapshot, const std::string& path) {
  const std::vector<std::uint8_t> bytes = encode_checkpoint(snapshot);
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) refuse(path, std::string("cannot write ") + tmp + " (" + std::strerror(errno) + ")");
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) {
      std::remove(tmp.c_str());
      refuse(path, "cannot write " + tmp + " (disk full?)");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::remove(tmp.c_str());
    refuse(path, "cannot rename " + tmp + " to it (" + ec.message() + ")");
  }
  return bytes.size();
}

SimulationSnapshot read_checkpoint(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) refuse(path, std::string("cannot open (") + std::strerror(errno) + ")");
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) refuse(path, "cannot read its size (" + ec.message() + ")");
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (static_cast<std::uintmax_t>(in.gcount()) != size) refuse(path, "cannot read it whole");
  return decode_checkpoint(bytes, path);
}

}  // namespace soda

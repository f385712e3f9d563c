// worlds/ — one territory's physics. This header: the byte encoding of the
// values worlds exchange (bodies with their raw state, manifolds), shared by
// snapshots (world_snapshot.h) and the runtime's messages.
//
// Layout: little-endian host order (checked at compile time), no padding,
// btScalar fields in this build's precision. Every read is bounds-checked and
// every count is checked against the bytes left before anything is allocated:
// malformed bytes throw, never read out of bounds.
#pragma once

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "soda/worlds/world_snapshot.h"

namespace soda {

/// Appends values as raw bytes.
class ByteWriter {
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
  void count(std::size_t n) { put(static_cast<std::uint32_t>(n)); }

  std::vector<std::uint8_t> bytes;
};

/// Reads values back; every failure calls `raise(message)`, which must throw
/// (the message names `context`, the reason and the byte offset).
class ByteReader {
 public:
  using Raise = void (*)(const std::string& message);
  ByteReader(const std::vector<std::uint8_t>& bytes, std::string context, Raise raise)
      : bytes_(bytes), context_(std::move(context)), raise_(raise) {}

  [[noreturn]] void fail(const std::string& what) const;
  template <class T>
  T get() {
    static_assert(std::is_trivially_copyable_v<T>);
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
  /// A finite double.
  double finite();
  Vec3 vec3();
  /// A u32 count, checked against the bytes left (each item >= min_bytes_each).
  std::uint32_t count(std::size_t min_bytes_each);
  bool done() const { return pos_ == bytes_.size(); }

 private:
  const std::vector<std::uint8_t>& bytes_;
  std::size_t pos_ = 0;
  std::string context_;
  Raise raise_;
};

/// The header every SODA byte format begins with: an 8-byte magic, a u32
/// version and a u32 sizeof(btScalar) (the precision of the build).
void write_header(ByteWriter& w, const char (&magic)[8], std::uint32_t version);
/// Reads and checks it; fails with "not a SODA <what> (bad magic)",
/// "unsupported <what> version" or "<what> precision differs from this
/// build's (float|double)".
void read_header(ByteReader& r, const char (&magic)[8], std::uint32_t version, const std::string& what);

/// Lower bounds of encoded sizes, for count checks.
inline constexpr std::size_t kMinBodyBytes = 4 + 1 + 1 + 8 * 5 + 4;
inline constexpr std::size_t kMinManifoldBytes = 4 + 4 + 4;
/// A compound's child: its shape (kind, dimensions, counts) and pose.
inline constexpr std::size_t kMinChildBytes = 1 + 8 * 5 + 4 + 4 + 8 * 7;

/// How a body record is written, oldest first: WithoutFilter (no
/// collision group and mask: the body reads back with the default filter),
/// WithoutCompounds (no child count after the hull points), WithoutUserData
/// (no user data after the collision filter: it reads back as 0),
/// WithoutMeshes (no triangle mesh or heightfield data after a shape's
/// children: such shapes cannot be written), WithoutSensor (no sensor flag
/// after the user data: not a sensor), WithoutKinematic (no kinematic
/// bodies: static byte 2 and its path and commands), Current.
enum class BodyFormat {
  WithoutFilter,
  WithoutCompounds,
  WithoutUserData,
  WithoutMeshes,
  WithoutSensor,
  WithoutKinematic,
  WithoutFilterCommands,
  Current
};
/// A body: description (shape, mass, friction, ..., collision filter, user
/// data) and raw state. An older `format` leaves out what it has no field
/// for; the caller checks that the body needs none of it (body_format_loss).
void write_body(ByteWriter& w, const BodySnapshot& body, BodyFormat format = BodyFormat::Current);
/// What of `body` `format` cannot hold ("" if nothing): a collision filter
/// other than the default, a compound shape, user data other than 0, a sensor,
/// a kinematic body, a kinematic body's collision filter inputs.
std::string body_format_loss(const Body& body, BodyFormat format);
/// Checks ids, flags, shape kind, finite description numbers, activation state.
BodySnapshot read_body(ByteReader& r, BodyFormat format = BodyFormat::Current);

/// A manifold: ids and every field of every point.
void write_manifold(ByteWriter& w, const ManifoldState& manifold);
/// Checks id0 < id1 and 1..4 points.
ManifoldState read_manifold(ByteReader& r);

/// A joint: its description (every field of scene.h's Joint) and whether
/// it has broken.
inline constexpr std::size_t kMinJointBytes =
    4 + 1 + 4 + 4 + 2 * 7 * 8 + 1 + 8 + 1 + 4 * 8 + 1 + 2 * 8 + 3 * 8 + 36 * 8 + 1;
void write_joint(ByteWriter& w, const JointSnapshot& joint);
/// Checks the kind, flags, finite numbers and a breaking impulse > 0.
JointSnapshot read_joint(ByteReader& r);

/// True if the two encode to the same bytes: every field bit for bit (NaNs
/// by their bits, -0 differs from 0).
bool same_bits(const BodyDynamicState& a, const BodyDynamicState& b);
bool same_bits(const ManifoldState& a, const ManifoldState& b);
/// A body description, as write_body encodes it.
bool same_bits(const Body& a, const Body& b);

}  // namespace soda

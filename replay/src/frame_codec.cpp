// Keyframe and delta chunks (docs/replay-format.md, "KEYF", "DELT").
#include <cmath>
#include <string>

#include "byte_io.h"
#include "replay_codec.h"

namespace soda::replay {
namespace {

constexpr std::uint8_t kHasMap = 1;
constexpr std::uint8_t kHasHash = 2;
// A keyframe's population byte (version 2).
constexpr std::uint8_t kHeaderBodies = 0;  // the header's dynamic bodies
constexpr std::uint8_t kListedBodies = 1;  // the ids listed in the keyframe

void put_box(ByteWriter& w, const PositionBox& b) {
  for (int a = 0; a < 3; ++a) w.f32(b.lo[a]);
  for (int a = 0; a < 3; ++a) w.f32(b.hi[a]);
}
PositionBox get_box(ByteReader& r) {
  PositionBox b;
  for (int a = 0; a < 3; ++a) b.lo[a] = r.f32();
  for (int a = 0; a < 3; ++a) b.hi[a] = r.f32();
  for (int a = 0; a < 3; ++a)
    if (!(std::isfinite(b.lo[a]) && std::isfinite(b.hi[a]) && b.lo[a] < b.hi[a]))
      r.fail("position box axis " + std::to_string(a) + " is [" + std::to_string(b.lo[a]) + ", " +
             std::to_string(b.hi[a]) + "]");
  return b;
}

void put_sleeping(ByteWriter& w, const std::vector<std::uint8_t>& sleeping) {
  for (std::size_t i = 0; i < sleeping.size(); i += 8) {
    std::uint8_t bits = 0;
    for (std::size_t j = 0; j < 8 && i + j < sleeping.size(); ++j) bits |= (sleeping[i + j] ? 1 : 0) << j;
    w.u8(bits);
  }
}
void get_sleeping(ByteReader& r, std::vector<std::uint8_t>& sleeping, std::size_t n) {
  sleeping.assign(n, 0);
  for (std::size_t i = 0; i < n; i += 8) {
    const std::uint8_t bits = r.u8();
    for (std::size_t j = 0; j < 8 && i + j < n; ++j) sleeping[i + j] = (bits >> j) & 1;
  }
}

std::uint16_t get_owner(ByteReader& r, int worlds, const char* of) {
  const std::uint16_t o = r.u16();
  if (o >= worlds) r.fail(std::string(of) + " owner " + std::to_string(o) + " >= territories " + std::to_string(worlds));
  return o;
}

// Map, busy times, hash: the same in both chunk kinds.
void put_tail(ByteWriter& w, const StoredFrame& f, bool with_map) {
  w.u8(static_cast<std::uint8_t>((with_map ? kHasMap : 0) | (f.state_hash ? kHasHash : 0)));
  if (with_map) {
    w.u32(static_cast<std::uint32_t>(f.cell_owner.size()));
    for (std::uint16_t o : f.cell_owner) w.u16(o);
  }
  w.u32(static_cast<std::uint32_t>(f.world_busy_ms.size()));
  for (float ms : f.world_busy_ms) w.f32(ms);
  if (f.state_hash) w.u64(*f.state_hash);
}
void get_tail(ByteReader& r, const FrameShape& shape, StoredFrame& f, bool map_required) {
  const std::uint8_t flags = r.u8();
  if (flags & ~(kHasMap | kHasHash)) r.fail("unknown flags " + std::to_string(flags));
  f.map_changed = flags & kHasMap;
  if (map_required && !f.map_changed) r.fail("a keyframe without its territory map");
  if (f.map_changed) {
    const std::uint32_t cells = r.u32();
    if (cells != shape.cells)
      r.fail("territory map of " + std::to_string(cells) + " cells, the header's box has " + std::to_string(shape.cells));
    f.cell_owner.resize(cells);
    for (std::uint16_t& o : f.cell_owner) o = get_owner(r, shape.worlds, "a cell's");
  }
  const std::uint32_t worlds = r.u32();
  if (worlds != 0 && worlds != static_cast<std::uint32_t>(shape.worlds))
    r.fail("busy times of " + std::to_string(worlds) + " worlds, the header has " + std::to_string(shape.worlds));
  f.world_busy_ms.resize(worlds);
  for (float& ms : f.world_busy_ms) ms = r.f32();
  f.state_hash.reset();
  if (flags & kHasHash) f.state_hash = r.u64();
  if (r.remaining() != 0) r.fail(std::to_string(r.remaining()) + " bytes left over");
}

}  // namespace

std::vector<std::uint8_t> encode_keyframe(const StoredFrame& f) {
  ByteWriter w;
  const std::size_t n = f.orientation.size();
  w.i64(f.step);
  put_box(w, f.box);
  w.u32(static_cast<std::uint32_t>(n));
  w.u8(f.ids ? kListedBodies : kHeaderBodies);
  if (f.ids)
    for (std::size_t i = 0; i < f.ids->size(); ++i)  // gaps: id - previous id - 1 (first: the id)
      w.varint(i == 0 ? (*f.ids)[i] : (*f.ids)[i] - (*f.ids)[i - 1] - 1);
  for (std::size_t a = 0; a < 3; ++a)  // one axis after another: like bytes together
    for (std::size_t i = 0; i < n; ++i) w.u16(f.position[3 * i + a]);
  for (std::uint32_t q : f.orientation) w.u32(q);
  put_sleeping(w, f.sleeping);
  for (std::uint16_t o : f.owner) w.u16(o);
  put_tail(w, f, true);
  return std::move(w.bytes());
}

std::vector<std::uint8_t> encode_delta(const StoredFrame& prev, const StoredFrame& f) {
  ByteWriter w;
  const std::size_t n = f.orientation.size();
  w.i64(f.step);
  std::vector<std::size_t> moved;
  for (std::size_t i = 0; i < n; ++i)
    if (f.orientation[i] != prev.orientation[i] || f.position[3 * i] != prev.position[3 * i] ||
        f.position[3 * i + 1] != prev.position[3 * i + 1] || f.position[3 * i + 2] != prev.position[3 * i + 2])
      moved.push_back(i);
  w.u32(static_cast<std::uint32_t>(moved.size()));
  std::size_t last = 0;
  for (std::size_t k = 0; k < moved.size(); ++k) {  // gaps: index - previous index - 1 (first: index)
    w.varint(k == 0 ? moved[k] : moved[k] - last - 1);
    last = moved[k];
  }
  for (std::size_t a = 0; a < 3; ++a)  // code differences mod 2^16: small moves, small numbers
    for (std::size_t i : moved) w.u16(static_cast<std::uint16_t>(f.position[3 * i + a] - prev.position[3 * i + a]));
  for (std::size_t i : moved) w.u32(f.orientation[i]);
  put_sleeping(w, f.sleeping);
  std::vector<std::size_t> reowned;
  for (std::size_t i = 0; i < n; ++i)
    if (f.owner[i] != prev.owner[i]) reowned.push_back(i);
  w.u32(static_cast<std::uint32_t>(reowned.size()));
  last = 0;
  for (std::size_t k = 0; k < reowned.size(); ++k) {
    w.varint(k == 0 ? reowned[k] : reowned[k] - last - 1);
    last = reowned[k];
  }
  for (std::size_t i : reowned) w.u16(f.owner[i]);
  put_tail(w, f, f.map_changed);
  return std::move(w.bytes());
}

void decode_keyframe(std::span<const std::uint8_t> raw, const FrameShape& shape, std::uint32_t version,
                     StoredFrame& f) {
  ByteReader r(raw, "keyframe");
  f.step = r.i64();
  f.box = get_box(r);
  const std::uint32_t n = r.u32();
  r.count(n, 10, "bodies");
  const std::uint8_t population = version >= 2 ? r.u8() : kHeaderBodies;
  f.ids.reset();
  if (population == kHeaderBodies) {
    if (n != shape.bodies)
      r.fail(std::to_string(n) + " bodies, the header has " + std::to_string(shape.bodies) + " dynamic bodies");
  } else if (population == kListedBodies) {
    std::vector<BodyId>& ids = f.ids.emplace(n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint64_t gap = r.varint();
      const std::uint64_t id = i == 0 ? gap : std::uint64_t{ids[i - 1]} + 1 + gap;
      if (gap > 0xFFFFFFFFu || id > 0xFFFFFFFFu) r.fail("body id " + std::to_string(id) + " out of range");
      ids[i] = static_cast<BodyId>(id);
    }
  } else {
    r.fail("unknown population kind " + std::to_string(population));
  }
  f.position.resize(3 * std::size_t{n});
  for (std::size_t a = 0; a < 3; ++a)
    for (std::size_t i = 0; i < n; ++i) f.position[3 * i + a] = r.u16();
  f.orientation.resize(n);
  for (std::uint32_t& q : f.orientation) q = r.u32();
  get_sleeping(r, f.sleeping, n);
  f.owner.resize(n);
  for (std::uint16_t& o : f.owner) o = get_owner(r, shape.worlds, "a body's");
  get_tail(r, shape, f, true);
}

namespace {

// Gap-coded ascending indices below n.
std::vector<std::size_t> get_indices(ByteReader& r, std::size_t n, const char* of) {
  const std::size_t m = r.count(r.u32(), 1, of);
  if (m > n) r.fail(std::to_string(m) + " " + of + ", more than the " + std::to_string(n) + " bodies");
  std::vector<std::size_t> out(m);
  for (std::size_t k = 0; k < m; ++k) {
    const std::uint64_t gap = r.varint();
    const std::uint64_t i = k == 0 ? gap : out[k - 1] + 1 + gap;
    if (gap >= n || i >= n) r.fail(std::string(of) + ": body index " + std::to_string(i) + " out of range");
    out[k] = static_cast<std::size_t>(i);
  }
  return out;
}

}  // namespace

void decode_delta(std::span<const std::uint8_t> raw, const FrameShape& shape, StoredFrame& f) {
  ByteReader r(raw, "delta");
  const std::int64_t step = r.i64();
  if (step <= f.step)
    r.fail("step " + std::to_string(step) + " does not follow step " + std::to_string(f.step));
  f.step = step;
  const std::size_t n = f.orientation.size();  // the keyframe's bodies
  const std::vector<std::size_t> moved = get_indices(r, n, "moved bodies");
  r.count(moved.size(), 10, "moved bodies");
  for (std::size_t a = 0; a < 3; ++a)
    for (std::size_t i : moved) f.position[3 * i + a] = static_cast<std::uint16_t>(f.position[3 * i + a] + r.u16());
  for (std::size_t i : moved) f.orientation[i] = r.u32();
  get_sleeping(r, f.sleeping, n);
  const std::vector<std::size_t> reowned = get_indices(r, n, "re-owned bodies");
  for (std::size_t i : reowned) f.owner[i] = get_owner(r, shape.worlds, "a body's");
  std::vector<std::uint16_t> map = std::move(f.cell_owner);
  f.cell_owner.clear();
  get_tail(r, shape, f, false);
  if (!f.map_changed) f.cell_owner = std::move(map);
}

ViewFrame to_view_frame(const StoredFrame& f) {
  ViewFrame v;
  v.step = f.step;
  v.ids = f.ids;
  const std::size_t n = f.orientation.size();
  v.position.resize(3 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t a = 0; a < 3; ++a)
      v.position[3 * i + a] = dequantise_position(f.position[3 * i + a], f.box.lo[a], f.box.hi[a]);
  v.orientation.resize(4 * n);
  for (std::size_t i = 0; i < n; ++i) unpack_orientation(f.orientation[i], &v.orientation[4 * i]);
  v.sleeping = f.sleeping;
  v.owner = f.owner;
  v.cell_owner = f.cell_owner;
  v.world_busy_ms = f.world_busy_ms;
  v.state_hash = f.state_hash;
  return v;
}

}  // namespace soda::replay

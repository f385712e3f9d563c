#include "soda/replay/replay_writer.h"

#include <cerrno>
#include <cmath>
#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "byte_io.h"
#include "replay_codec.h"

namespace soda::replay {
namespace {

// "step S, body ID: field" for the i-th body of a frame whose bodies are `ids`.
std::string body_field(const std::vector<BodyId>& ids, std::int64_t step, std::size_t i, const char* field) {
  if (i < ids.size()) return "step " + std::to_string(step) + ", body " + std::to_string(ids[i]) + ": " + field;
  return "step " + std::to_string(step) + ": " + field;
}

bool same_shape(const Shape& a, const Shape& b) {
  if (!(a.kind == b.kind && a.half_extents == b.half_extents && a.radius == b.radius && a.height == b.height &&
        a.points == b.points && a.children.size() == b.children.size() && a.mesh == b.mesh &&
        a.heightfield == b.heightfield))
    return false;
  for (std::size_t i = 0; i < a.children.size(); ++i) {
    const CompoundChild &x = a.children[i], &y = b.children[i];
    if (!same_shape(x.shape, y.shape) || x.position != y.position || x.orientation.coeffs() != y.orientation.coeffs())
      return false;
  }
  return true;
}

// What the file could not store of `body`'s shape ("" if nothing): a mesh or
// heightfield without its data, or heights that do not fill its grid.
std::string shape_gap(const ViewBody& body) {
  const Shape& s = body.shape;
  if (s.kind == ShapeKind::TriangleMesh && !s.mesh) return "a triangle mesh without its triangles";
  if (s.kind == ShapeKind::Heightfield) {
    if (!s.heightfield) return "a heightfield without its heights";
    const HeightfieldData& h = *s.heightfield;
    if (h.columns < 2 || h.rows < 2 || h.heights.size() != std::size_t(h.columns) * std::size_t(h.rows))
      return "a heightfield of " + std::to_string(h.columns) + " x " + std::to_string(h.rows) + " samples with " +
             std::to_string(h.heights.size()) + " heights";
  }
  for (const CompoundChild& c : s.children)
    if (c.shape.kind >= ShapeKind::Compound) return "a compound child that is not convex";
  return "";
}

}  // namespace

ReplayWriter::ReplayWriter(std::string path, ViewHeader header, ReplayWriterOptions options)
    : path_(std::move(path)), header_(std::move(header)), options_(options) {
  if (options_.keyframe_every < 1) throw std::invalid_argument("ReplayWriter: keyframe_every must be >= 1");
  if (options_.compression_level < 1 || options_.compression_level > 9)
    throw std::invalid_argument("ReplayWriter: compression_level must be in 1 .. 9");
  if (header_.territories < 1 || header_.territories > 0xFFFF)
    throw std::invalid_argument(path_ + ": territories " + std::to_string(header_.territories) +
                                " cannot be stored (1 .. 65535)");
  for (std::size_t i = 1; i < header_.bodies.size(); ++i)
    if (header_.bodies[i].id <= header_.bodies[i - 1].id)
      throw std::invalid_argument(path_ + ": header bodies not in ascending id order at body " +
                                  std::to_string(header_.bodies[i].id));
  for (const ViewBody& b : header_.bodies) {
    if (const std::string gap = shape_gap(b); !gap.empty())
      throw std::invalid_argument(path_ + ": body " + std::to_string(b.id) + ": " + gap);
    if (!b.is_static) header_ids_.push_back(b.id);
  }
  const std::vector<std::uint8_t> head = encode_header(header_, static_cast<std::uint32_t>(options_.keyframe_every));
  file_ = std::fopen(path_.c_str(), "wb");
  if (!file_) throw ReplayError(path_, std::string("cannot open for writing: ") + std::strerror(errno));
  ByteWriter w;
  for (char c : kFileMagic) w.u8(static_cast<std::uint8_t>(c));
  w.u32(kFormatVersion);
  w.u32(0);  // flags, none yet
  write_bytes(w.bytes().data(), w.bytes().size());
  write_chunk(kHeaderTag, head);
}

ReplayWriter::~ReplayWriter() {
  try {
    close();
  } catch (...) {
  }
  if (file_) std::fclose(file_);
}

std::size_t ReplayWriter::keyframes() const {
  std::size_t n = 0;
  for (const IndexEntry& e : index_) n += e.key ? 1 : 0;
  return n;
}

void ReplayWriter::write_bytes(const void* data, std::size_t size) {
  if (size && std::fwrite(data, 1, size, file_) != size)
    throw ReplayError(path_, "write failed at byte " + std::to_string(offset_) + ": " + std::strerror(errno));
  offset_ += size;
}

void ReplayWriter::write_chunk(std::uint32_t tag, const std::vector<std::uint8_t>& raw) {
  const std::vector<std::uint8_t> stored = deflate_bytes(raw, options_.compression_level);
  ByteWriter w;
  w.u32(tag);
  w.u32(static_cast<std::uint32_t>(raw.size()));
  w.u32(static_cast<std::uint32_t>(stored.size()));
  w.u32(crc32_of(stored));
  write_bytes(w.bytes().data(), w.bytes().size());
  write_bytes(stored.data(), stored.size());
}

void ReplayWriter::describe(const ViewBody& body) {
  const std::string what = path_ + ": describe body " + std::to_string(body.id);
  if (!file_) throw std::logic_error(what + " after close()");
  if (body.is_static) throw std::invalid_argument(what + ": a static body (only dynamic bodies are added)");
  if (FrameSource::header_body(header_, body.id))
    throw std::invalid_argument(what + ": the header has a body with that id");
  if (const std::string gap = shape_gap(body); !gap.empty()) throw std::invalid_argument(what + ": " + gap);
  auto [it, added] = described_.try_emplace(body.id, Described{body, false});
  if (!added && !same_shape(it->second.body.shape, body.shape))
    throw std::invalid_argument(what + ": described before with another shape");
}

std::vector<BodyId> ReplayWriter::check(const ViewFrame& f) const {
  if (!file_) throw std::logic_error(path_ + ": append after close()");
  const std::string at = "step " + std::to_string(f.step);
  if (last_ && f.step <= last_->step)
    throw std::invalid_argument(path_ + ": " + at + " does not follow step " + std::to_string(last_->step));
  const FrameShape shape = frame_shape(header_);
  std::vector<BodyId> undescribed;  // ids a BODS chunk must describe before this frame
  const std::vector<BodyId>& ids = f.ids ? *f.ids : header_ids_;
  for (std::size_t i = 0; f.ids && i < ids.size(); ++i) {
    const BodyId id = ids[i];
    if (i > 0 && id <= ids[i - 1])
      throw std::invalid_argument(path_ + ": " + at + ": ids not ascending at body " + std::to_string(id));
    if (std::binary_search(header_ids_.begin(), header_ids_.end(), id)) continue;
    const auto d = described_.find(id);
    if (d == described_.end())
      throw std::invalid_argument(path_ + ": " + at + ", body " + std::to_string(id) +
                                  (FrameSource::header_body(header_, id) ? ": a static body of the header"
                                                                         : ": not in the header and never described "
                                                                           "(ReplayWriter::describe)"));
    if (!d->second.written) undescribed.push_back(id);
  }
  const std::size_t n = ids.size();
  auto size = [&](std::size_t got, std::size_t want, const char* field) {
    if (got != want)
      throw std::invalid_argument(path_ + ": " + at + ": " + field + " has " + std::to_string(got) +
                                  " values, the frame's " + std::to_string(n) + " dynamic bodies need " +
                                  std::to_string(want));
  };
  size(f.position.size(), 3 * n, "position");
  size(f.orientation.size(), 4 * n, "orientation");
  size(f.sleeping.size(), n, "sleeping");
  size(f.owner.size(), n, "owner");
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t a = 0; a < 3; ++a)
      if (!std::isfinite(f.position[3 * i + a]))
        throw std::invalid_argument(path_ + ": " + body_field(ids, f.step, i, "position is not finite"));
    double norm2 = 0;
    for (std::size_t a = 0; a < 4; ++a) norm2 += static_cast<double>(f.orientation[4 * i + a]) * f.orientation[4 * i + a];
    if (!(std::isfinite(norm2) && norm2 > 0.25 && norm2 < 4))
      throw std::invalid_argument(path_ + ": " + body_field(ids, f.step, i, "orientation is not a unit quaternion"));
    if (f.owner[i] >= header_.territories)
      throw std::invalid_argument(path_ + ": " + body_field(ids, f.step, i, "owner") + " " +
                                  std::to_string(f.owner[i]) + " >= territories " +
                                  std::to_string(header_.territories));
  }
  if (!f.cell_owner.empty() || (!last_ && shape.cells > 0)) {
    if (f.cell_owner.size() != shape.cells)
      throw std::invalid_argument(path_ + ": " + at + ": cell_owner has " + std::to_string(f.cell_owner.size()) +
                                  " cells, the header's box " + std::to_string(shape.cells) +
                                  (last_ ? "" : " (the first frame must carry the map)"));
    for (std::uint16_t o : f.cell_owner)
      if (o >= header_.territories)
        throw std::invalid_argument(path_ + ": " + at + ": cell_owner " + std::to_string(o) + " >= territories " +
                                    std::to_string(header_.territories));
  }
  if (!f.world_busy_ms.empty() && f.world_busy_ms.size() != static_cast<std::size_t>(header_.territories))
    throw std::invalid_argument(path_ + ": " + at + ": world_busy_ms has " + std::to_string(f.world_busy_ms.size()) +
                                " values, not one per world (" + std::to_string(header_.territories) + ")");
  return undescribed;
}

void ReplayWriter::append(const ViewFrame& f) {
  const std::vector<BodyId> undescribed = check(f);
  const std::size_t n = f.sleeping.size();
  auto cur = std::make_unique<StoredFrame>();
  cur->step = f.step;
  // The header's bodies are stored as "the header's" (no ids), whichever way
  // the frame names them.
  if (f.ids && *f.ids != header_ids_) cur->ids = f.ids;
  const bool key = !last_ || since_key_ + 1 >= options_.keyframe_every || last_->ids != cur->ids ||
                   !box_holds(last_->box, f.position);
  cur->box = key ? position_box(f.position) : last_->box;
  cur->position.resize(3 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t a = 0; a < 3; ++a)
      cur->position[3 * i + a] = quantise_position(f.position[3 * i + a], cur->box.lo[a], cur->box.hi[a]);
  cur->orientation.resize(n);
  for (std::size_t i = 0; i < n; ++i) cur->orientation[i] = pack_orientation(&f.orientation[4 * i]);
  cur->sleeping.resize(n);
  for (std::size_t i = 0; i < n; ++i) cur->sleeping[i] = f.sleeping[i] ? 1 : 0;
  cur->owner = f.owner;
  if (!f.cell_owner.empty()) {
    cur->cell_owner = f.cell_owner;
    cur->map_changed = !last_ || last_->cell_owner != f.cell_owner;
  } else if (last_) {
    cur->cell_owner = last_->cell_owner;
  }
  if (key) cur->map_changed = true;  // a keyframe carries the map in force
  cur->world_busy_ms = f.world_busy_ms;
  cur->state_hash = f.state_hash;
  if (!undescribed.empty()) {  // the first frame that holds them: their descriptions first
    std::vector<ViewBody> bodies;
    for (BodyId id : undescribed) bodies.push_back(described_.at(id).body);
    const std::uint64_t bodies_at = offset_;
    write_chunk(kBodiesTag, encode_bodies(bodies));
    bodies_chunks_.push_back(bodies_at);
    for (BodyId id : undescribed) described_.at(id).written = true;
  }
  const std::uint64_t at = offset_;
  write_chunk(key ? kKeyframeTag : kDeltaTag, key ? encode_keyframe(*cur) : encode_delta(*last_, *cur));
  index_.push_back({f.step, at, key, cur->box});
  since_key_ = key ? 0 : since_key_ + 1;
  last_ = std::move(cur);
}

void ReplayWriter::close() {
  if (!file_) return;
  ByteWriter w;
  w.u64(index_.size());
  for (const IndexEntry& e : index_) {
    w.i64(e.step);
    w.u64(e.offset);
    w.u8(e.key ? 1 : 0);
    if (!e.key) continue;
    for (int a = 0; a < 3; ++a) w.f32(e.box.lo[a]);
    for (int a = 0; a < 3; ++a) w.f32(e.box.hi[a]);
  }
  w.u32(static_cast<std::uint32_t>(bodies_chunks_.size()));
  for (std::uint64_t at : bodies_chunks_) w.u64(at);
  const std::uint64_t index_at = offset_;
  write_chunk(kIndexTag, w.bytes());
  ByteWriter t;
  t.u64(index_at);
  for (char c : kEndMagic) t.u8(static_cast<std::uint8_t>(c));
  write_bytes(t.bytes().data(), t.bytes().size());
  std::FILE* f = file_;
  file_ = nullptr;
  if (std::fclose(f) != 0) throw ReplayError(path_, std::string("closing failed: ") + std::strerror(errno));
}

ViewFrame ReplayWriter::stored_frame() const {
  if (!last_) throw std::logic_error(path_ + ": stored_frame() before the first append");
  return to_view_frame(*last_);
}

PositionBox ReplayWriter::stored_box() const {
  if (!last_) throw std::logic_error(path_ + ": stored_box() before the first append");
  return last_->box;
}

}  // namespace soda::replay

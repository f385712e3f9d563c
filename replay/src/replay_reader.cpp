#include "soda/replay/replay_reader.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "byte_io.h"
#include "replay_codec.h"

namespace soda::replay {
namespace {

std::string tag_name(std::uint32_t t) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((t >> (8 * i)) & 0xFF);
    s += (c >= 32 && c < 127) ? c : '?';
  }
  return "'" + s + "'";
}

}  // namespace

[[noreturn]] void ReplayReader::fail(const std::string& what) const { throw ReplayFormatError(path_, what); }

void ReplayReader::read_bytes(std::uint64_t offset, void* out, std::size_t size, const std::string& what) const {
  if (offset > file_bytes_ || size > file_bytes_ - offset)
    fail("truncated: " + what + " needs bytes " + std::to_string(offset) + " .. " + std::to_string(offset + size) +
         ", the file has " + std::to_string(file_bytes_));
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = ::pread(fd_, static_cast<char*>(out) + done, size - done, static_cast<off_t>(offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) fail("reading " + what + " at byte " + std::to_string(offset + done) + " failed: " +
                     (n < 0 ? std::strerror(errno) : "unexpected end of file"));
    done += static_cast<std::size_t>(n);
  }
}

std::vector<std::uint8_t> ReplayReader::read_chunk(std::uint64_t offset, std::uint32_t want_tag,
                                                   const std::string& what) const {
  std::uint8_t head[kChunkHeaderBytes];
  read_bytes(offset, head, sizeof head, what + " (chunk header)");
  ByteReader r(head, what);
  const std::uint32_t tag = r.u32(), raw_size = r.u32(), stored_size = r.u32(), crc = r.u32();
  const std::string where = what + " at byte " + std::to_string(offset);
  if (tag != want_tag) fail(where + ": chunk tag " + tag_name(tag) + ", expected " + tag_name(want_tag) + " (corrupted)");
  if (raw_size > kMaxChunkBytes || stored_size > kMaxChunkBytes)
    fail(where + ": chunk sizes " + std::to_string(raw_size) + "/" + std::to_string(stored_size) + " (corrupted)");
  std::vector<std::uint8_t> stored(stored_size);
  read_bytes(offset + kChunkHeaderBytes, stored.data(), stored.size(), where);
  if (crc32_of(stored) != crc) fail(where + ": checksum mismatch (corrupted)");
  try {
    return inflate_bytes(stored, raw_size);
  } catch (const FormatError& e) {
    fail(where + ": " + e.what());
  }
}

ReplayReader::ReplayReader(std::string path) : path_(std::move(path)) {
  fd_ = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) fail(std::string("cannot open: ") + std::strerror(errno));
  try {
    struct stat st {};
    if (::fstat(fd_, &st) != 0) fail(std::string("cannot stat: ") + std::strerror(errno));
    if (!S_ISREG(st.st_mode)) fail("not a regular file");
    file_bytes_ = static_cast<std::uint64_t>(st.st_size);
    std::uint8_t head[kFileHeaderBytes];
    if (file_bytes_ < kFileHeaderBytes) fail("not a replay file: " + std::to_string(file_bytes_) + " bytes");
    read_bytes(0, head, sizeof head, "the file header");
    if (std::memcmp(head, kFileMagic, sizeof kFileMagic) != 0) fail("not a replay file (no SODARPLY magic)");
    ByteReader h(std::span<const std::uint8_t>(head).subspan(8), "the file header");
    version_ = h.u32();
    if (version_ < kOldestVersion || version_ > kFormatVersion)
      fail("replay format version " + std::to_string(version_) + ", this build reads versions " +
           std::to_string(kOldestVersion) + " to " + std::to_string(kFormatVersion) +
           (version_ > kFormatVersion ? " (a newer writer?)" : ""));
    if (h.u32() != 0) fail("unknown file flags (a newer writer?)");
    if (file_bytes_ < kFileHeaderBytes + kTrailerBytes) fail("truncated: no end marker (the writer did not close it)");
    std::uint8_t tail[kTrailerBytes];
    read_bytes(file_bytes_ - kTrailerBytes, tail, sizeof tail, "the end marker");
    if (std::memcmp(tail + 8, kEndMagic, sizeof kEndMagic) != 0)
      fail("truncated or not closed: no end marker (the recording did not finish, or the file was cut)");
    const std::uint64_t index_at = ByteReader(tail, "the end marker").u64();
    if (index_at < kFileHeaderBytes || index_at >= file_bytes_ - kTrailerBytes)
      fail("the end marker points the index at byte " + std::to_string(index_at) + " (corrupted)");

    std::uint32_t every = 1;
    try {
      header_ = decode_header(read_chunk(kFileHeaderBytes, kHeaderTag, "the scene header"), version_, every);
    } catch (const FormatError& e) {
      fail(e.what());
    }
    keyframe_every_ = static_cast<int>(std::min<std::uint32_t>(every, 1u << 30));

    const std::vector<std::uint8_t> raw = read_chunk(index_at, kIndexTag, "the index");
    std::vector<std::uint64_t> bodies_at;
    try {
      ByteReader r(raw, "the index");
      const std::size_t n = r.count(r.u64(), 17, "frames");
      index_.reserve(n);
      std::size_t key = 0;
      for (std::size_t i = 0; i < n; ++i) {
        IndexEntry e{};
        e.step = r.i64();
        e.offset = r.u64();
        e.key = r.u8() != 0;
        if (i == 0 && !e.key) r.fail("the first frame is not a keyframe");
        if (i > 0 && e.step <= index_.back().step)
          r.fail("frame #" + std::to_string(i) + " step " + std::to_string(e.step) + " does not follow step " +
                 std::to_string(index_.back().step));
        if (e.offset < kFileHeaderBytes || e.offset >= index_at)
          r.fail("frame at step " + std::to_string(e.step) + " at byte " + std::to_string(e.offset) +
                 ", outside the frames");
        if (e.key) {
          key = i;
          for (int a = 0; a < 3; ++a) e.box.lo[a] = r.f32();
          for (int a = 0; a < 3; ++a) e.box.hi[a] = r.f32();
        } else {
          e.box = index_[key].box;
        }
        e.keyframe = key;
        index_.push_back(e);
      }
      if (version_ >= 2) {  // the BODS chunks: every body added during the run
        const std::size_t chunks = r.count(r.u32(), 8, "added-bodies chunks");
        for (std::size_t c = 0; c < chunks; ++c) {
          const std::uint64_t at = r.u64();
          if (at < kFileHeaderBytes || at >= index_at)
            r.fail("added bodies at byte " + std::to_string(at) + ", outside the frames");
          bodies_at.push_back(at);
        }
      }
      if (r.remaining() != 0) r.fail(std::to_string(r.remaining()) + " bytes left over");
    } catch (const FormatError& e) {
      fail(e.what());
    }
    for (std::uint64_t at : bodies_at) {
      const std::vector<std::uint8_t> chunk = read_chunk(at, kBodiesTag, "the added bodies");
      try {
        for (ViewBody& b : decode_bodies(chunk, version_)) added_.push_back(std::move(b));
      } catch (const FormatError& e) {
        fail("the added bodies at byte " + std::to_string(at) + ": " + e.what());
      }
    }
    std::sort(added_.begin(), added_.end(), [](const ViewBody& a, const ViewBody& b) { return a.id < b.id; });
    for (std::size_t i = 0; i < added_.size(); ++i) {
      if (i > 0 && added_[i].id == added_[i - 1].id)
        fail("body " + std::to_string(added_[i].id) + " is described twice (corrupted)");
      if (FrameSource::header_body(header_, added_[i].id))
        fail("added body " + std::to_string(added_[i].id) + " has the id of a header body (corrupted)");
    }
  } catch (...) {
    ::close(fd_);
    throw;
  }
}

ReplayReader::~ReplayReader() {
  if (fd_ >= 0) ::close(fd_);
}

std::size_t ReplayReader::keyframe_count() const {
  return static_cast<std::size_t>(std::count_if(index_.begin(), index_.end(), [](const IndexEntry& e) { return e.key; }));
}

std::pair<std::int64_t, std::int64_t> ReplayReader::step_range() const {
  if (index_.empty()) return {0, -1};
  return {index_.front().step, index_.back().step};
}

std::optional<std::size_t> ReplayReader::find(std::int64_t step) const {
  auto it = std::lower_bound(index_.begin(), index_.end(), step,
                             [](const IndexEntry& e, std::int64_t s) { return e.step < s; });
  if (it == index_.end() || it->step != step) return std::nullopt;
  return static_cast<std::size_t>(it - index_.begin());
}

std::optional<PositionBox> ReplayReader::box_at(std::int64_t step) const {
  const std::optional<std::size_t> i = find(step);
  if (!i) return std::nullopt;
  return index_[*i].box;
}

double ReplayReader::position_error_bound() const {
  double bound = 0;
  for (const IndexEntry& e : index_)
    if (e.key) bound = std::max(bound, replay::position_error_bound(e.box));
  return bound;
}

ViewFrame ReplayReader::decode_locked(std::size_t i) {
  const FrameShape shape = frame_shape(header_);
  std::size_t from = index_[i].keyframe;
  const bool on_the_way = state_ && state_index_ >= from && state_index_ <= i;
  if (on_the_way) from = state_index_ + 1;
  if (!state_) state_ = std::make_unique<StoredFrame>();
  for (std::size_t j = from; j <= i; ++j) {
    const IndexEntry& e = index_[j];
    const std::string what = std::string(e.key ? "keyframe" : "delta") + " of step " + std::to_string(e.step);
    try {
      const std::vector<std::uint8_t> raw = read_chunk(e.offset, e.key ? kKeyframeTag : kDeltaTag, what);
      if (e.key) {
        decode_keyframe(raw, shape, version_, *state_);
        if (state_->ids)
          for (BodyId id : *state_->ids)
            if (!body_known(id)) throw FormatError("body " + std::to_string(id) + " has no description");
      } else {
        decode_delta(raw, shape, *state_);
      }
      if (state_->step != e.step)
        throw FormatError("holds step " + std::to_string(state_->step) + ", the index says " + std::to_string(e.step));
      if (e.key && !(state_->box == e.box)) throw FormatError("position box differs from the index's");
    } catch (const FormatError& err) {
      state_.reset();
      fail(what + ": " + err.what());
    } catch (...) {
      state_.reset();
      throw;
    }
    state_index_ = j;
  }
  return to_view_frame(*state_);
}

std::optional<ViewBody> ReplayReader::body(BodyId id) const {
  if (auto b = header_body(header_, id)) return b;
  auto it = std::lower_bound(added_.begin(), added_.end(), id, [](const ViewBody& b, BodyId i) { return b.id < i; });
  if (it == added_.end() || it->id != id) return std::nullopt;
  return *it;
}

bool ReplayReader::body_known(BodyId id) const {
  const std::optional<ViewBody> b = body(id);
  return b && !b->is_static;
}

std::optional<ViewFrame> ReplayReader::frame_at(std::int64_t step) {
  const std::optional<std::size_t> i = find(step);
  if (!i) return std::nullopt;
  std::lock_guard lock(mutex_);
  return decode_locked(*i);
}

std::optional<ViewFrame> ReplayReader::newest_after(std::int64_t after) {
  if (index_.empty() || index_.back().step <= after) return std::nullopt;
  std::lock_guard lock(mutex_);
  return decode_locked(index_.size() - 1);
}

}  // namespace soda::replay

#include "soda/viewer/memory_frame_source.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace soda::viewer {

void MemoryFrameSource::add(replay::ViewFrame frame) {
  const std::size_t n = frame.ids ? frame.ids->size() : header_.dynamic_count();
  auto check = [&](const char* name, std::size_t got, std::size_t want) {
    if (got != want)
      throw std::invalid_argument("frame " + std::to_string(frame.step) + ": " + name + " has " +
                                  std::to_string(got) + " values, expected " + std::to_string(want) + " (" +
                                  std::to_string(n) + " dynamic bodies)");
  };
  check("position", frame.position.size(), 3 * n);
  check("orientation", frame.orientation.size(), 4 * n);
  check("sleeping", frame.sleeping.size(), n);
  check("owner", frame.owner.size(), n);
  std::lock_guard lock(mutex_);
  if (!frames_.empty() && frame.step <= frames_.back().step)
    throw std::invalid_argument("frame " + std::to_string(frame.step) + " after frame " +
                                std::to_string(frames_.back().step) + ": steps must increase");
  frames_.push_back(std::move(frame));
}

void MemoryFrameSource::describe(const replay::ViewBody& body) {
  std::lock_guard lock(mutex_);
  described_.insert_or_assign(body.id, body);
}

std::optional<replay::ViewBody> MemoryFrameSource::body(BodyId id) const {
  if (auto b = header_body(header_, id)) return b;
  std::lock_guard lock(mutex_);
  auto it = described_.find(id);
  if (it == described_.end()) return std::nullopt;
  return it->second;
}

void MemoryFrameSource::finish() {
  std::lock_guard lock(mutex_);
  finished_ = true;
}

std::optional<replay::ViewFrame> MemoryFrameSource::newest_after(std::int64_t after) {
  std::lock_guard lock(mutex_);
  if (frames_.empty() || frames_.back().step <= after) return std::nullopt;
  return with_map(frames_.size() - 1);
}

std::optional<replay::ViewFrame> MemoryFrameSource::frame_at(std::int64_t step) {
  std::lock_guard lock(mutex_);
  auto it = std::lower_bound(frames_.begin(), frames_.end(), step,
                             [](const replay::ViewFrame& f, std::int64_t s) { return f.step < s; });
  if (it == frames_.end() || it->step != step) return std::nullopt;
  return with_map(static_cast<std::size_t>(it - frames_.begin()));
}

replay::ViewFrame MemoryFrameSource::with_map(std::size_t index) const {
  replay::ViewFrame out = frames_[index];
  for (std::size_t i = index + 1; out.cell_owner.empty() && i-- > 0;)
    if (!frames_[i].cell_owner.empty()) out.cell_owner = frames_[i].cell_owner;
  return out;
}

std::pair<std::int64_t, std::int64_t> MemoryFrameSource::step_range() const {
  std::lock_guard lock(mutex_);
  if (frames_.empty()) return {0, -1};
  return {frames_.front().step, frames_.back().step};
}

bool MemoryFrameSource::finished() const {
  std::lock_guard lock(mutex_);
  return finished_;
}

}  // namespace soda::viewer

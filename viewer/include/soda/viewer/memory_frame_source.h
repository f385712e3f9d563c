// viewer/ — a FrameSource held in memory: a header and frames added by the
// caller. For tests (a small scene's frames without a replay file) and for
// any producer that keeps its whole history. Every frame it returns
// carries the territory map in force at its step (cell_owner), not only the
// frames where it changed.
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

#include "soda/replay/view_frame.h"

namespace soda::viewer {

/// Frames in memory, ascending step. Thread safety: every member may be
/// called from any thread at once (one mutex).
class MemoryFrameSource : public replay::FrameSource {
 public:
  explicit MemoryFrameSource(replay::ViewHeader header) : header_(std::move(header)) {}

  /// Appends a frame; its step must be greater than the last one's (throws
  /// std::invalid_argument otherwise), its arrays sized for its bodies (its
  /// ids, or the header's dynamic bodies; throws std::invalid_argument
  /// naming the array).
  void add(replay::ViewFrame frame);
  /// Describes a body that frames hold and the header lacks (added during
  /// the run); body() answers for it.
  void describe(const replay::ViewBody& body);
  /// No frame will be added any more.
  void finish();

  const replay::ViewHeader& header() const override { return header_; }
  std::optional<replay::ViewFrame> newest_after(std::int64_t after) override;
  std::optional<replay::ViewFrame> frame_at(std::int64_t step) override;
  std::pair<std::int64_t, std::int64_t> step_range() const override;
  bool finished() const override;
  std::optional<replay::ViewBody> body(BodyId id) const override;

 private:
  // frames_[index] with the map in force at its step (the frame's own, or
  // the last earlier frame's): a viewer that jumps in or scrubs always has
  // the map. Call with mutex_ held.
  replay::ViewFrame with_map(std::size_t index) const;

  const replay::ViewHeader header_;
  mutable std::mutex mutex_;
  std::vector<replay::ViewFrame> frames_;
  std::map<BodyId, replay::ViewBody> described_;
  bool finished_ = false;
};

}  // namespace soda::viewer

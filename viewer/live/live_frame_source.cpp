#include "soda/viewer/live_frame_source.h"

#include <stdexcept>
#include <string>

#include "soda/runtime/view_adapter.h"

namespace soda::viewer {

replay::ViewFrame to_view_frame(const SceneFrame& frame, const replay::ViewHeader& header,
                                const std::vector<std::uint16_t>& cell_owner) {
  replay::ViewFrame f = view_frame(frame, header);
  f.cell_owner = cell_owner;
  return f;
}

LiveFrameSource::LiveFrameSource(Simulation& sim, const Scene& scene, TerritoryMap map)
    : sim_(sim),
      header_(view_header(scene, map)),
      map_(std::move(map)),
      cell_owner_(view_cell_owner(map_)),
      reader_(sim.add_reader()) {
  // Step 0 is published at construction: a viewer that comes before the
  // worlds run (soda run --serve-wait) sees the scene as given.
  if (auto frame = reader_.try_read_at(0.0)) keep(to_view_frame(*frame, header_, cell_owner_));
}

LiveFrameSource::~LiveFrameSource() { stop_pump(); }

void LiveFrameSource::start() {
  if (thread_.joinable()) return;
  stop_ = false;
  thread_ = std::thread([this] { pump(); });
}

void LiveFrameSource::stop_pump() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void LiveFrameSource::pump() {
  try {
    pump_loop();
  } catch (const std::exception& e) {  // a failed world: the run reports it; the viewer keeps the last frame
    std::lock_guard lock(mutex_);
    pump_error_ = e.what();
  }
}

void LiveFrameSource::pump_loop() {
  while (!stop_.load()) {
    const std::int64_t step = sim_.published_step();
    if (step > reader_.last_step()) {
      // Never waits: a step some world has not published yet is tried again
      // at the next period.
      if (auto frame = reader_.try_read_at(sim_.time_of(step))) {
        keep(to_view_frame(*frame, header_, cell_owner_));
        ++frames_read_;
      }
    }
    if (sim_.stopped()) break;
    std::this_thread::sleep_for(kPumpPeriod);
  }
}

void LiveFrameSource::finish(std::int64_t last_step, std::uint64_t state_hash) {
  stop_pump();
  std::optional<replay::ViewFrame> last;
  if (last_step == reader_.last_step()) {
    std::lock_guard lock(mutex_);
    last = newest_;
  } else if (auto frame = reader_.read_at(sim_.time_of(last_step))) {
    last = to_view_frame(*frame, header_, cell_owner_);
  }
  std::lock_guard lock(mutex_);
  if (last) {
    last->state_hash = state_hash;
    newest_ = std::move(last);
  }
  finished_ = true;
}

void LiveFrameSource::keep(replay::ViewFrame frame) {
  std::lock_guard lock(mutex_);
  newest_ = std::move(frame);
}

void LiveFrameSource::describe(const Body& body) {
  std::lock_guard lock(mutex_);
  described_.insert_or_assign(body.id, view_body(body));
}

std::optional<replay::ViewBody> LiveFrameSource::body(BodyId id) const {
  if (auto b = header_body(header_, id)) return b;
  std::lock_guard lock(mutex_);
  auto it = described_.find(id);
  if (it == described_.end()) return std::nullopt;
  return it->second;
}

std::optional<replay::ViewFrame> LiveFrameSource::newest_after(std::int64_t after) {
  std::lock_guard lock(mutex_);
  if (!newest_ || newest_->step <= after) return std::nullopt;
  return newest_;
}

std::optional<replay::ViewFrame> LiveFrameSource::frame_at(std::int64_t step) {
  std::lock_guard lock(mutex_);
  if (!newest_ || newest_->step != step) return std::nullopt;
  return newest_;
}

std::string LiveFrameSource::pump_error() const {
  std::lock_guard lock(mutex_);
  return pump_error_;
}

std::pair<std::int64_t, std::int64_t> LiveFrameSource::step_range() const {
  std::lock_guard lock(mutex_);
  if (!newest_) return {0, -1};
  return {newest_->step, newest_->step};
}

bool LiveFrameSource::finished() const {
  std::lock_guard lock(mutex_);
  return finished_;
}

}  // namespace soda::viewer

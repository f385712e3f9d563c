#include "embedding/run_control.h"

#include <algorithm>
#include <utility>

namespace soda {

RunControl::RunControl(int worlds, int substeps, std::int64_t start)
    : substeps_(substeps),
      limit_(start * substeps),
      final_(start),
      started_(static_cast<std::size_t>(worlds), start * substeps),
      parked_at_(static_cast<std::size_t>(worlds), -1),
      published_(static_cast<std::size_t>(worlds), start),
      rewind_to_(static_cast<std::size_t>(worlds)) {}

bool RunControl::may_start(WorldId world, std::int64_t steps_done) {
  std::lock_guard lock(mutex_);
  const auto w = static_cast<std::size_t>(world);
  // A world with a rewind pending takes it first (take_rewind): a step it
  // began now would be one of the run the rewind undid.
  if (shut_down_ || steps_done >= limit_ || (hold_ >= 0 && steps_done >= hold_) ||
      held_by_readers_locked(steps_done) || rewind_to_[w]) {
    if (parked_at_[w] != steps_done) {
      parked_at_[w] = steps_done;
      watch_cv_.notify_all();
    }
    return false;
  }
  parked_at_[w] = -1;
  started_[w] = std::max(started_[w], steps_done + 1);
  return true;
}

bool RunControl::wait_limit_above(WorldId world, std::int64_t steps_done) const {
  std::unique_lock lock(mutex_);
  const std::uint64_t rewinds = rewinds_;
  // A rewind pending for it (rewind() may have come between its may_start
  // and this wait): it must go and take it, whatever steps_done says.
  const std::shared_ptr<const WorldSnapshot>& pending = rewind_to_[static_cast<std::size_t>(world)];
  auto may_go = [&] {
    return limit_ > steps_done && !(hold_ >= 0 && steps_done >= hold_) && !held_by_readers_locked(steps_done);
  };
  world_cv_.wait(lock, [&] { return shut_down_ || frozen_ || pending || rewinds_ != rewinds || may_go(); });
  return !shut_down_ && (pending || rewinds_ != rewinds || may_go());
}

bool RunControl::run_if_future(std::int64_t internal_step, const std::function<void()>& add) {
  std::lock_guard lock(mutex_);
  if (*std::max_element(started_.begin(), started_.end()) > internal_step) return false;
  add();
  return true;
}

std::int64_t RunControl::hold() {
  std::int64_t h;
  {
    std::lock_guard lock(mutex_);
    hold_ = highest_boundary_begun_locked();
    h = hold_;
    bump_wake_locked();
  }
  call_hook();
  return h;
}

void RunControl::wait_all_held() const {
  std::unique_lock lock(mutex_);
  watch_cv_.wait(lock, [&] {
    return error_ || std::all_of(parked_at_.begin(), parked_at_.end(), [&](std::int64_t p) { return p == hold_; });
  });
  if (error_) throw_error_locked();
}

void RunControl::rewind(std::int64_t internal_step, std::shared_ptr<const WorldSnapshot> state) {
  {
    std::lock_guard lock(mutex_);
    for (std::size_t w = 0; w < started_.size(); ++w) {
      rewind_to_[w] = state;
      started_[w] = internal_step;
      parked_at_[w] = -1;
      published_[w] = std::min(published_[w], internal_step / substeps_);
    }
    hold_ = -1;
    ++rewinds_;
    ++watch_epoch_;
    watch_cv_.notify_all();
    bump_wake_locked();
  }
  call_hook();
}

std::shared_ptr<const WorldSnapshot> RunControl::take_rewind(WorldId world) {
  std::lock_guard lock(mutex_);
  return std::exchange(rewind_to_[static_cast<std::size_t>(world)], nullptr);
}

void RunControl::rolled_back(std::int64_t internal_step) {
  std::lock_guard lock(mutex_);
  for (std::size_t w = 0; w < published_.size(); ++w) {
    published_[w] = std::min(published_[w], internal_step / substeps_);
    if (parked_at_[w] > internal_step) parked_at_[w] = -1;
  }
  ++watch_epoch_;
  watch_cv_.notify_all();
}

void RunControl::release_hold() {
  {
    std::lock_guard lock(mutex_);
    hold_ = -1;
    bump_wake_locked();
  }
  call_hook();
}

bool RunControl::finished(std::int64_t steps_done) const {
  std::lock_guard lock(mutex_);
  return shut_down_ || (frozen_ && steps_done >= limit_);
}

bool RunControl::raise_limit(std::int64_t internal_steps) {
  {
    std::lock_guard lock(mutex_);
    if (frozen_ || shut_down_) return false;
    if (internal_steps <= limit_) return true;
    limit_ = internal_steps;
    bump_wake_locked();
  }
  call_hook();
  return true;
}

std::int64_t RunControl::freeze() {
  std::int64_t limit;
  {
    std::lock_guard lock(mutex_);
    if (!frozen_) {
      limit_ = highest_boundary_begun_locked();
      frozen_ = true;
      bump_wake_locked();
    }
    limit = limit_;
  }
  call_hook();
  return limit;
}

// The end of the highest step any world has begun, rounded up to a scene
// step: every world can reach it, none has gone past it.
std::int64_t RunControl::highest_boundary_begun_locked() const {
  const std::int64_t begun = *std::max_element(started_.begin(), started_.end());
  return (begun + substeps_ - 1) / substeps_ * substeps_;
}

std::int64_t RunControl::limit() const {
  std::lock_guard lock(mutex_);
  return limit_;
}

bool RunControl::all_parked() const {
  std::lock_guard lock(mutex_);
  return all_parked_locked();
}

bool RunControl::all_parked_locked() const {
  return std::all_of(parked_at_.begin(), parked_at_.end(), [&](std::int64_t p) { return p >= limit_; });
}

void RunControl::wait_all_parked() const {
  std::unique_lock lock(mutex_);
  watch_cv_.wait(lock, [&] { return error_ || all_parked_locked(); });
  if (error_) throw_error_locked();
}

std::uint64_t RunControl::wake_epoch() const {
  std::lock_guard lock(mutex_);
  return wake_epoch_;
}

void RunControl::wake() {
  {
    std::lock_guard lock(mutex_);
    bump_wake_locked();
  }
  call_hook();
}

void RunControl::wait_wake(std::uint64_t seen) const {
  std::unique_lock lock(mutex_);
  world_cv_.wait(lock, [&] { return shut_down_ || wake_epoch_ != seen; });
}

void RunControl::set_wake_hook(std::function<void()> hook) {
  std::lock_guard lock(mutex_);
  hook_ = std::move(hook);
}

void RunControl::bump_wake_locked() {
  ++wake_epoch_;
  world_cv_.notify_all();
}

// The hook is copied under the lock and called outside it; it owns what it
// touches (shared pointers), so clearing it meanwhile is harmless.
void RunControl::call_hook() {
  std::function<void()> hook;
  {
    std::lock_guard lock(mutex_);
    hook = hook_;
  }
  if (hook) hook();
}

void RunControl::published(WorldId world, std::int64_t step) {
  std::lock_guard lock(mutex_);
  std::int64_t& p = published_[static_cast<std::size_t>(world)];
  p = std::max(p, step);
  ++watch_epoch_;
  watch_cv_.notify_all();
}

void RunControl::hold_for_readers(std::int64_t room) {
  std::lock_guard lock(mutex_);
  room_ = room;
}

void RunControl::set_final(std::int64_t scene_step) {
  {
    std::lock_guard lock(mutex_);
    if (scene_step <= final_) return;
    final_ = scene_step;
    ++watch_epoch_;
    watch_cv_.notify_all();
    bump_wake_locked();
  }
  call_hook();
}

bool RunControl::readers_hold_horizon() const {
  std::lock_guard lock(mutex_);
  return room_ > 0;
}

std::optional<std::int64_t> RunControl::held_until(std::int64_t steps_done) const {
  std::lock_guard lock(mutex_);
  if (!held_by_readers_locked(steps_done)) return std::nullopt;
  return steps_done / substeps_ + 2 - room_;
}

bool RunControl::held_by_readers_locked(std::int64_t steps_done) const {
  return room_ > 0 && steps_done % substeps_ == 0 && steps_done / substeps_ + 1 - final_ >= room_;
}

std::int64_t RunControl::published_step() const {
  std::lock_guard lock(mutex_);
  return *std::min_element(published_.begin(), published_.end());
}

std::vector<std::int64_t> RunControl::published_steps() const {
  std::lock_guard lock(mutex_);
  return published_;
}

std::uint64_t RunControl::watch_epoch() const {
  std::lock_guard lock(mutex_);
  return watch_epoch_;
}

void RunControl::wait_watch(std::uint64_t seen) const {
  std::unique_lock lock(mutex_);
  watch_cv_.wait(lock, [&] { return watch_epoch_ != seen; });
}

bool RunControl::wait_published(std::int64_t step) const {
  std::unique_lock lock(mutex_);
  watch_cv_.wait(lock, [&] {
    return error_ || stopping_ || *std::min_element(published_.begin(), published_.end()) >= step;
  });
  if (error_) throw_error_locked();
  return *std::min_element(published_.begin(), published_.end()) >= step;
}

void RunControl::request_stop() {
  std::lock_guard lock(mutex_);
  stopping_ = true;
  ++watch_epoch_;
  watch_cv_.notify_all();
}

bool RunControl::stopping() const {
  std::lock_guard lock(mutex_);
  return stopping_;
}

bool RunControl::fail(WorldId world, std::exception_ptr error) {
  std::string message = "unknown error";
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    message = e.what();
  } catch (...) {
  }
  bool first = false;
  {
    std::lock_guard lock(mutex_);
    if (!error_) {
      error_.emplace(world, message, error);
      first = true;
    }
    shut_down_ = true;
    ++watch_epoch_;
    watch_cv_.notify_all();
    bump_wake_locked();
  }
  call_hook();
  return first;
}

bool RunControl::failed() const {
  std::lock_guard lock(mutex_);
  return error_.has_value();
}

bool RunControl::shut_down() const {
  std::lock_guard lock(mutex_);
  return shut_down_;
}

std::optional<SimulationError> RunControl::error() const {
  std::lock_guard lock(mutex_);
  return error_;
}

void RunControl::rethrow_if_failed() const {
  std::lock_guard lock(mutex_);
  if (error_) throw_error_locked();
}

bool RunControl::error_reported() const {
  std::lock_guard lock(mutex_);
  return error_reported_;
}

void RunControl::throw_error_locked() const {
  error_reported_ = true;
  throw SimulationError(*error_);
}

}  // namespace soda

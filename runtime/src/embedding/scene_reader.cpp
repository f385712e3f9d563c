// SceneReader: whole-scene frames from every world's transform buffer.
//
// Why a read cannot deadlock the worlds (docs/embedding.md, "Back-pressure"):
// every pass of a read moves this reader's cursor in EVERY world to that
// world's newest entry at or before the wanted step, so it pins at most one
// entry per world at or before that step. A world blocked for room is then
// either ahead of the wanted step (and not needed by this read) or held by
// another reader; the worlds the read waits for need only their neighbours,
// which are never more than one step ahead of them.
#include "soda/runtime/scene_reader.h"

#include <algorithm>
#include <functional>
#include <queue>
#include <utility>
#include <stdexcept>
#include <string>

#include <BulletCollision/CollisionDispatch/btCollisionObject.h>  // ISLAND_SLEEPING
#include <LinearMath/btMatrix3x3.h>
#include <LinearMath/btQuaternion.h>

#include "embedding/simulation_core.h"

namespace soda {

ScenePose body_pose(const BodyState& s) {
  ScenePose p;
  p.id = s.id;
  const btMatrix3x3 basis(s.basis[0], s.basis[1], s.basis[2], s.basis[3], s.basis[4], s.basis[5], s.basis[6],
                          s.basis[7], s.basis[8]);
  btQuaternion q;
  basis.getRotation(q);
  for (int i = 0; i < 3; ++i) {
    p.position[i] = s.origin[i];
    p.linear_velocity[i] = s.linear_velocity[i];
    p.angular_velocity[i] = s.angular_velocity[i];
  }
  p.orientation[0] = q.x();
  p.orientation[1] = q.y();
  p.orientation[2] = q.z();
  p.orientation[3] = q.w();
  p.sleeping = s.activation_state == ISLAND_SLEEPING;
  return p;
}

namespace {

const ScenePose* find_pose(const std::vector<ScenePose>& poses, BodyId id) {
  auto it = std::lower_bound(poses.begin(), poses.end(), id, [](const ScenePose& p, BodyId i) { return p.id < i; });
  return it != poses.end() && it->id == id ? &*it : nullptr;
}

}  // namespace

const ScenePose* SceneFrame::find(BodyId id) const { return find_pose(poses, id); }

const ScenePose* SceneFrame::find_kinematic(BodyId id) const { return find_pose(kinematic, id); }

SceneReader::SceneReader(std::shared_ptr<SimulationCore> core, bool pins) : core_(std::move(core)) {
  for (auto& b : core_->buffers) ids_.push_back(b->add_reader());
  if (pins && core_->reader_pins) pinned_ = core_->pin_first();
}

SceneReader::SceneReader(SceneReader&& other) noexcept
    : core_(std::move(other.core_)), ids_(std::move(other.ids_)), last_step_(other.last_step_), pinned_(other.pinned_) {
  other.ids_.clear();
  other.pinned_ = -1;
}

SceneReader& SceneReader::operator=(SceneReader&& other) noexcept {
  if (this != &other) {
    release();
    core_ = std::move(other.core_);
    ids_ = std::move(other.ids_);
    other.ids_.clear();
    last_step_ = other.last_step_;
    pinned_ = other.pinned_;
    other.pinned_ = -1;
  }
  return *this;
}

SceneReader::~SceneReader() { release(); }

void SceneReader::release() noexcept {
  if (!core_ || ids_.empty()) return;
  try {
    for (std::size_t w = 0; w < ids_.size(); ++w) core_->buffers[w]->remove_reader(ids_[w]);
    if (pinned_ >= 0) core_->unpin(pinned_);
    core_->control.wake();  // entries it pinned may be free now
  } catch (...) {
  }
  pinned_ = -1;
  ids_.clear();
}

// Reader pins: this reader now uses frames up to `step` (docs/embedding.md,
// "The game loop"); the horizon may pass the frames before it.
void SceneReader::use_up_to(std::int64_t step) {
  if (pinned_ < 0 || step <= pinned_) return;
  core_->move_pin(pinned_, step);
  pinned_ = step;
  core_->control.wake();  // worlds held by the horizon may go on
}

// One pass over every world (never stopping early: every cursor must move,
// see the top of the file). With move_cursors, read_at(reader) moves the
// reader's cursor to the world's newest entry at or before the step;
// without, entries are looked up without a cursor (for the step after the
// reader's, which its cursor keeps from being freed).
Gathered gather_entries(SimulationCore& core, const std::vector<BufferReaderId>& ids, std::int64_t step,
                        bool move_cursors, std::vector<std::shared_ptr<const TransformEntry<btScalar>>>& out) {
  const double time = core.time_of(step);
  out.assign(ids.size(), nullptr);
  bool gone = false, not_yet = false, moved = false;
  for (std::size_t w = 0; w < ids.size(); ++w) {
    TransformBuffer<btScalar>& buffer = *core.buffers[w];
    std::shared_ptr<const TransformEntry<btScalar>> e;
    if (move_cursors) {
      const std::int64_t before = buffer.cursor(ids[w]);
      e = buffer.read_at(ids[w], time);
      moved = moved || (e && e->step != before);
    } else {
      e = buffer.read_at(time);
    }
    // Nothing at or before `time` held: gone if the step's entry was freed
    // (it was final: nothing will bring it back); else a rollback dropped
    // every held entry from some step at or before this one, and the world
    // republishes them (freed entries and the readers' cursors may both be
    // past the commit step's entry when the world rolls back above it).
    if (!e) (buffer.freed_step() >= step ? gone : not_yet) = true;
    else if (e->step != step) not_yet = true;
    else out[w] = std::move(e);
  }
  if (moved) core.control.wake();
  // A frame a rollback may still rewrite is not served (simulation_core.h).
  return gone ? Gathered::Gone : (not_yet || !core.is_final(step)) ? Gathered::NotYet : Gathered::Frame;
}

SceneReader::Got SceneReader::gather(std::int64_t step, bool move_cursors,
                                     std::vector<std::shared_ptr<const TransformEntry<btScalar>>>& out) {
  if (!core_ || ids_.empty()) throw std::logic_error("SceneReader: used after being moved from");
  switch (gather_entries(*core_, ids_, step, move_cursors, out)) {
    case Gathered::Frame: return Got::Frame;
    case Gathered::Gone: return Got::Gone;
    case Gathered::NotYet: break;
  }
  return Got::NotYet;
}

SceneFrame SceneReader::assemble(std::int64_t step,
                                 const std::vector<std::shared_ptr<const TransformEntry<btScalar>>>& entries) const {
  SceneFrame f;
  f.step = step;
  f.time = core_->time_of(step);
  std::size_t n = 0;
  for (const auto& e : entries) n += e->poses.size();
  f.poses.reserve(n);
  f.owners.reserve(n);
  f.busy_seconds.reserve(entries.size());
  // Each entry is sorted by id: merge them, noting whose entry held each.
  using Head = std::pair<BodyId, std::size_t>;  // (id, world)
  std::priority_queue<Head, std::vector<Head>, std::greater<>> heads;
  std::vector<std::size_t> next(entries.size(), 0);
  for (std::size_t w = 0; w < entries.size(); ++w) {
    f.busy_seconds.push_back(entries[w]->busy_seconds);
    if (!entries[w]->poses.empty()) heads.emplace(entries[w]->poses.front().id, w);
  }
  while (!heads.empty()) {
    const std::size_t w = heads.top().second;
    heads.pop();
    const std::vector<ScenePose>& poses = entries[w]->poses;
    f.poses.push_back(poses[next[w]]);
    f.owners.push_back(static_cast<WorldId>(w));
    if (++next[w] < poses.size()) heads.emplace(poses[next[w]].id, w);
  }
  for (std::size_t i = 1; i < f.poses.size(); ++i) {
    if (f.poses[i].id != f.poses[i - 1].id) continue;
    std::string worlds;
    for (std::size_t w = 0; w < entries.size(); ++w)
      for (const ScenePose& p : entries[w]->poses)
        if (p.id == f.poses[i].id) worlds.append(" ").append(std::to_string(w));
    std::string what = "SceneReader: body ";
    what.append(std::to_string(f.poses[i].id)).append(" is in more than one world at step ");
    what.append(std::to_string(step)).append(" (worlds").append(worlds).append(")");
    throw std::logic_error(what);
  }
  std::vector<BodyId> ids;
  ids.reserve(f.poses.size());
  for (const ScenePose& p : f.poses) ids.push_back(p.id);
  core_->census.check(step, ids);
  for (const BodyState& k : core_->census.kinematic_states(step)) f.kinematic.push_back(body_pose(k));
  return f;
}

std::optional<SceneFrame> SceneReader::read(double time, bool wait) {
  const std::int64_t step = core_ ? core_->step_at(time) : 0;
  use_up_to(step);
  std::vector<std::shared_ptr<const TransformEntry<btScalar>>> entries;
  for (;;) {
    const std::uint64_t seen = core_ ? core_->control.watch_epoch() : 0;
    switch (gather(step, true, entries)) {
      case Got::Frame: last_step_ = step; return assemble(step, entries);
      case Got::Gone: return std::nullopt;
      case Got::NotYet: break;
    }
    if (!wait) return std::nullopt;
    core_->control.rethrow_if_failed();
    if (core_->control.stopping()) return std::nullopt;
    core_->control.wait_watch(seen);
  }
}

std::optional<SceneFrame> SceneReader::read_at(double time) { return read(time, true); }

std::optional<BodyAt> SceneReader::properties(std::int64_t step, BodyId id) const {
  Body d;
  if (!core_ || !core_->census.properties(id, step, d)) return std::nullopt;
  BodyAt out;
  out.step = step;
  out.time = core_->time_of(step);
  out.pose.id = id;
  out.mass = d.mass;
  out.friction = d.friction;
  out.restitution = d.restitution;
  out.user_data = d.user_data;
  out.collision_group = d.collision_group;
  out.collision_mask = d.collision_mask;
  return out;
}

namespace {

std::optional<BodyAt> body_of(const SceneReader& reader, const std::optional<SceneFrame>& frame, BodyId id) {
  if (!frame) return std::nullopt;
  const ScenePose* pose = frame->find(id);
  const ScenePose* kinematic = pose ? nullptr : frame->find_kinematic(id);
  if (!pose && !kinematic) return std::nullopt;
  std::optional<BodyAt> out = reader.properties(frame->step, id);
  if (!out) return std::nullopt;
  out->time = frame->time;
  out->pose = pose ? *pose : *kinematic;
  out->owner = pose ? frame->owners[static_cast<std::size_t>(pose - frame->poses.data())] : kNoWorld;
  return out;
}

}  // namespace

std::optional<BodyAt> SceneReader::body_at(double time, BodyId id) { return body_of(*this, read(time, true), id); }

std::optional<BodyAt> SceneReader::try_body_at(double time, BodyId id) {
  return body_of(*this, read(time, false), id);
}

std::optional<SceneFrame> SceneReader::try_read_at(double time) { return read(time, false); }

std::optional<SceneSample> SceneReader::interpolate(double time) {
  // Both frames must be final: between two steps the later one is in use too.
  if (core_) {
    const std::int64_t step = core_->step_at(time);
    use_up_to(core_->time_of(step) == time ? step : step + 1);
  }
  std::optional<SceneFrame> before = read(time, true);
  if (!before) return std::nullopt;
  auto entry_of = [](SceneFrame&& f) {
    TransformEntry<btScalar> e;
    e.step = f.step;
    e.time = f.time;
    e.poses = std::move(f.poses);
    return e;
  };
  const TransformEntry<btScalar> a = entry_of(std::move(*before));
  if (a.time == time) return interpolate_entries(a, a, time);
  std::vector<std::shared_ptr<const TransformEntry<btScalar>>> entries;
  for (;;) {
    const std::uint64_t seen = core_->control.watch_epoch();
    const Got got = gather(a.step + 1, false, entries);
    if (got == Got::Frame) return interpolate_entries(a, entry_of(assemble(a.step + 1, entries)), time);
    core_->control.rethrow_if_failed();
    if (got == Got::Gone || core_->control.stopping()) return interpolate_entries(a, a, time);
    core_->control.wait_watch(seen);
  }
}

}  // namespace soda

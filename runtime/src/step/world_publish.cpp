// One world's Publish stage (world_process.h): under a Simulation, the
// poses of the owned bodies after each scene step go to the world's
// transform buffer; a full buffer holds the world back.
#include <algorithm>

#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/scene_reader.h"
#include "embedding/run_control.h"
#include "step/world_process.h"

namespace soda {

TransformEntry<btScalar> transform_entry(std::int64_t scene_step, double dt, const std::vector<BodyState>& states) {
  TransformEntry<btScalar> e;
  e.step = scene_step;
  e.time = scene_time(scene_step, dt);
  e.poses.reserve(states.size());
  for (const BodyState& b : states) e.poses.push_back(body_pose(b));
  return e;
}

// A pair is reported by the owner of its key body (TerritoryWorld::key_body):
// that world holds the pair's contact state at every step boundary, live or
// kept (TerritoryWorld invariant 4), and every copy of it is the same bits.
std::vector<PairContact<btScalar>> reported_contacts(const TerritoryWorld& world,
                                                     const std::vector<ManifoldState>& manifolds,
                                                     const std::vector<BodyId>& owned) {
  std::vector<PairContact<btScalar>> out;
  for (const ManifoldState& m : manifolds) {
    if (m.points.empty()) continue;
    if (!std::binary_search(owned.begin(), owned.end(), world.key_body(m.id0, m.id1))) continue;
    if (!out.empty() && out.back().a == m.id0 && out.back().b == m.id1) continue;  // live and kept: one state
    PairContact<btScalar>& c = out.emplace_back();
    c.a = m.id0;
    c.b = m.id1;
    c.point_count = static_cast<std::uint32_t>(m.points.size());
    for (std::size_t i = 0; i < m.points.size(); ++i) {
      const ContactPointState& p = m.points[i];
      PairContactPoint<btScalar>& q = c.points[i];
      for (int k = 0; k < 3; ++k) {
        q.position_on_a[k] = p.position_world_on_a[k];
        q.position_on_b[k] = p.position_world_on_b[k];
        q.normal_on_b[k] = p.normal_world_on_b[k];
      }
      q.distance = p.distance;
      q.impulse = p.applied_impulse;
    }
  }
  return out;
}

// Publish: first the entries a rejoin took back (s_.backlog), then, if due,
// the entry of the step just ended, made once; a full buffer keeps it
// pending. A stopped buffer drops it (the run is being stopped).
bool PartitionedWorld::Process::try_publish() {
  while (!s_.backlog.empty()) {
    const std::int64_t scene_step = s_.backlog.front().step;
    if (output_.buffer->try_publish(std::move(s_.backlog.front()))) {
      s_.backlog.pop_front();
      entry_published(scene_step, true);
    } else if (!output_.buffer->stopped()) {
      if (!s_.room_wait_since_ns) s_.room_wait_since_ns = wall_ns();
      return false;
    } else {
      s_.backlog.pop_front();
      entry_published(scene_step, false);
    }
  }
  if (!s_.publish_current) {
    s_.phase = StepPhase::Predict;
    return true;
  }
  if (!s_.pending) {
    s_.pending = transform_entry(s_.step / substeps_, output_.dt, s_.world->owned_states());
    if (output_.contacts)
      s_.pending->contacts = reported_contacts(*s_.world, s_.world->kept_contact_state(), s_.world->owned_ids());
    const std::int64_t cpu_ns = clock_.published().cpu_ns_sum;  // published at the step's end
    s_.pending->busy_seconds = static_cast<double>(cpu_ns - entry_cpu_mark_ns_) * 1e-9;
    entry_cpu_mark_ns_ = cpu_ns;
  }
  if (output_.buffer->try_publish(std::move(*s_.pending))) {
    published(true);
    return true;
  }
  if (!output_.buffer->stopped()) {
    if (!s_.room_wait_since_ns) s_.room_wait_since_ns = wall_ns();
    return false;
  }
  published(false);
  return true;
}

void PartitionedWorld::Process::publish_blocking() {
  StageClock::Scope stage(clock_, Stage::Publish);
  while (!s_.backlog.empty()) {
    if (!s_.room_wait_since_ns) s_.room_wait_since_ns = wall_ns();
    const std::int64_t scene_step = s_.backlog.front().step;
    const bool kept = output_.buffer->publish(std::move(s_.backlog.front()));
    s_.backlog.pop_front();
    entry_published(scene_step, kept);
  }
  if (!s_.pending) {
    if (try_publish()) return;
  }
  if (!s_.room_wait_since_ns) s_.room_wait_since_ns = wall_ns();
  published(output_.buffer->publish(std::move(*s_.pending)));
}

// Without speculation no step is ever rolled back: the commit step follows
// the writer, one behind, so that the newest entry stays readable even with
// no reader (a reader added later starts from it).
void PartitionedWorld::Process::published(bool kept) {
  const std::int64_t scene_step = s_.pending->step;
  s_.pending.reset();
  s_.publish_current = false;
  s_.phase = StepPhase::Predict;
  entry_published(scene_step, kept);
}

void PartitionedWorld::Process::entry_published(std::int64_t scene_step, bool kept) {
  if (s_.room_wait_since_ns) {
    room_blocked_ns_ += wall_ns() - s_.room_wait_since_ns;
    clock_.add_wait(Stage::Publish, wall_ns() - s_.room_wait_since_ns);
  }
  s_.room_wait_since_ns = 0;
  s_.next_publish = scene_step + 1;
  if (!kept) {
    ++entries_dropped_;
    return;
  }
  ++entries_published_;
  clock_.count(Stage::Publish, 1);
  spec_->published(scene_step);  // what is committed now (lockstep.h, anticipation.h)
}

}  // namespace soda

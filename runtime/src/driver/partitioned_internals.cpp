#include "driver/partitioned_internals.h"

#include <algorithm>
#include <mutex>
#include <stdexcept>
#include <string>

namespace soda {

// The scheduler's view of a world process: its public members, one for one.
class PartitionedWorld::Internals::ProcessTask final : public WorldTask {
 public:
  explicit ProcessTask(Process& process) : process_(process) {}
  // Every call that changes the process, under its activity lock (readers
  // of metrics() wait for it); publish_blocking may block and takes none.
  Advance advance() override {
    std::lock_guard lock(process_.activity());
    const Process::Advance a = process_.advance();
    return Advance{a.progressed, a.done};
  }
  void deliver(Message message) override {
    std::lock_guard lock(process_.activity());
    process_.hold(std::move(message));
  }
  bool waiting_for_room() const override { return process_.waiting_for_room(); }
  void publish_blocking() override { process_.publish_blocking(); }
  std::int64_t steps_done() const override { return process_.steps_done(); }
  std::string waiting_for() const override { return process_.waiting_for(); }
  void add_blocked_ns(std::int64_t ns) override {
    std::lock_guard lock(process_.activity());
    process_.add_blocked_ns(ns);
  }
  void add_guest_work(std::int64_t tasks, std::int64_t cpu_ns) override {
    std::lock_guard lock(process_.activity());
    process_.add_guest_work(tasks, cpu_ns);
  }

 private:
  Process& process_;
};

void PartitionedWorld::Internals::add_process(std::unique_ptr<Process> process) {
  tasks.push_back(std::make_unique<ProcessTask>(*process));
  processes.push_back(std::move(process));
}

std::vector<WorldTask*> PartitionedWorld::Internals::task_list() const {
  std::vector<WorldTask*> out;
  for (const auto& t : tasks) out.push_back(t.get());
  return out;
}

std::optional<WorldSnapshot> PartitionedWorld::Internals::kept_snapshot(std::int64_t scene_step, int substeps) const {
  for (const auto& p : processes)
    if (!p->kept_state(scene_step)) return std::nullopt;
  std::vector<WorldSnapshot> parts;
  for (const auto& p : processes) parts.push_back(*p->kept_state(scene_step));
  WorldSnapshot whole = assemble(scene_step, std::move(parts));
  whole.settings.substeps = substeps;  // the boundary may have been kept by a re-simulation
  return whole;
}

// Bodies by id (one owner each); a pair's contact state may be held by one
// world and kept by its key body's owner, and the copies must be identical.
WorldSnapshot PartitionedWorld::Internals::assemble(std::int64_t scene_step, std::vector<WorldSnapshot> parts) const {
  return assemble(scene_step, std::move(parts), worlds.front()->static_snapshots());
}

WorldSnapshot PartitionedWorld::Internals::assemble(std::int64_t scene_step, std::vector<WorldSnapshot> parts,
                                                    std::vector<BodySnapshot> statics) {
  WorldSnapshot s;
  s.settings = parts.front().settings;
  s.steps_done = scene_step;
  s.bodies = std::move(statics);
  std::vector<ManifoldState> manifolds;
  for (WorldSnapshot& part : parts) {
    s.bodies.insert(s.bodies.end(), std::make_move_iterator(part.bodies.begin()),
                    std::make_move_iterator(part.bodies.end()));
    manifolds.insert(manifolds.end(), std::make_move_iterator(part.manifolds.begin()),
                     std::make_move_iterator(part.manifolds.end()));
    s.joints.insert(s.joints.end(), std::make_move_iterator(part.joints.begin()),
                    std::make_move_iterator(part.joints.end()));
  }
  // A joint is held by the one world that owns its group (territory_world.h).
  std::sort(s.joints.begin(), s.joints.end(),
            [](const JointSnapshot& a, const JointSnapshot& b) { return a.description.id < b.description.id; });
  for (std::size_t i = 1; i < s.joints.size(); ++i)
    if (s.joints[i].description.id == s.joints[i - 1].description.id)
      throw std::logic_error("PartitionedWorld::snapshot: joint " + std::to_string(s.joints[i].description.id) +
                             " is held by two worlds");
  std::sort(s.bodies.begin(), s.bodies.end(), [](const BodySnapshot& a, const BodySnapshot& b) {
    return a.description.id < b.description.id;
  });
  for (std::size_t i = 1; i < s.bodies.size(); ++i)
    if (s.bodies[i].description.id == s.bodies[i - 1].description.id)
      throw std::logic_error("PartitionedWorld::snapshot: body " + std::to_string(s.bodies[i].description.id) +
                             " is owned by two worlds");
  std::stable_sort(manifolds.begin(), manifolds.end(), [](const ManifoldState& a, const ManifoldState& b) {
    return std::make_pair(a.id0, a.id1) < std::make_pair(b.id0, b.id1);
  });
  for (ManifoldState& m : manifolds) {
    if (!s.manifolds.empty() && s.manifolds.back().id0 == m.id0 && s.manifolds.back().id1 == m.id1) {
      if (contact_hash({s.manifolds.back()}) != contact_hash({m}))
        throw std::logic_error("PartitionedWorld::snapshot: two worlds hold different contact states for pair " +
                               std::to_string(m.id0) + "-" + std::to_string(m.id1));
      continue;
    }
    s.manifolds.push_back(std::move(m));
  }
  return s;
}

}  // namespace soda

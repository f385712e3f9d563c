#include "step/validator.h"

#include <algorithm>
#include <sstream>

#include "soda/runtime/partitioned_world.h"

namespace soda {

Validator::Validator(const Scene& scene, int world_count, bool gathered)
    : world_count_(world_count), gathered_(gathered) {
  for (const Body& b : scene.bodies) {
    if (b.is_static) {
      ++static_count_;
    } else {
      lives_[b.id] = Life{};
    }
  }
}

void Validator::expect(const UserInput& in, int substeps) {
  std::lock_guard lock(lives_mutex_);
  const std::int64_t boundary = in.step * substeps;
  if (in.kind == UserInput::Kind::AddBody) lives_[in.body.id] = Life{boundary, INT64_MAX};
  if (in.kind == UserInput::Kind::RemoveBody) lives_[in.id].removed = boundary;
}

void Validator::expect_bodies(const std::vector<BodyId>& ids) {
  std::lock_guard lock(lives_mutex_);
  for (BodyId id : ids) lives_.try_emplace(id);
}

void Validator::report(WorldStepReport r) {
  std::vector<WorldStepReport> complete;
  std::int64_t step = r.step;
  {
    std::lock_guard lock(mutex_);
    std::vector<WorldStepReport>& list = pending_[step];
    list.push_back(std::move(r));
    if (gathered_ || static_cast<int>(list.size()) < world_count_) return;
    complete = std::move(list);
    pending_.erase(step);
    ++checked_;
  }
  check(step, complete);
}

std::int64_t Validator::steps_checked() const {
  std::lock_guard lock(mutex_);
  return checked_;
}

std::vector<WorldStepReport> Validator::take_pending() {
  std::lock_guard lock(mutex_);
  std::vector<WorldStepReport> out;
  for (auto& [step, list] : pending_)
    for (WorldStepReport& r : list) out.push_back(std::move(r));
  pending_.clear();
  return out;
}

void Validator::check_gathered(std::vector<WorldStepReport> reports) {
  for (WorldStepReport& r : reports) incomplete_[r.step].push_back(std::move(r));
  for (auto it = incomplete_.begin(); it != incomplete_.end();) {
    if (static_cast<int>(it->second.size()) < world_count_) {
      ++it;
      continue;
    }
    // In world order: the same list, hence the same message, on every rank.
    std::sort(it->second.begin(), it->second.end(),
              [](const WorldStepReport& a, const WorldStepReport& b) { return a.world < b.world; });
    const std::int64_t step = it->first;
    const std::vector<WorldStepReport> complete = std::move(it->second);
    it = incomplete_.erase(it);
    {
      std::lock_guard lock(mutex_);
      ++checked_;
    }
    check(step, complete);
  }
}

void Validator::check(std::int64_t step, const std::vector<WorldStepReport>& reports) const {
  std::ostringstream err;
  for (const WorldStepReport& r : reports) {
    if (r.statics > static_count_)
      err << "world " << r.world << " holds " << r.statics << " statics, the scene has " << static_count_ << "; ";
    if (r.parked > r.owned.size() || r.bullet_objects != r.owned.size() - r.parked + r.ghosts + r.statics)
      err << "world " << r.world << " has " << r.bullet_objects << " Bullet objects but " << r.owned.size()
          << " owned (" << r.parked << " of them parked) + " << r.ghosts << " ghosts + " << r.statics << " statics; ";
  }
  std::map<BodyId, std::vector<WorldId>> owners;
  for (const WorldStepReport& r : reports)
    for (BodyId id : r.owned) owners[id].push_back(r.world);
  {
    std::lock_guard lock(lives_mutex_);
    for (const auto& [id, ws] : owners) {
      auto life = lives_.find(id);
      if (life == lives_.end()) {
        err << "body " << id << " is owned but is not a dynamic body of the scene or of an input; ";
      } else if (!expected(life->second, step)) {
        err << "body " << id << " is owned but is not in the scene then (";
        if (life->second.added >= step) err << "added by an input at internal step boundary " << life->second.added;
        else err << "removed by an input at internal step boundary " << life->second.removed;
        err << "); ";
      } else if (ws.size() > 1) {
        err << "body " << id << " is owned by worlds";
        for (WorldId w : ws) err << " " << w;
        err << "; ";
      }
    }
    for (const auto& [id, life] : lives_)
      if (expected(life, step) && !owners.count(id)) err << "body " << id << " has no owner (lost); ";
  }
  std::map<std::pair<BodyId, BodyId>, std::vector<WorldId>> holders;
  for (const WorldStepReport& r : reports)
    for (const auto& p : r.held_pairs) holders[p].push_back(r.world);
  for (const auto& [p, ws] : holders)
    if (ws.size() > 1) {
      err << "contact state of pair " << p.first << "-" << p.second << " is held by worlds";
      for (WorldId w : ws) err << " " << w;
      err << "; ";
    }
  const std::string e = err.str();
  if (!e.empty()) throw ValidationError("validation failed after step " + std::to_string(step) + ": " + e);
}

}  // namespace soda

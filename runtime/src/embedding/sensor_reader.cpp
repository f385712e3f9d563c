// SensorReader: the overlaps of every sensor at each committed step, diffed
// against the step before (sensor_reader.h).
#include "soda/runtime/sensor_reader.h"

#include <stdexcept>
#include <string>
#include <utility>

#include "embedding/simulation_core.h"
#include "soda/scene/fnv1a.h"

namespace soda {

const char* to_string(SensorEventKind kind) { return kind == SensorEventKind::Begin ? "begin" : "end"; }

std::uint64_t sensor_stream_hash(const std::vector<SensorStep>& steps) {
  std::uint64_t h = kFnv1aOffset;
  for (const SensorStep& s : steps)
    for (const SensorEvent& e : s.events) {
      fnv1a_mix(h, &e.step, sizeof e.step);
      const auto kind = static_cast<std::uint8_t>(e.kind);
      fnv1a_mix(h, &kind, sizeof kind);
      fnv1a_mix(h, &e.sensor, sizeof e.sensor);
      fnv1a_mix(h, &e.body, sizeof e.body);
    }
  return h;
}

namespace {

std::vector<SensorOverlap> overlaps_of(const std::vector<std::pair<BodyId, BodyId>>& pairs) {
  std::vector<SensorOverlap> out;
  out.reserve(pairs.size());
  for (const auto& [sensor, body] : pairs) out.push_back(SensorOverlap{sensor, body});
  return out;
}

// Both sides ascending: a merge, begin for what is new, end for what is gone.
std::vector<SensorEvent> diff(std::int64_t step, const std::vector<SensorOverlap>& before,
                              const std::vector<SensorOverlap>& now) {
  std::vector<SensorEvent> out;
  std::size_t i = 0, j = 0;
  while (i < before.size() || j < now.size()) {
    if (j == now.size() || (i < before.size() && before[i] < now[j])) {
      out.push_back(SensorEvent{step, SensorEventKind::End, before[i].sensor, before[i].body});
      ++i;
    } else if (i == before.size() || now[j] < before[i]) {
      out.push_back(SensorEvent{step, SensorEventKind::Begin, now[j].sensor, now[j].body});
      ++j;
    } else {
      ++i, ++j;
    }
  }
  return out;
}

}  // namespace

SensorReader::SensorReader(std::int64_t first_step, SceneQuery query)
    : first_step_(first_step), query_(std::move(query)) {}

SensorReader::SensorReader(SensorReader&&) noexcept = default;
SensorReader& SensorReader::operator=(SensorReader&&) noexcept = default;
SensorReader::~SensorReader() = default;

std::optional<SensorStep> SensorReader::read(std::int64_t step, bool wait) {
  if (step < first_step_)
    throw std::invalid_argument("SensorReader: step " + std::to_string(step) + " is before the run's first step " +
                                std::to_string(first_step_));
  if (step == last_.step) return last_;
  if (step < last_.step) return std::nullopt;
  // The overlaps of the step before: the last step read's when it is that
  // one (not copied), else read now; none before the run's first step.
  std::vector<SensorOverlap> earlier;
  const std::vector<SensorOverlap>* before = &earlier;
  if (step > first_step_) {
    if (last_.step == step - 1) {
      before = &last_.inside;
    } else {
      auto pairs = query_.sensor_overlaps(step - 1, wait);
      if (!pairs) return std::nullopt;
      earlier = overlaps_of(*pairs);
    }
  }
  auto pairs = query_.sensor_overlaps(step, wait);
  if (!pairs) return std::nullopt;
  SensorStep out;
  out.step = step;
  out.time = query_.core_->time_of(step);
  out.inside = overlaps_of(*pairs);
  out.events = diff(step, *before, out.inside);
  last_ = out;
  return out;
}

std::optional<SensorStep> SensorReader::read_step(std::int64_t step) { return read(step, true); }
std::optional<SensorStep> SensorReader::try_read_step(std::int64_t step) { return read(step, false); }
std::optional<SensorStep> SensorReader::read_next() { return read(last_.step < 0 ? first_step_ : last_.step + 1, true); }

}  // namespace soda

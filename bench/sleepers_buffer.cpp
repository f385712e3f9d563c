// `soda bench sleepers --buffer-steps C`: what a buffered step of the
// transform buffers costs in memory, the sleepers scene against its active
// bodies alone, delta entries on and off (docs/memory.md, "Transform
// buffers").
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "soda/bench/sleepers.h"
#include "soda/runtime/simulation.h"

namespace soda {

BufferMemoryRun buffer_memory_run(const Scene& scene, int territories, int from, std::size_t capacity, bool delta) {
  if (capacity < 2) throw std::invalid_argument("--buffer-steps must be >= 2");
  SimulationConfig config{.territories = territories, .buffer_capacity = capacity};
  config.delta_entries = delta;
  Simulation sim(scene, config);
  SceneReader reader = sim.add_reader();
  // Read every step up to `from` (a reader that does not read stalls the
  // worlds once the buffers are full).
  for (int k = 0; k <= from; ++k)
    if (!sim.advance_to(sim.time_of(k)) || !reader.read_at(sim.time_of(k)))
      throw std::runtime_error("buffer memory run: step " + std::to_string(k) + " not read");
  // The reader stays at `from`: every later entry is pinned, so the buffers
  // fill to `capacity` entries each.
  const std::int64_t last = from + static_cast<std::int64_t>(capacity) - 1;
  if (!sim.advance_to(sim.time_of(last))) throw std::runtime_error("buffer memory run: stopped");
  BufferMemoryRun r;
  r.delta = delta;
  r.bodies = scene.dynamic_count();
  r.from = from;
  for (const BufferMemory& m : sim.buffer_memory()) {
    r.memory.entries += m.entries;
    r.memory.key_entries += m.key_entries;
    r.memory.delta_bytes += m.delta_bytes;
    r.memory.key_bytes += m.key_bytes;
  }
  r.sleeping_bodies = sim.sleeping_count();
  spdlog::info("buffer memory: {} bodies, delta {}: {} entries, {} keys, {} B per step ({} B with keys)", r.bodies,
               delta ? "on" : "off", r.memory.entries, r.memory.key_entries, r.bytes_per_step(),
               r.bytes_per_step_with_keys());
  return r;
}

nlohmann::json buffer_memory_json(const std::vector<BufferMemoryRun>& runs) {
  nlohmann::json rows = nlohmann::json::array();
  for (const BufferMemoryRun& r : runs)
    rows.push_back({{"name", r.name},
                    {"delta", r.delta},
                    {"dynamic_bodies", r.bodies},
                    {"sleeping_bodies", r.sleeping_bodies},
                    {"from_step", r.from},
                    {"entries", r.memory.entries},
                    {"key_entries", r.memory.key_entries},
                    {"delta_bytes", r.memory.delta_bytes},
                    {"key_bytes", r.memory.key_bytes},
                    {"bytes_per_buffered_step", r.bytes_per_step()},
                    {"bytes_per_buffered_step_with_keys", r.bytes_per_step_with_keys()}});
  return rows;
}

}  // namespace soda

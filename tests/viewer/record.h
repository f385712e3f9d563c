// Test helper: a small scene's every frame in a MemoryFrameSource (the
// in-memory stand-in for a replay file), read through a SceneReader of a
// Simulation exactly as the live source reads.
#pragma once

#include <cstdint>
#include <memory>

#include "soda/grid/partition.h"
#include "soda/runtime/simulation.h"
#include "soda/runtime/view_adapter.h"
#include "soda/viewer/live_frame_source.h"
#include "soda/viewer/memory_frame_source.h"

namespace soda::test {

struct Recording {
  std::shared_ptr<viewer::MemoryFrameSource> source;
  std::uint64_t state_hash = 0;
};

/// Runs `scene` for `steps` steps on `territories` worlds (kmeans) and keeps
/// every frame; the last carries the state hash. The first frame only
/// carries the map (the source adds it to the others).
inline Recording record_frames(const Scene& scene, int territories, int steps) {
  SimulationConfig config;
  config.territories = territories;
  const TerritoryMap map = make_partition(config.partition, scene, territories, config.grid);
  Simulation sim(scene, map, config);
  SceneReader reader = sim.add_reader();
  const replay::ViewHeader header = view_header(scene, map);
  const std::vector<std::uint16_t> owners = view_cell_owner(map);
  auto source = std::make_shared<viewer::MemoryFrameSource>(header);
  sim.start(sim.time_of(steps));
  for (int step = 0; step <= steps; ++step) {
    auto frame = reader.read_at(sim.time_of(step));
    if (!frame) throw std::runtime_error("record_frames: step " + std::to_string(step) + " not read");
    replay::ViewFrame f = viewer::to_view_frame(*frame, header, step == 0 ? owners : std::vector<std::uint16_t>{});
    if (step == steps) f.state_hash = sim.state_hash();
    source->add(std::move(f));
  }
  source->finish();
  return {source, sim.state_hash()};
}

}  // namespace soda::test

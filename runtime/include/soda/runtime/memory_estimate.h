// runtime/ — the step, threads, messages and the public API.
// This header: how much memory a run needs, how much the process may have,
// and the refusal when the first exceeds the second (docs/memory.md).
//
// The estimate is a model, not a measurement: bytes per body of a built
// world (measured per precision, contacts of a dense pile included), summed
// over the territories (each world holds its owned bodies, ghosts and every
// static body), plus the states kept to roll back to, plus the transform
// buffers, plus the stacks of the stepping threads. It is checked before any
// world is built, so a scene that cannot fit is refused with a clear message
// instead of dying half-built. Anything the model misses still ends as
// std::bad_alloc (Bullet's allocations too: worlds/bullet_allocator.h).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include "soda/runtime/run.h"
#include "soda/scene/scene.h"

namespace soda {

/// Bytes a run is expected to need beyond what the process holds already
/// (the Scene itself is not counted: it exists when the estimate is made).
struct MemoryEstimate {
  std::uint64_t world_bytes = 0;       // Bullet worlds: bodies, broadphase, pairs, manifolds, SODA entries
  std::uint64_t kept_state_bytes = 0;  // states kept to roll back to (speculation, heal, SyncTest)
  std::uint64_t buffer_bytes = 0;      // transform buffers (embedding API; 0 for run_scene)
  std::uint64_t thread_bytes = 0;      // stacks of the threads that step the worlds (address space)
  std::uint64_t world_body_count = 0;  // bodies summed over the worlds (statics once per world)
  /// The Bullet shapes of static triangle meshes and heightfields (a
  /// mesh's vertices, indices and BVH, a heightfield's heights), built once
  /// per process and shared by every world (level_geometry_bytes()).
  std::uint64_t level_geometry_bytes = 0;

  /// Every byte of the estimate.
  std::uint64_t total() const {
    return world_bytes + kept_state_bytes + buffer_bytes + thread_bytes + level_geometry_bytes;
  }
  /// What will be touched (thread stacks are mostly reserved, not touched).
  std::uint64_t touched() const { return world_bytes + kept_state_bytes + buffer_bytes + level_geometry_bytes; }
};

/// Bytes this process may still get, from each source of a limit. A source
/// with no limit is UINT64_MAX.
struct MemoryBudget {
  std::uint64_t address_space = UINT64_MAX;  // RLIMIT_AS (ulimit -v) minus the process's VmSize
  std::uint64_t data = UINT64_MAX;           // RLIMIT_DATA (ulimit -d) minus its data segment
  std::uint64_t available = UINT64_MAX;      // MemAvailable, or the cgroup's memory.max minus memory.current
};

/// Thrown when a run's estimate does not fit the budget; the message says
/// what the run needs, what limits it and how to get it to fit.
class MemoryLimitError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Per-body bytes of a built world in this build's precision (measured:
/// docs/memory.md). Shared with tests.
std::uint64_t world_bytes_per_body();

/// Bytes of the shared Bullet shapes of the scene's static triangle meshes
/// and heightfields, each data counted once however many bodies or worlds
/// hold it (docs/memory.md, "Static meshes and heightfields"): a mesh's
/// vertices (3 btScalar each), indices (3 int a triangle) and quantized BVH
/// (kBvhBytesPerTriangle), a heightfield's heights (one btScalar a sample).
/// The scene's own copy of the data is not counted (it exists already).
std::uint64_t level_geometry_bytes(const Scene& scene);

/// The model for `scene` run as `config` describes (territories, schedule,
/// speculation, heal, SyncTest). `threads`: threads that will step the
/// worlds (0: only the caller's). Pure; thread-safe.
MemoryEstimate estimate_run_memory(const Scene& scene, const RunConfig& config, int threads);

/// run_scene's estimate for `scene` run as `config` says, with the threads
/// it will start, checked against current_memory_budget(): throws
/// MemoryLimitError naming the scene when it does not fit; returns the
/// estimate. Over ranks (config.group) it is this rank's: the worlds' and
/// kept states' bytes in proportion to the worlds the rank steps.
MemoryEstimate check_run_memory(const Scene& scene, const RunConfig& config);
/// What the process may get now (reads getrlimit, /proc/self/statm,
/// /proc/meminfo and the cgroup v2 memory files; a source that cannot be
/// read imposes no limit). Thread-safe.
MemoryBudget current_memory_budget();

/// Throws MemoryLimitError if `estimate` does not fit `budget`: its total
/// must fit the address space and the data limit, its touched bytes the
/// available memory. `what` names the run in the message.
void check_memory(const MemoryEstimate& estimate, const MemoryBudget& budget, const std::string& what);

}  // namespace soda

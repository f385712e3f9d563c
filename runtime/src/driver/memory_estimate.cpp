#include "soda/runtime/memory_estimate.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include <LinearMath/btScalar.h>

#include "soda/runtime/process_group.h"
#include "soda/worlds/world_snapshot.h"

namespace soda {
namespace {

// Bytes per body of a built world. Float: measured as peak RSS of `soda run
// --scene cube-pile --steps 0` minus that of the scene alone, per body:
// 1,730 B at 100,000 cubes, 1,640 B at 1,000,000 (docs/memory.md), plus
// ~400 B for the manifolds of a resting pile. Double: scaled by the size of
// Bullet's types (not measured yet). Covers the SODA entry, the Bullet
// shape, body, broadphase proxy and tree nodes, pairs with their collision
// algorithms and manifolds.
#if defined(BT_USE_DOUBLE_PRECISION)
constexpr std::uint64_t kWorldBytesPerBody = 3300;
#else
constexpr std::uint64_t kWorldBytesPerBody = 2100;
#endif

// A territory world also holds ghosts of its neighbours' border bodies:
// counted as this share of the dynamic bodies (a thin strip of small
// territories has more; the margin below covers it).
constexpr double kGhostShare = 0.25;

// Manifolds per body in a kept state: a resting dense pile has about three
// manifolds per body. A ManifoldState holds its (at most four) points inline.
constexpr std::uint64_t kKeptManifoldsPerBody = 3;

// The model is refused only when the estimate times this margin does not
// fit: it guards against what the model misses (allocator slack, per-step
// scratch, messages) while keeping the refusal for runs that clearly cannot fit.
constexpr double kSafetyMargin = 1.25;

// A quantized BVH (btOptimizedBvh) has 2 n - 1 nodes of 16 bytes for n
// triangles, plus subtree headers and array slack: measured 33.05 bytes a
// triangle on a 1,002,528-triangle mesh (docs/results/shared-mesh-memory.md:
// 51,200,480 bytes of shape, less its vertices and indices).
constexpr std::uint64_t kBvhBytesPerTriangle = 34;

std::uint64_t kept_state_bytes_per_body() {
  return sizeof(BodySnapshot) + kKeptManifoldsPerBody * sizeof(ManifoldState);
}

// Stack of a std::thread: glibc takes RLIMIT_STACK (8 MiB unless changed),
// or 2 MiB when it is unlimited.
std::uint64_t thread_stack_bytes() {
  rlimit r{};
  if (getrlimit(RLIMIT_STACK, &r) != 0 || r.rlim_cur == RLIM_INFINITY) return 2ull << 20;
  return static_cast<std::uint64_t>(r.rlim_cur);
}

std::uint64_t limit_minus(int resource, std::uint64_t used) {
  rlimit r{};
  if (getrlimit(resource, &r) != 0 || r.rlim_cur == RLIM_INFINITY) return UINT64_MAX;
  const auto limit = static_cast<std::uint64_t>(r.rlim_cur);
  return limit > used ? limit - used : 0;
}

// /proc/self/statm: size resident shared text lib data dt, in pages.
void read_statm(std::uint64_t& vm_bytes, std::uint64_t& data_bytes) {
  vm_bytes = data_bytes = 0;
  std::ifstream in("/proc/self/statm");
  std::uint64_t size = 0, resident = 0, shared = 0, text = 0, lib = 0, data = 0;
  if (!(in >> size >> resident >> shared >> text >> lib >> data)) return;
  const auto page = static_cast<std::uint64_t>(sysconf(_SC_PAGESIZE));
  vm_bytes = size * page;
  data_bytes = data * page;
}

std::uint64_t mem_available() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  std::uint64_t kb = 0;
  std::string unit;
  while (in >> key >> kb) {
    std::getline(in, unit);
    if (key == "MemAvailable:") return kb * 1024;
  }
  return UINT64_MAX;
}

// cgroup v2: memory.max minus memory.current of this process's cgroup.
std::uint64_t cgroup_available() {
  std::ifstream cg("/proc/self/cgroup");
  std::string line;
  while (std::getline(cg, line)) {
    if (line.rfind("0::", 0) != 0) continue;
    const std::string dir = "/sys/fs/cgroup" + line.substr(3);
    std::ifstream max_in(dir + "/memory.max"), cur_in(dir + "/memory.current");
    std::string max_text;
    std::uint64_t current = 0;
    if (!(max_in >> max_text) || max_text == "max" || !(cur_in >> current)) return UINT64_MAX;
    const std::uint64_t max = std::stoull(max_text);
    return max > current ? max - current : 0;
  }
  return UINT64_MAX;
}

std::string gib(std::uint64_t bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f GiB", static_cast<double>(bytes) / double(1ull << 30));
  return text;
}

}  // namespace

std::uint64_t world_bytes_per_body() { return kWorldBytesPerBody; }

std::uint64_t level_geometry_bytes(const Scene& scene) {
  std::set<const void*> seen;  // shared data is built once
  std::uint64_t bytes = 0;
  for (const Body& b : scene.bodies) {
    if (!b.is_static) continue;
    if (b.shape.kind == ShapeKind::TriangleMesh && b.shape.mesh && seen.insert(b.shape.mesh.get()).second)
      bytes += b.shape.mesh->vertices.size() * 3 * sizeof(btScalar) +
               b.shape.mesh->triangles.size() * (3 * sizeof(int) + kBvhBytesPerTriangle);
    if (b.shape.kind == ShapeKind::Heightfield && b.shape.heightfield && seen.insert(b.shape.heightfield.get()).second)
      bytes += b.shape.heightfield->heights.size() * sizeof(btScalar);
  }
  return bytes;
}

MemoryEstimate estimate_run_memory(const Scene& scene, const RunConfig& config, int threads) {
  MemoryEstimate e;
  const std::uint64_t dynamic = scene.dynamic_count();
  const std::uint64_t statics = scene.static_count();
  const bool partitioned = config.territories > 1 || config.sync_test > 0 ||
                           config.runtime.watchdog.response == WatchdogResponse::Heal;
  const auto worlds = static_cast<std::uint64_t>(std::max(1, config.territories));
  // Every world holds every static; ghosts only where there are borders.
  const double ghosts = worlds > 1 ? kGhostShare * static_cast<double>(dynamic) : 0.0;
  e.world_body_count = dynamic + statics * worlds + static_cast<std::uint64_t>(ghosts);
  e.world_bytes = e.world_body_count * kWorldBytesPerBody;
  if (partitioned) {
    // States kept per world, from the commit horizon to its clock: every
    // checkpoint_every internal steps while speculating, every step with
    // heal (lockstep: the horizon is at most a few steps behind).
    const std::uint64_t substeps = static_cast<std::uint64_t>(std::max(1, scene.settings.substeps));
    std::uint64_t kept = 0;
    if (config.runtime.anticipation > 0)
      kept = static_cast<std::uint64_t>(config.runtime.anticipation) * substeps /
                 static_cast<std::uint64_t>(std::max(1, config.runtime.checkpoint_every)) + 2;
    else if (config.runtime.watchdog.response == WatchdogResponse::Heal)
      kept = 3;
    // SyncTest keeps the whole scene's state for its window of steps.
    if (config.sync_test > 0) kept += static_cast<std::uint64_t>(config.sync_test) + 1;
    e.kept_state_bytes = kept * (dynamic + statics) * kept_state_bytes_per_body();
  }
  e.thread_bytes = static_cast<std::uint64_t>(std::max(0, threads)) * thread_stack_bytes();
  e.level_geometry_bytes = level_geometry_bytes(scene);
  return e;
}

MemoryEstimate check_run_memory(const Scene& scene, const RunConfig& config) {
  const int k = config.territories;
  const int threads = k <= 1 || config.threads == 1 ? 0 : (config.threads == 0 || config.threads >= k ? k : config.threads);
  MemoryEstimate e = estimate_run_memory(scene, config, threads);
  if (config.group && k > 1) {
    // A rank builds its worlds' share of the scene (docs/mpi.md, "What a rank
    // holds"): its part of the worlds and kept states, in proportion to the
    // worlds it steps (territories taken as equal), and their threads.
    std::uint64_t own = 0;
    for (WorldId w = 0; w < k; ++w) own += config.group->rank_of(w, k) == config.group->rank();
    e.world_bytes = e.world_bytes * own / static_cast<std::uint64_t>(k);
    e.kept_state_bytes = e.kept_state_bytes * own / static_cast<std::uint64_t>(k);
    e.world_body_count = e.world_body_count * own / static_cast<std::uint64_t>(k);
    if (threads > 0) e.thread_bytes = e.thread_bytes * own / static_cast<std::uint64_t>(k);
  }
  check_memory(e, current_memory_budget(),
               "scene '" + scene.name + "' (" + std::to_string(scene.bodies.size()) + " bodies, " +
                   std::to_string(k) + (k == 1 ? " territory)" : " territories)"));
  return e;
}

MemoryBudget current_memory_budget() {
  MemoryBudget b;
  std::uint64_t vm = 0, data = 0;
  read_statm(vm, data);
  b.address_space = limit_minus(RLIMIT_AS, vm);
  b.data = limit_minus(RLIMIT_DATA, data);
  b.available = std::min(mem_available(), cgroup_available());
  return b;
}

void check_memory(const MemoryEstimate& estimate, const MemoryBudget& budget, const std::string& what) {
  const auto need = [](std::uint64_t bytes) {
    return static_cast<std::uint64_t>(static_cast<double>(bytes) * kSafetyMargin);
  };
  std::string limit;
  std::uint64_t have = UINT64_MAX;
  if (need(estimate.total()) > budget.address_space) {
    limit = "the address-space limit (RLIMIT_AS, ulimit -v)";
    have = budget.address_space;
  } else if (need(estimate.total()) > budget.data) {
    limit = "the data-segment limit (RLIMIT_DATA, ulimit -d)";
    have = budget.data;
  } else if (need(estimate.touched()) > budget.available) {
    limit = "the memory available (MemAvailable, or the cgroup's memory.max)";
    have = budget.available;
  } else {
    return;
  }
  std::ostringstream m;
  m << what << " needs about " << gib(estimate.total()) << " (worlds " << gib(estimate.world_bytes) << ": "
    << estimate.world_body_count << " bodies x " << kWorldBytesPerBody << " B in " << (sizeof(btScalar) == 8 ? "double" : "float")
    << "; level geometry " << gib(estimate.level_geometry_bytes) << " once per process"
    << "; kept states " << gib(estimate.kept_state_bytes) << "; thread stacks " << gib(estimate.thread_bytes)
    << "; a margin of " << kSafetyMargin << "x on top) but " << limit << " leaves " << gib(have)
    << ": use fewer bodies, territories or kept states, or raise the limit (docs/memory.md)";
  throw MemoryLimitError(m.str());
}

}  // namespace soda

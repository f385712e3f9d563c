// Border culling's process-wide switch (territory_world.h, docs/skip.md).
#include <atomic>

#include "safe_box.h"

namespace soda {
namespace {

std::atomic<bool> g_border_culling{true};

}  // namespace

void set_border_culling(bool on) { g_border_culling.store(on, std::memory_order_relaxed); }

bool border_culling() { return g_border_culling.load(std::memory_order_relaxed); }

}  // namespace soda

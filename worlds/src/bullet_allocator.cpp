#include "soda/worlds/bullet_allocator.h"

#include <atomic>
#include <cstdlib>
#include <mutex>
#include <new>

#include <LinearMath/btAlignedAllocator.h>

namespace soda {
namespace {

std::atomic<bool> installed{false};

// Bullet's default is malloc; this is malloc that throws. Paired with free,
// like Bullet's default, so blocks from before the install free correctly.
void* allocate_or_throw(std::size_t size) {
  void* p = std::malloc(size);
  if (!p) throw std::bad_alloc();
  return p;
}

void release(void* p) { std::free(p); }

}  // namespace

void install_bullet_allocator() {
  static std::once_flag once;
  std::call_once(once, [] {
    btAlignedAllocSetCustom(&allocate_or_throw, &release);
    installed.store(true, std::memory_order_release);
  });
}

bool bullet_allocator_installed() { return installed.load(std::memory_order_acquire); }

}  // namespace soda

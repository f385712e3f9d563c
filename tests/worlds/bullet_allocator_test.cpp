// Bullet running out of memory is std::bad_alloc, never a crash
// (worlds/bullet_allocator.h). Each case runs in a forked child: a failure
// before the hook was a SIGSEGV (Bullet memsets the NULL it got).
#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <new>

#include <gtest/gtest.h>
#include <LinearMath/btAlignedAllocator.h>

#include "soda/grid/partition.h"
#include "soda/scene/registry.h"
#include "soda/worlds/bullet_allocator.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/territory_world.h"

namespace {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitized = true;  // sanitizers reserve terabytes of address space: no RLIMIT_AS
#else
constexpr bool kSanitized = false;
#endif

// Bytes of address space the process uses now (VmSize).
std::uint64_t vm_size() {
  std::ifstream in("/proc/self/statm");
  std::uint64_t pages = 0;
  in >> pages;
  return pages * static_cast<std::uint64_t>(sysconf(_SC_PAGESIZE));
}

TEST(BulletAllocatorDeathTest, AnAllocationBulletCannotGetThrowsBadAlloc) {
  EXPECT_EXIT(
      {
        soda::CanonicalWorld world(soda::make_scene("falling-cubes", {10, 1}));  // installs the hook
        if (!soda::bullet_allocator_installed()) std::_Exit(2);
        try {
          void* p = btAlignedAlloc(std::size_t{1} << 62, 16);  // no machine has 4 EiB
          std::printf("got %p\n", p);
          std::_Exit(1);
        } catch (const std::bad_alloc&) {
          std::_Exit(0);
        }
      },
      testing::ExitedWithCode(0), "");
}

// Under an address-space limit a little above what the process holds,
// building worlds of 200,000 cubes runs out of memory part way: bad_alloc
// out of the constructor, the half-built world destroyed without a crash.
TEST(BulletAllocatorDeathTest, WorldsThatDoNotFitThrowBadAllocAndUnwind) {
  if (kSanitized) GTEST_SKIP() << "no RLIMIT_AS under a sanitizer";
  const soda::Scene scene = soda::make_scene("cube-pile", {200000, 1});
  const soda::TerritoryMap map = soda::make_partition("grid:2x1x1", scene, 2, {});
  const auto build_under_limit = [&](int kind) {
    constexpr std::uint64_t kHeadroom = 48ull << 20;  // far below the ~340 MB the worlds need
    rlimit limit{};
    limit.rlim_cur = limit.rlim_max = vm_size() + kHeadroom;
    if (setrlimit(RLIMIT_AS, &limit) != 0) std::_Exit(3);
    try {
      if (kind == 0) {
        soda::CanonicalWorld world(scene);
      } else {
        soda::TerritoryWorld world(scene, 0, map);
      }
      std::_Exit(1);
    } catch (const std::bad_alloc&) {
      std::_Exit(0);
    }
  };
  EXPECT_EXIT(build_under_limit(0), testing::ExitedWithCode(0), "") << "CanonicalWorld";
  EXPECT_EXIT(build_under_limit(1), testing::ExitedWithCode(0), "") << "TerritoryWorld";
}

}  // namespace

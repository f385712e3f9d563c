// Reading a large scene file holds the scene and little else: never the
// file's text, never a document of it (a 10-million-body file died with
// std::terminate from a second bad_alloc in the JSON parser). This
// executable replaces the global operator new/delete to count the bytes
// held, and to refuse allocations above a limit, as a process out of memory
// would: the loader must then throw a SceneError naming the file.
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <new>
#include <string>

#include <gtest/gtest.h>

#include "soda/scene/registry.h"
#include "soda/scene/scene_json.h"
#include "soda/scene/validate.h"

namespace {

constexpr std::size_t kHeader = 16;  // keeps the default new alignment
std::atomic<std::size_t> g_held{0};
std::atomic<std::size_t> g_peak{0};
std::atomic<std::size_t> g_limit{SIZE_MAX};

void* counted_new(std::size_t n) {
  const std::size_t held = g_held.fetch_add(n) + n;
  if (held > g_limit.load()) {
    g_held.fetch_sub(n);
    throw std::bad_alloc();
  }
  std::size_t peak = g_peak.load();
  while (held > peak && !g_peak.compare_exchange_weak(peak, held)) {
  }
  void* p = std::malloc(n + kHeader);
  if (!p) {
    g_held.fetch_sub(n);
    throw std::bad_alloc();
  }
  *static_cast<std::size_t*>(p) = n;
  return static_cast<char*>(p) + kHeader;
}

void counted_delete(void* p) noexcept {
  if (!p) return;
  char* base = static_cast<char*>(p) - kHeader;
  g_held.fetch_sub(*reinterpret_cast<std::size_t*>(base));
  std::free(base);
}

}  // namespace

void* operator new(std::size_t n) { return counted_new(n); }
void* operator new[](std::size_t n) { return counted_new(n); }
void operator delete(void* p) noexcept { counted_delete(p); }
void operator delete[](void* p) noexcept { counted_delete(p); }
void operator delete(void* p, std::size_t) noexcept { counted_delete(p); }
void operator delete[](void* p, std::size_t) noexcept { counted_delete(p); }

namespace soda {
namespace {

constexpr int kBodies = 20000;

class SceneMemory : public ::testing::Test {
 protected:
  std::string path_;
  void SetUp() override {
    path_ = (std::filesystem::temp_directory_path() / ("soda_memory_" + std::to_string(::getpid()) + ".json")).string();
    write_scene_file(make_scene("falling-cubes", {kBodies, 1, false}), path_);
  }
  void TearDown() override { std::filesystem::remove(path_); }
};

TEST_F(SceneMemory, LoadingHoldsTheSceneNotTheTextNorADocument) {
  const std::size_t file_bytes = std::filesystem::file_size(path_);
  const std::size_t before = g_held.load();
  g_peak = before;
  const Scene s = load_scene_file(path_);
  const std::size_t peak = g_peak.load() - before;
  // The bodies' vector grows by doubling: at worst the old and the new
  // buffer, 3x the final size; plus the 1 MiB read buffer and one body's JSON.
  const std::size_t bound = 3 * s.bodies.size() * sizeof(Body) + (std::size_t{2} << 20);
  std::printf("%zu bodies, file %zu bytes, sizeof(Body) %zu: peak held while loading %zu bytes (bound %zu)\n",
              s.bodies.size(), file_bytes, sizeof(Body), peak, bound);
  EXPECT_EQ(s.bodies.size(), static_cast<std::size_t>(kBodies) + 1);
  EXPECT_LT(peak, bound);
}

TEST_F(SceneMemory, OutOfMemoryIsASceneErrorNamingTheFile) {
  g_limit = g_held.load() + kBodies * sizeof(Body) / 2;  // half the bodies fit
  try {
    load_scene_file(path_);
    g_limit = SIZE_MAX;
    FAIL() << "loaded within the limit";
  } catch (const SceneError& e) {
    g_limit = SIZE_MAX;
    std::printf("refused: %s\n", e.what());
    EXPECT_NE(std::string(e.what()).find(path_ + ": out of memory"), std::string::npos) << e.what();
  } catch (const std::bad_alloc&) {
    g_limit = SIZE_MAX;
    FAIL() << "std::bad_alloc escaped the loader";
  }
}

}  // namespace
}  // namespace soda

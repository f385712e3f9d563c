// Nothing lost, counted (docs/soak.md): bodies shuttling across the borders
// of a thin territory map, validation on every step, bodies and contact
// pairs counted from the worlds at the start and at the end; the state hash
// equals one territory's. The small CI version of the ≥ 1,000,000-migration
// soak; also the memory estimate's refusal (runtime/memory_estimate.h).
#include <algorithm>
#include <cstdio>

#include <gtest/gtest.h>

#include "soda/runtime/memory_estimate.h"
#include "soda/runtime/run.h"
#include "soda/scene/registry.h"
#include "soda/worlds/body_state.h"
#include "soda/worlds/canonical_world.h"

namespace {

soda::RunConfig soak_config(int territories) {
  soda::RunConfig c;
  c.steps = 600;
  c.territories = territories;
  c.partition = "grid:32x1x1";
  c.threads = 1;
  c.runtime.validate = true;
  c.progress_seconds = 0;
  return c;
}

TEST(Soak, BorderShuttleLosesNothingAcrossThousandsOfMigrations) {
  const soda::Scene scene = soda::make_scene("border-shuttle", {200, 7});
  const soda::RunResult one = soda::run_scene(scene, soak_config(1));
  const soda::RunResult many = soda::run_scene(scene, soak_config(32));
  std::printf("border-shuttle 200, 32 territories, 600 steps: %llu migrations; bodies %zu -> %zu, contact pairs "
              "%zu -> %zu (one territory %zu); hash %s (one territory %s)\n",
              static_cast<unsigned long long>(many.migrations), many.bodies_at_start, many.bodies_at_end,
              many.contact_pairs_at_start, many.contact_pairs_at_end, one.contact_pairs_at_end,
              soda::hash_hex(many.state_hash).c_str(), soda::hash_hex(one.state_hash).c_str());
  EXPECT_GE(many.migrations, 2000u);
  EXPECT_EQ(many.bodies_at_start, scene.bodies.size());
  EXPECT_EQ(many.bodies_at_end, scene.bodies.size());
  EXPECT_EQ(one.bodies_at_end, scene.bodies.size());
  EXPECT_EQ(many.contact_pairs_at_start, one.contact_pairs_at_start);
  EXPECT_EQ(many.contact_pairs_at_end, one.contact_pairs_at_end);
  EXPECT_GT(many.contact_pairs_at_end, 0u);  // every sphere touches the ground
  EXPECT_EQ(many.state_hash, one.state_hash);
}

// The soak only counts if the spheres keep crossing borders: the scene must
// neither pump energy in (Bullet's elastic contacts did: the spheres of the
// first border-shuttle bounced out of the box) nor bleed it away. Kinetic
// energy of the spheres (1 kg each, frictionless: no spin) at the start and
// after 600 steps (10 s), and every sphere still on the ground.
TEST(Soak, BorderShuttleKeepsItsEnergyAndStaysOnTheGround) {
  const soda::Scene scene = soda::make_scene("border-shuttle", {80, 7});
  double start = 0;
  for (const soda::Body& b : scene.bodies) start += 0.5 * b.mass * b.linear_velocity.squaredNorm();
  soda::CanonicalWorld world(scene);
  constexpr int kSteps = 600;  // 10 s: at most 80 m, no sphere reaches the far wall (>= 90 m away)
  for (int i = 0; i < kSteps; ++i) world.step();
  double end = 0, highest = 0, lowest = 1e9;
  for (const soda::BodyState& s : world.body_states()) {
    if (s.id <= 4) continue;  // ground, walls
    const double v2 = double(s.linear_velocity[0]) * s.linear_velocity[0] +
                      double(s.linear_velocity[1]) * s.linear_velocity[1] +
                      double(s.linear_velocity[2]) * s.linear_velocity[2];
    end += 0.5 * v2;
    highest = std::max(highest, double(s.origin[1]));
    lowest = std::min(lowest, double(s.origin[1]));
  }
  std::printf("border-shuttle 80: kinetic energy %.3f J at the start, %.3f J after %d steps; centres at y "
              "%.4f .. %.4f m\n",
              start, end, kSteps, lowest, highest);
  EXPECT_GT(end, 0.999 * start);  // crossings go on at the same pace
  EXPECT_LT(end, 1.001 * start);  // nothing pumps energy in
  EXPECT_LT(highest, 0.25 + 0.01);  // on the ground (radius 0.25 m), not bouncing
  EXPECT_GT(lowest, 0.25 - 0.01);   // nor through it
}

TEST(MemoryEstimate, GrowsWithBodiesTerritoriesAndKeptStates) {
  const soda::Scene small = soda::make_scene("falling-cubes", {1000, 1});
  const soda::Scene large = soda::make_scene("falling-cubes", {4000, 1});
  soda::RunConfig c;
  const soda::MemoryEstimate a = soda::estimate_run_memory(small, c, 0);
  const soda::MemoryEstimate b = soda::estimate_run_memory(large, c, 0);
  EXPECT_EQ(a.world_bytes, small.bodies.size() * soda::world_bytes_per_body());
  EXPECT_GT(b.world_bytes, 3 * a.world_bytes);
  EXPECT_EQ(a.kept_state_bytes, 0u);
  c.territories = 4;
  c.runtime.anticipation = 16;
  c.runtime.checkpoint_every = 1;
  const soda::MemoryEstimate k = soda::estimate_run_memory(small, c, 4);
  EXPECT_GT(k.world_bytes, a.world_bytes);  // statics per world, ghosts
  EXPECT_GT(k.kept_state_bytes, 0u);
  EXPECT_GT(k.thread_bytes, 0u);
}

TEST(MemoryEstimate, RefusesWhatDoesNotFitNamingTheLimit) {
  const soda::Scene scene = soda::make_scene("falling-cubes", {1000, 1});
  const soda::MemoryEstimate e = soda::estimate_run_memory(scene, {}, 0);
  soda::MemoryBudget plenty;
  EXPECT_NO_THROW(soda::check_memory(e, plenty, "test"));
  soda::MemoryBudget tight;
  tight.address_space = e.total();  // no room for the margin
  try {
    soda::check_memory(e, tight, "scene 'x'");
    FAIL() << "no MemoryLimitError";
  } catch (const soda::MemoryLimitError& err) {
    const std::string m = err.what();
    EXPECT_NE(m.find("scene 'x'"), std::string::npos) << m;
    EXPECT_NE(m.find("RLIMIT_AS"), std::string::npos) << m;
  }
  soda::MemoryBudget low_ram;
  low_ram.available = e.touched() / 2;
  EXPECT_THROW(soda::check_memory(e, low_ram, "x"), soda::MemoryLimitError);
}

}  // namespace

// Static meshes and heightfields are counted once per process, whatever
// the number of territories (docs/memory.md, "Static meshes and
// heightfields"): the heights of terrain's heightfield, one btScalar each;
// a mesh's vertices, indices and BVH, once for two bodies sharing it.
TEST(MemoryEstimate, CountsLevelGeometryOncePerProcess) {
  const soda::Scene terrain = soda::make_scene("terrain", {200, 1});
  soda::RunConfig c;
  const soda::MemoryEstimate one = soda::estimate_run_memory(terrain, c, 0);
  EXPECT_EQ(one.level_geometry_bytes, terrain.bodies[0].shape.heightfield->heights.size() * sizeof(btScalar));
  c.territories = 8;
  const soda::MemoryEstimate eight = soda::estimate_run_memory(terrain, c, 8);
  EXPECT_EQ(eight.level_geometry_bytes, one.level_geometry_bytes);
  EXPECT_EQ(eight.total() - eight.world_bytes - eight.kept_state_bytes - eight.thread_bytes - eight.buffer_bytes,
            eight.level_geometry_bytes);
  EXPECT_EQ(soda::estimate_run_memory(soda::make_scene("falling-cubes", {100, 1}), c, 0).level_geometry_bytes, 0u);

  soda::Scene city = soda::make_scene("city", {100, 1});
  ASSERT_EQ(city.bodies[0].shape.kind, soda::ShapeKind::TriangleMesh);
  const soda::TriangleMeshData& mesh = *city.bodies[0].shape.mesh;
  const std::uint64_t once = soda::level_geometry_bytes(city);
  EXPECT_GT(once, mesh.vertices.size() * 3 * sizeof(btScalar) + mesh.triangles.size() * 3 * sizeof(int));
  soda::Body twin = city.bodies[0];
  twin.id = static_cast<soda::BodyId>(city.bodies.size() + 10);
  city.bodies.push_back(twin);  // the same data again: built once
  EXPECT_EQ(soda::level_geometry_bytes(city), once);
}

// Static heightfields and triangle meshes (docs/scene-format.md, "Triangle
// meshes and heightfields") keep decomposition invariance: the terrain scene
// (boulders, balls and boxes rolling down a heightfield valley, every
// territory's border through it) ends with the one-world hash for K = 1, 2,
// 4, 8 territories, speculating (anticipation 8), under SyncTest and with
// parking on and off; the same valley as a triangle mesh (the heightfield's
// own triangles) does too; a body rolling across a border of the
// heightfield between two territories matches the one world at every step;
// a run saved and resumed from a checkpoint goes on to the same hash.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>

#include "runtime/partitioned_test_util.h"
#include "worlds/heightfield_mesh.h"
#include "soda/loadbalance/policy.h"
#include "soda/runtime/balance_log.h"
#include "soda/runtime/checkpoint.h"
#include "soda/runtime/simulation.h"
#include "soda/scene/validate.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/stock_world.h"
#include "soda/worlds/world_snapshot.h"

namespace soda {
namespace {

constexpr int kSteps = 150;

const Scene& valley() {
  static const Scene s = test::scene("terrain", 40);
  return s;
}

const Scene& mesh_valley() {
  static const Scene s = [] {
    Scene m = valley();
    for (Body& b : m.bodies)
      if (b.shape.kind == ShapeKind::Heightfield) b.shape = Shape::triangle_mesh(test::mesh_of(*b.shape.heightfield));
    return m;
  }();
  return s;
}

// The valley with every third body an L-shaped compound of two boxes: a
// compound's pair with the heightfield keeps one manifold (compound_contact.h
// over concave_contact.h).
const Scene& compound_valley() {
  static const Scene s = [] {
    Scene m = valley();
    for (Body& b : m.bodies)
      if (!b.is_static && b.id % 3 == 0)
        b.shape = Shape::compound({CompoundChild{Shape::box(Vec3(0.45, 0.15, 0.2)), Vec3(0, -0.15, 0), Quat::Identity()},
                                   CompoundChild{Shape::box(Vec3(0.15, 0.3, 0.2)), Vec3(0.3, 0.3, 0), Quat::Identity()}});
    validate_scene(m, "compound valley", Precision::Float);
    return m;
  }();
  return s;
}

void expect_exercised(const test::MatrixCase& c, const test::MatrixRun& run) {
  const WorldMetrics& t = run.total;
  if (c.territories > 1) {
    EXPECT_GT(t.ghosts_sent, 0u);
    EXPECT_GT(t.migrations_out, 0u);
  }
  // Border islands from 4 territories on (on 2, the double build's bodies
  // meet none within the run).
  if (c.territories >= 4) EXPECT_GT(t.merged_islands, 0u);
  if (c.anticipation > 0 && c.territories > 1) EXPECT_GT(t.bets, 0u);
  if (c.sync_test > 0) EXPECT_GT(run.sync_rollbacks, 0u);
}

const auto kMatrix = test::decomposition_matrix();

class HeightfieldDecomposition : public ::testing::TestWithParam<test::MatrixCase> {};

TEST_P(HeightfieldDecomposition, EqualsTheOneWorldHash) {
  static const std::uint64_t ref = test::reference_hash(valley(), kSteps);
  expect_exercised(GetParam(), test::expect_one_world_hash(valley(), "terrain 40", GetParam(), kSteps, ref));
}

INSTANTIATE_TEST_SUITE_P(Partitioned, HeightfieldDecomposition, kMatrix,
                         [](const auto& info) { return test::matrix_case_name(info.param); });

class TriangleMeshDecomposition : public ::testing::TestWithParam<test::MatrixCase> {};

TEST_P(TriangleMeshDecomposition, EqualsTheOneWorldHash) {
  static const std::uint64_t ref = test::reference_hash(mesh_valley(), kSteps);
  expect_exercised(GetParam(),
                   test::expect_one_world_hash(mesh_valley(), "terrain 40 as a mesh", GetParam(), kSteps, ref));
}

INSTANTIATE_TEST_SUITE_P(Partitioned, TriangleMeshDecomposition, kMatrix,
                         [](const auto& info) { return test::matrix_case_name(info.param); });

// Load balancing moves cells (and the bodies in them) between worlds while
// the bodies roll over the heightfield and the mesh: churn (random cessions
// every 10 steps, seeded) on 4 territories, speculating, under SyncTest.
TEST(TerrainBalance, ChurnEqualsTheOneWorldHash) {
  for (const Scene* s : {&valley(), &mesh_valley()}) {
    PartitionedWorld w(*s, make_partition("grid:4x1x1", *s, 4, GridOptions{}), test::churn_options(3));
    w.step(kSteps);
    const BalanceTotals t = balance_totals(w.balance_log());
    std::printf("[ terrain 40 %s %s, churn K 4 ] %lld cells and %lld bodies moved; %s, one world %s\n",
                s == &valley() ? "heightfield" : "mesh", kPrecisionName, static_cast<long long>(t.cells_moved),
                static_cast<long long>(t.bodies_moved), hash_hex(w.state_hash()).c_str(),
                hash_hex(test::reference_hash(*s, kSteps)).c_str());
    EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(test::reference_hash(*s, kSteps)));
    EXPECT_GT(t.cells_moved, 0);
    EXPECT_GT(t.bodies_moved, 0);
  }
}

// The cost model sees the heightfield (docs/loadbalance.md, "Triangles"):
// the runtime hands every policy the triangles within each loaded cell's
// reach, the first map weighs bodies by them, and the hash stays the one
// world's under every policy; with the triangle cost off the policies see
// none, and the hash is the same again.
class RecordingPolicy final : public BalancePolicy {
 public:
  explicit RecordingPolicy(const BalanceOptions& o) : inner_(make_balance_policy(o)) {}
  const char* name() const override { return inner_->name(); }
  std::vector<CellMove> decide(const LoadView& view) override {
    for (const CellLoad& c : view.cells) max_cell_triangles = std::max(max_cell_triangles, c.triangles);
    for (const WorldLoad& w : view.worlds) body_triangles += w.body_triangles;
    return inner_->decide(view);
  }
  const LoadMonitor* monitor() const override { return inner_->monitor(); }
  std::int32_t max_cell_triangles = 0;
  std::int64_t body_triangles = 0;

 private:
  std::unique_ptr<BalancePolicy> inner_;
};

TEST(TerrainBalance, TriangleCostKeepsTheOneWorldHashUnderEveryPolicy) {
  const Scene& s = valley();
  const std::string reference = hash_hex(test::reference_hash(s, kSteps));
  struct Case {
    const char* policy;
    int k;
    bool triangle_cost;
  };
  for (const Case c : {Case{"diffusive", 2, true}, Case{"rcb", 2, true}, Case{"churn", 2, true},
                       Case{"diffusive", 4, true}, Case{"rcb", 4, true}, Case{"churn", 4, true},
                       Case{"diffusive", 4, false}}) {
    PartitionedOptions o;
    o.runtime.validate = true;
    o.runtime.balance.policy = c.policy;
    o.runtime.balance.period = 10;
    o.runtime.balance.overload = 1.05;  // move cells at small imbalances too: the test is the hash
    o.runtime.balance.underload = 0.95;
    o.runtime.balance.triangle_cost = c.triangle_cost;
    auto policy = std::make_shared<RecordingPolicy>(o.runtime.balance);
    o.balance_policy = policy;
    GridOptions grid;
    if (!c.triangle_cost) grid.triangle_weight = 0;
    PartitionedWorld w(s, make_partition("kmeans", s, c.k, grid), o);
    w.step(kSteps);
    const BalanceTotals t = balance_totals(w.balance_log());
    std::printf("[ terrain 40 %s, %s K %d, triangle cost %s ] %lld cells moved, most triangles a cell %d, "
                "body triangles %lld; %s, one world %s\n",
                kPrecisionName, c.policy, c.k, c.triangle_cost ? "on" : "off", static_cast<long long>(t.cells_moved),
                policy->max_cell_triangles, static_cast<long long>(policy->body_triangles),
                hash_hex(w.state_hash()).c_str(), reference.c_str());
    EXPECT_EQ(hash_hex(w.state_hash()), reference) << c.policy << " K " << c.k;
    if (c.triangle_cost) {
      EXPECT_GT(policy->max_cell_triangles, 0) << c.policy;
      EXPECT_GT(policy->body_triangles, 0) << c.policy;
    } else {
      EXPECT_EQ(policy->max_cell_triangles, 0);
      EXPECT_EQ(policy->body_triangles, 0);
    }
  }
}

class CompoundOnHeightfield : public ::testing::TestWithParam<test::MatrixCase> {};

TEST_P(CompoundOnHeightfield, EqualsTheOneWorldHash) {
  static const std::uint64_t ref = test::reference_hash(compound_valley(), kSteps);
  expect_exercised(GetParam(),
                   test::expect_one_world_hash(compound_valley(), "terrain 40 with compounds", GetParam(), kSteps, ref));
}

INSTANTIATE_TEST_SUITE_P(Partitioned, CompoundOnHeightfield,
                         ::testing::Values(test::MatrixCase{1, 0, 0, false}, test::MatrixCase{2, 0, 0, true},
                                           test::MatrixCase{8, 0, 0, true}, test::MatrixCase{8, 8, 0, false},
                                           test::MatrixCase{4, 0, 2, true}),
                         [](const auto& info) { return test::matrix_case_name(info.param); });

// city: debris falling onto one triangle mesh of ground and buildings.
class CityDecomposition : public ::testing::TestWithParam<test::MatrixCase> {};

TEST_P(CityDecomposition, EqualsTheOneWorldHash) {
  constexpr int kCitySteps = 200;  // the debris lands from about step 120
  static const Scene city = test::scene("city", 40);
  static const std::uint64_t ref = test::reference_hash(city, kCitySteps);
  const test::MatrixRun run = test::expect_one_world_hash(city, "city 40", GetParam(), kCitySteps, ref);
  if (GetParam().territories > 1) EXPECT_GT(run.total.ghosts_sent, 0u);
}

INSTANTIATE_TEST_SUITE_P(Partitioned, CityDecomposition,
                         ::testing::Values(test::MatrixCase{1, 0, 0, true}, test::MatrixCase{4, 0, 0, true},
                                           test::MatrixCase{8, 0, 0, false}, test::MatrixCase{8, 8, 0, true},
                                           test::MatrixCase{4, 0, 2, false}),
                         [](const auto& info) { return test::matrix_case_name(info.param); });

// Parking does not change the one world's result; the bodies roll down and
// stay on the valley (none falls through it) in SODA's worlds and in stock
// Bullet, on the heightfield and on the mesh.
TEST(HeightfieldDecomposition, BodiesRollDownAndStayAbove) {
  EXPECT_EQ(hash_hex(test::reference_hash(valley(), kSteps, true)), hash_hex(test::reference_hash(valley(), kSteps)));
  for (const Scene* s : {&valley(), &mesh_valley(), &compound_valley()}) {
    CanonicalWorld one(*s);
    StockWorld stock(*s);
    for (int i = 0; i < 300; ++i) one.step(), stock.step();
    for (const auto& [name, states] : {std::pair{"canonical", one.body_states()}, {"stock", stock.body_states()}}) {
      double lowest = 1e9, mean_x = 0.0;
      int n = 0;
      for (const BodyState& b : states) {
        if (b.id == 0) continue;
        lowest = std::min(lowest, double(b.origin[1]));
        mean_x += b.origin[0];
        ++n;
      }
      mean_x /= n;
      std::printf("[ terrain 40 %s, %s, %s, 300 steps ] lowest origin y %.3f, mean x %.2f (start %.2f)\n",
                  kPrecisionName, s == &valley() ? "heightfield" : s == &mesh_valley() ? "mesh" : "compounds", name,
                  lowest, mean_x, -28.8);
      EXPECT_GT(lowest, -0.5) << name;  // the basin's floor is at about y = -0.3
      EXPECT_GT(mean_x, -20.0) << name;  // they have rolled down
    }
  }
}

// Two bodies (a ball and a boulder) rolling along the valley across x = 0,
// the border of two territories (2 m cells, grid:2x1x1): every step's states
// bit for bit those of the one world.
Scene rolling_pair(const Scene& base) {
  Scene s = base;
  s.bodies.resize(1);  // the valley
  const HeightfieldData* hf = base.bodies[0].shape.heightfield.get();
  auto surface = [&](double x, double z) {
    const int i = static_cast<int>(std::lround(x / hf->spacing.x() + 0.5 * (hf->columns - 1)));
    const int j = static_cast<int>(std::lround(z / hf->spacing.z() + 0.5 * (hf->rows - 1)));
    return hf->heights[static_cast<std::size_t>(j) * hf->columns + i] * hf->spacing.y();
  };
  Body ball = base.bodies[1];
  ball.id = 1;
  ball.shape = Shape::sphere(0.5);
  ball.mass = 2.0;
  ball.position = Vec3(-3.0, surface(-3.0, 0.0) + 0.6, 0.0);
  ball.orientation = Quat::Identity();
  ball.linear_velocity = Vec3(3.0, 0.0, 0.0);
  Body rock = ball;
  rock.id = 2;
  rock.shape = Shape::convex_hull({Vec3(0.5, 0, 0), Vec3(-0.4, 0.1, 0), Vec3(0, 0.45, 0.1), Vec3(0, -0.4, 0.2),
                                   Vec3(0.1, 0, 0.5), Vec3(0, 0.1, -0.45)});
  rock.position = Vec3(-4.0, surface(-4.0, 2.0) + 0.6, 2.0);
  s.bodies.push_back(ball);
  s.bodies.push_back(rock);
  return s;
}

TEST(HeightfieldBorder, RollingBodyMatchesTheOneWorldEveryStep) {
  for (const Scene* base : {&valley(), &mesh_valley()}) {
    const bool mesh = base == &mesh_valley();
    Scene s = rolling_pair(valley());
    if (mesh) s.bodies[0] = mesh_valley().bodies[0];
    GridOptions g;
    g.cell_size = 2.0;
    g.origin = Vec3::Zero();
    g.box = CellBox{{-20, -2, -10}, {19, 12, 9}};  // x from -40 to 40 m: the border at x = 0
    const TerritoryMap map = make_partition("grid:2x1x1", s, 2, g);
    ASSERT_EQ(map.owner(CellCoord{-1, 0, 0}), map.owner(CellCoord{-5, 0, 0}));
    ASSERT_NE(map.owner(CellCoord{-1, 0, 0}), map.owner(CellCoord{0, 0, 0}));
    constexpr int kRollSteps = 240;
    EXPECT_EQ(test::first_divergence(s, map, kRollSteps), "") << (mesh ? "mesh" : "heightfield");
    PartitionedWorld part(s, map, PartitionedOptions{});
    part.step(kRollSteps);
    double x_ball = 0, x_rock = 0;
    for (const BodyState& b : part.body_states()) (b.id == 1 ? x_ball : x_rock) = b.id == 0 ? 0 : b.origin[0];
    const WorldMetrics t = test::total(part.metrics());
    std::printf("[ %s %s border x = 0, %d steps ] ball at x %.2f, boulder at x %.2f; %s; hash %s\n",
                mesh ? "mesh" : "heightfield", kPrecisionName, kRollSteps, x_ball, x_rock, test::summary(t).c_str(),
                hash_hex(part.state_hash()).c_str());
    EXPECT_GT(x_ball, 1.0);  // it crossed the border
    EXPECT_GT(t.migrations_out, 0u);
  }
}

// A checkpoint of the terrain scene carries the heightfield: resumed from the
// file alone on another territory count, the run goes on to the hash of the
// uninterrupted one.
TEST(TerrainCheckpoint, ResumesToTheUninterruptedHash) {
  for (const Scene* s : {&valley(), &mesh_valley()}) {
    const std::string path = ::testing::TempDir() + "/terrain-" + (s == &valley() ? "hf" : "mesh") + ".ckpt";
    Simulation a(*s, SimulationConfig{.territories = 2});
    ASSERT_TRUE(a.advance_to(a.time_of(60)));
    ASSERT_EQ(a.save(path), 60);
    ASSERT_TRUE(a.advance_to(a.time_of(kSteps)));
    Simulation b = Simulation::resume(path, SimulationConfig{.territories = 4});
    ASSERT_TRUE(b.advance_to(b.time_of(kSteps)));
    std::printf("[ terrain 40 %s %s checkpoint at 60 ] uninterrupted %s, resumed on K 4 %s\n", kPrecisionName,
                s == &valley() ? "heightfield" : "mesh", hash_hex(a.state_hash()).c_str(),
                hash_hex(b.state_hash()).c_str());
    EXPECT_EQ(hash_hex(b.state_hash()), hash_hex(a.state_hash()));
    EXPECT_EQ(hash_hex(a.state_hash()), hash_hex(test::reference_hash(*s, kSteps)));
    // Version 4 has no field for the level geometry: refused, naming it.
    try {
      encode_checkpoint(a.snapshot(), 4);
      ADD_FAILURE() << "version 4 took a concave static";
    } catch (const CheckpointError& e) {
      EXPECT_NE(std::string(e.what()).find(s == &valley() ? "heightfield" : "triangle_mesh"), std::string::npos)
          << e.what();
    }
  }
}

// World snapshot bytes carry the heightfield and the mesh bit for bit; a
// world rebuilt from them goes on to the uninterrupted hash.
TEST(TerrainCheckpoint, WorldSnapshotBytesRoundTrip) {
  for (const Scene* s : {&valley(), &mesh_valley()}) {
    CanonicalWorld a(*s);
    for (int i = 0; i < 60; ++i) a.step();
    const WorldSnapshot snap = a.snapshot();
    const WorldSnapshot back = deserialize_snapshot(serialize(snap));
    EXPECT_TRUE(same_bits(snap, back));
    CanonicalWorld b(back);
    for (int i = 60; i < kSteps; ++i) a.step(), b.step();
    EXPECT_EQ(hash_hex(b.state_hash()), hash_hex(a.state_hash()));
  }
}

}  // namespace
}  // namespace soda

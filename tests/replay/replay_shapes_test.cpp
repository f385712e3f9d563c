// Shapes in replay files (docs/replay-format.md, "Bodies"): a compound's
// children, a triangle mesh and a heightfield come back whole, so that a
// replay draws the level a run had; a version 2 file, which stored such
// shapes as the box of their local AABB, still reads; a writer refuses a
// shape it cannot store, naming the body.
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "replay_test_util.h"
#include "soda/replay/replay_reader.h"
#include "soda/replay/replay_writer.h"
#include "soda/scene/registry.h"

namespace soda::replay {
namespace {

using testing::TempPath;

ViewHeader header_of(const Scene& s) {
  ViewHeader h = testing::make_header(0, 2);
  h.scene = s.name;
  h.bodies.clear();
  for (const Body& b : s.bodies) h.bodies.push_back({b.id, b.is_static, b.shape, b.position, b.orientation});
  return h;
}

void expect_same_shape(const Shape& read, const Shape& written, const std::string& who) {
  ASSERT_EQ(read.kind, written.kind) << who;
  EXPECT_EQ(read.half_extents, written.half_extents) << who;
  EXPECT_EQ(read.radius, written.radius) << who;
  EXPECT_EQ(read.height, written.height) << who;
  EXPECT_EQ(read.points, written.points) << who;
  ASSERT_EQ(read.children.size(), written.children.size()) << who;
  for (std::size_t i = 0; i < read.children.size(); ++i) {
    const std::string child = who + ", child " + std::to_string(i);
    expect_same_shape(read.children[i].shape, written.children[i].shape, child);
    EXPECT_EQ(read.children[i].position, written.children[i].position) << child;
    EXPECT_EQ(read.children[i].orientation.coeffs(), written.children[i].orientation.coeffs()) << child;
  }
  ASSERT_EQ(read.mesh != nullptr, written.mesh != nullptr) << who;
  if (read.mesh) {
    EXPECT_EQ(read.mesh->vertices, written.mesh->vertices) << who;
    EXPECT_EQ(read.mesh->triangles, written.mesh->triangles) << who;
    EXPECT_EQ(read.mesh->file, written.mesh->file) << who;
  }
  ASSERT_EQ(read.heightfield != nullptr, written.heightfield != nullptr) << who;
  if (read.heightfield) {
    EXPECT_EQ(read.heightfield->columns, written.heightfield->columns) << who;
    EXPECT_EQ(read.heightfield->rows, written.heightfield->rows) << who;
    EXPECT_EQ(read.heightfield->spacing, written.heightfield->spacing) << who;
    EXPECT_EQ(read.heightfield->heights, written.heightfield->heights) << who;
  }
}

// terrain (a heightfield), city (a triangle mesh), compounds (static and
// dynamic compounds): every body's shape reads back bit for bit.
TEST(ReplayShapes, CompoundsMeshesAndHeightfieldsRoundTripWhole) {
  std::map<std::string, int> seen;  // "static compound", "dynamic compound", "triangle mesh", "heightfield"
  for (const auto& [name, n] : {std::pair{"terrain", 20}, {"city", 20}, {"compounds", 12}}) {
    const Scene s = make_scene(name, {n, 1});
    const ViewHeader h = header_of(s);
    TempPath file(std::string("shapes_") + name);
    {
      ReplayWriter out(file.path, h, {.keyframe_every = 2});
      for (const ViewFrame& f : testing::make_frames(h, 3, 5)) out.append(f);
      out.close();
    }
    ReplayReader in(file.path);
    EXPECT_EQ(in.version(), 3u);
    ASSERT_EQ(in.header().bodies.size(), h.bodies.size()) << name;
    for (std::size_t i = 0; i < h.bodies.size(); ++i) {
      const ViewBody& w = h.bodies[i];
      const std::string who = std::string(name) + " body " + std::to_string(w.id);
      EXPECT_EQ(in.header().bodies[i].id, w.id) << who;
      EXPECT_EQ(in.header().bodies[i].is_static, w.is_static) << who;
      expect_same_shape(in.header().bodies[i].shape, w.shape, who);
      if (w.shape.kind == ShapeKind::Compound) ++seen[w.is_static ? "static compound" : "dynamic compound"];
      if (w.shape.kind == ShapeKind::TriangleMesh) ++seen["triangle mesh"];
      if (w.shape.kind == ShapeKind::Heightfield) ++seen["heightfield"];
    }
    EXPECT_TRUE(in.frame_at(in.step_of(2)).has_value()) << name;
  }
  EXPECT_GT(seen["static compound"], 0);
  EXPECT_GT(seen["dynamic compound"], 0);
  EXPECT_EQ(seen["triangle mesh"], 1);
  EXPECT_EQ(seen["heightfield"], 1);
}

// Bodies added during a run (BODS) keep their children too.
TEST(ReplayShapes, AnAddedCompoundKeepsItsChildren) {
  const Scene s = make_scene("compounds", {6, 1});
  const ViewHeader h = testing::make_header(2, 1);
  ViewBody chair;
  for (const Body& b : s.bodies)
    if (!b.is_static && b.shape.kind == ShapeKind::Compound) chair = {900, false, b.shape, b.position, b.orientation};
  ASSERT_EQ(chair.id, 900u);
  TempPath file("added_compound");
  {
    ReplayWriter out(file.path, h, {.keyframe_every = 2});
    out.describe(chair);
    std::vector<ViewFrame> frames = testing::make_frames(h, 2, 3);
    ViewFrame& with = frames.back();
    with.ids = std::vector<BodyId>{1, 2, 900};
    for (int a = 0; a < 3; ++a) with.position.push_back(1.f);
    for (int a = 0; a < 4; ++a) with.orientation.push_back(a == 3 ? 1.f : 0.f);
    with.sleeping.push_back(0);
    with.owner.push_back(0);
    for (const ViewFrame& f : frames) out.append(f);
    out.close();
  }
  ReplayReader in(file.path);
  ASSERT_EQ(in.added_bodies().size(), 1u);
  expect_same_shape(in.added_bodies().front().shape, chair.shape, "added body 900");
}

// Recorded by the version 2 writer: soda run --scene compounds --n 6
// --territories 2 --steps 30 --record version2.replay --record-keyframes 16.
// Its compounds read back as the boxes that version stored.
TEST(ReplayShapes, VersionTwoFilesStillReadWithTheirCompoundsAsBoxes) {
  ReplayReader in(std::string(SODA_REPLAY_TEST_DATA) + "/version2.replay");
  EXPECT_EQ(in.version(), 2u);
  EXPECT_EQ(in.header().scene, "compounds");
  const Scene s = make_scene("compounds", {6, 1});
  ASSERT_EQ(in.header().bodies.size(), s.bodies.size());
  int boxed = 0;
  for (std::size_t i = 0; i < s.bodies.size(); ++i) {
    const Shape& read = in.header().bodies[i].shape;
    const Shape& scene = s.bodies[i].shape;
    EXPECT_TRUE(read.children.empty());
    if (scene.kind == ShapeKind::Compound) {
      ++boxed;
      EXPECT_EQ(read.kind, ShapeKind::Box);
      EXPECT_EQ(read.half_extents, scene.local_half_extents());
    } else {
      EXPECT_EQ(read.kind, scene.kind);
    }
  }
  EXPECT_GT(boxed, 0);
  EXPECT_EQ(in.frame_count(), 31u);
  const ViewFrame last = *in.frame_at(30);
  ASSERT_TRUE(last.state_hash);
  EXPECT_EQ(*last.state_hash, 0x217a155c5393ee5eULL);
}

TEST(ReplayShapes, AShapeItCannotStoreIsRefusedNamingTheBody) {
  TempPath file("refused");
  auto refused = [&](const ViewHeader& h) -> std::string {
    try {
      ReplayWriter out(file.path, h, {});
      return "";
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
  };
  ViewHeader h = testing::make_header(2, 1);
  h.bodies.front().shape.kind = ShapeKind::TriangleMesh;  // no mesh data
  EXPECT_NE(refused(h).find("body 0: a triangle mesh without its triangles"), std::string::npos) << refused(h);
  auto field = std::make_shared<HeightfieldData>();
  field->columns = 3;
  field->rows = 2;
  field->heights = {0, 1, 2, 3, 4};  // one short
  h.bodies.front().shape = Shape::heightfield_of(field);
  EXPECT_NE(refused(h).find("body 0: a heightfield of 3 x 2 samples with 5 heights"), std::string::npos)
      << refused(h);
  h = testing::make_header(2, 1);
  ViewBody nested{7, false, Shape::compound({CompoundChild{Shape::compound({CompoundChild{Shape::sphere(1)}})}})};
  ReplayWriter out(file.path, h, {});
  try {
    out.describe(nested);
    ADD_FAILURE() << "a compound inside a compound was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("describe body 7: a compound child that is not convex"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace soda::replay

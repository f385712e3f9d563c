// Triangle meshes and heightfields in scene files (docs/scene-format.md,
// "Triangle meshes and heightfields"): inline and OBJ meshes and
// heightfields round trip; each bad input is an error naming the source,
// the body and the field.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "soda/scene/obj_mesh.h"
#include "soda/scene/registry.h"
#include "scene_test_util.h"
#include "soda/scene/scene_json.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

std::string scene_with(const std::string& static_shape, const std::string& type = "static") {
  return R"({"format": "soda-scene", "version": 1, "name": "t", "bodies": [
      {"id": 4, "type": ")" + type + R"(", "mass": 1, "shape": )" + static_shape + R"(, "position": [0, 0, 0]},
      {"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": 0.5}, "position": [0, 2, 0]}]})";
}

using test::scene_error_of;

const char* kSquare = R"({"type": "triangle_mesh", "vertices": [[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]],
                          "indices": [[0, 2, 1], [0, 3, 2]]})";
const char* kField = R"({"type": "heightfield", "columns": 3, "rows": 2, "spacing": [0.5, 2, 0.25],
                         "heights": [0, 0.5, 1, 0.25, -0.5, 0]})";

TEST(ConcaveShapes, InlineMeshAndHeightfieldRoundTrip) {
  for (const char* shape : {kSquare, kField}) {
    const Scene s = parse_scene_json(scene_with(shape), "ok.json");
    const Scene r = parse_scene_json(scene_to_json(s), "again.json");
    const Shape &a = s.bodies[0].shape, &b = r.bodies[0].shape;
    ASSERT_EQ(a.kind, b.kind);
    if (a.kind == ShapeKind::TriangleMesh) {
      EXPECT_EQ(a.mesh->vertices, b.mesh->vertices);
      EXPECT_EQ(a.mesh->triangles, b.mesh->triangles);
      EXPECT_EQ(a.local_half_extents(), Vec3(1, 0, 1));  // flat: allowed
    } else {
      EXPECT_EQ(b.heightfield->columns, 3);
      EXPECT_EQ(b.heightfield->rows, 2);
      EXPECT_EQ(b.heightfield->heights, a.heightfield->heights);
      EXPECT_EQ(b.heightfield->spacing, Vec3(0.5, 2, 0.25));
      // x: 2 gaps of 0.5 m about the origin; y: the largest |height| * 2; z: 1 gap of 0.25 m
      EXPECT_EQ(a.local_half_extents(), Vec3(0.5, 2.0, 0.125));
    }
  }
}

TEST(ConcaveShapes, ObjFileBesideTheSceneIsRead) {
  const std::string path = std::string(SODA_TEST_DATA) + "/bowl.json";
  const Scene s = load_scene_file(path);
  const Shape& bowl = s.bodies[0].shape;
  ASSERT_EQ(bowl.kind, ShapeKind::TriangleMesh);
  EXPECT_EQ(bowl.mesh->file, "bowl.obj");
  EXPECT_EQ(bowl.mesh->vertices.size(), 81u);
  EXPECT_EQ(bowl.mesh->triangles.size(), 128u);  // 64 quads, each a fan of two
  EXPECT_EQ(bowl.mesh->vertices[0], Vec3(-4, 0.08 * 32, -4));
  // Written back, the body names its file again.
  EXPECT_NE(scene_to_json(s).find("\"file\": \"bowl.obj\""), std::string::npos);
}

TEST(ConcaveShapes, BadObjFilesNameTheLine) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "soda-obj";
  std::filesystem::create_directories(dir);
  auto write = [&](const char* name, const char* text) {
    std::ofstream(dir / name) << text;
    return (dir / name).string();
  };
  auto error = [](const std::string& path) {
    try {
      read_obj_mesh(path, "x.obj");
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(error(write("a.obj", "v 0 0 0\nv 1 0\n")).find("line 2: a vertex needs three numbers"), std::string::npos);
  EXPECT_NE(error(write("b.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 4\n")).find("line 4: face corner 4 names no vertex"),
            std::string::npos);
  EXPECT_NE(error(write("c.obj", "v 0 0 0\nf 1 x 2\n")).find("line 2: bad face corner 'x'"), std::string::npos);
  EXPECT_NE(error((dir / "missing.obj").string()).find("cannot open the mesh file"), std::string::npos);
  // Negative indices count back from the last vertex.
  write("d.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nf -3 -1 -2\n");
  const auto mesh = read_obj_mesh((dir / "d.obj").string(), "d.obj");
  ASSERT_EQ(mesh->triangles.size(), 1u);
  EXPECT_EQ(mesh->triangles[0], (std::array<std::uint32_t, 3>{0, 2, 1}));
  // Through a scene file: the body and the field, then the file's reason.
  write("s.json", R"({"format": "soda-scene", "version": 1, "bodies": [
      {"id": 3, "type": "static", "shape": {"type": "triangle_mesh", "file": "a.obj"}, "position": [0, 0, 0]}]})");
  try {
    load_scene_file((dir / "s.json").string());
    ADD_FAILURE() << "a bad OBJ file was accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("body #0 (id 3): field 'shape.file': "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
}

TEST(ConcaveShapes, BadMeshesAndHeightfieldsAreRejected) {
  struct Bad {
    std::string shape, type, expect;
  };
  const Bad cases[] = {
      {kSquare, "dynamic", "(id 4): field 'shape.type': a dynamic body cannot be a triangle_mesh: it is concave"},
      {kField, "dynamic", "(id 4): field 'shape.type': a dynamic body cannot be a heightfield"},
      {R"({"type": "triangle_mesh", "vertices": [], "indices": []})", "static",
       "(id 4): field 'shape.vertices': empty"},
      {R"({"type": "triangle_mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 0, 1]], "indices": []})", "static",
       "(id 4): field 'shape.indices': empty"},
      {R"({"type": "triangle_mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 0, 1]], "indices": [[0, 1, 3]]})", "static",
       "(id 4): field 'shape.indices[0]': vertex index 3 out of range (the mesh has 3 vertices)"},
      {R"({"type": "triangle_mesh", "vertices": [[0, 0, 0], [1, 0, 0], [2, 0, 0]], "indices": [[0, 1, 2]]})", "static",
       "(id 4): field 'shape.indices[0]': degenerate triangle (vertices 0, 1, 2 have no area)"},
      {R"({"type": "triangle_mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 0, 1]], "indices": [[0, 1, 1]]})", "static",
       "field 'shape.indices[0]': degenerate triangle"},
      {R"({"type": "triangle_mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 0, 1]], "indices": [[0, -1, 2]]})", "static",
       "field 'shape.indices[0]': vertex indices must be integers >= 0"},
      {R"({"type": "triangle_mesh", "vertices": [[0, 0]], "indices": [[0, 1, 2]]})", "static",
       "field 'shape.vertices[0]': must be an array of 3 numbers"},
      {R"({"type": "triangle_mesh", "file": "x.obj", "vertices": []})", "static",
       "field 'shape.file': a triangle mesh takes either a file or vertices and indices"},
      {R"({"type": "heightfield", "columns": 1, "rows": 2, "heights": [0, 0]})", "static",
       "(id 4): field 'shape.columns': must be an integer >= 2"},
      {R"({"type": "heightfield", "columns": 2, "rows": 2, "heights": [0, 0, 0]})", "static",
       "(id 4): field 'shape.heights': holds 3 heights, columns * rows = 4"},
      {R"({"type": "heightfield", "columns": 2, "rows": 2, "spacing": [1, 0, 1], "heights": [0, 0, 0, 0]})", "static",
       "(id 4): field 'shape.spacing': must be > 0"},
      {R"({"type": "heightfield", "columns": 2, "rows": 2, "heights": [0, 0, "a", 0]})", "static",
       "(id 4): field 'shape.heights[2]': must be a number"},
      {R"({"type": "compound", "children": [{"shape": {"type": "heightfield", "columns": 2, "rows": 2, "heights": [0, 0, 0, 0]}}]})",
       "static", "(id 4): field 'shape.children[0].shape': a compound's child cannot be concave"},
  };
  for (const Bad& c : cases) {
    const std::string e = scene_error_of(scene_with(c.shape, c.type));
    EXPECT_NE(e.find(c.expect), std::string::npos) << e;
    EXPECT_EQ(e.rfind("bad.json: body #0", 0), 0u) << e;
  }
  // NaN and infinity cannot be written in JSON; through the API they are
  // refused, naming the vertex or the sample.
  Scene s = parse_scene_json(scene_with(kSquare), "api");
  auto mesh = std::make_shared<TriangleMeshData>(*s.bodies[0].shape.mesh);
  mesh->vertices[2].y() = NAN;
  s.bodies[0].shape.mesh = mesh;
  try {
    validate_scene(s, "api");
    ADD_FAILURE() << "a NaN vertex was accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("(id 4): field 'shape.vertices[2]': must be finite"), std::string::npos)
        << e.what();
  }
  s = parse_scene_json(scene_with(kField), "api");
  auto hf = std::make_shared<HeightfieldData>(*s.bodies[0].shape.heightfield);
  hf->heights[4] = INFINITY;
  s.bodies[0].shape.heightfield = hf;
  EXPECT_THROW(validate_scene(s, "api"), SceneError);
  // A dynamic compound may share a scene with a concave static.
  EXPECT_NO_THROW(parse_scene_json(R"({"format": "soda-scene", "version": 1, "bodies": [
      {"id": 4, "type": "static", "shape": )" + std::string(kSquare) + R"(, "position": [0, 0, 0]},
      {"id": 7, "type": "dynamic", "mass": 1, "position": [0, 2, 0], "shape": {"type": "compound", "children": [{"shape": {"type": "sphere", "radius": 0.5}}]}}]})",
                                   "ok.json"));
}

TEST(ConcaveShapes, TerrainSceneIsAValidHeightfieldValley) {
  const Scene s = make_scene("terrain", SceneParams{40, 1, false});
  validate_scene(s, "terrain", Precision::Float);
  ASSERT_EQ(s.bodies[0].shape.kind, ShapeKind::Heightfield);
  const HeightfieldData& hf = *s.bodies[0].shape.heightfield;
  EXPECT_EQ(hf.columns, 161);
  EXPECT_EQ(hf.rows, 81);
  EXPECT_EQ(s.dynamic_count(), 40u);
  // Seeded: the same seed, the same scene; another seed, other bodies.
  EXPECT_EQ(scene_to_json(s), scene_to_json(make_scene("terrain", SceneParams{40, 1, false})));
  EXPECT_NE(scene_to_json(s), scene_to_json(make_scene("terrain", SceneParams{40, 2, false})));
}

}  // namespace
}  // namespace soda

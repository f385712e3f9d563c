// city (docs/scenes.md): debris falling onto a street grid, one static
// triangle mesh (docs/scene-format.md, "Triangle meshes and heightfields")
// of ground and buildings, across territory borders.
#include <algorithm>
#include <cmath>

#include "generators.h"
#include "random.h"

namespace soda::detail {
namespace {

constexpr int kDefaultDebris = 200;
constexpr double kBlock = 8.0;    // m: a building's footprint side
constexpr double kStreet = 6.0;   // m: street width
constexpr double kGroundQuad = 4.0;  // m: the ground's triangles are halves of these squares
constexpr double kDebrisPitch = 1.8;    // m between debris at the start

class MeshBuilder {
 public:
  explicit MeshBuilder(TriangleMeshData& mesh) : mesh_(mesh) {}
  std::uint32_t vertex(double x, double y, double z) {
    mesh_.vertices.emplace_back(x, y, z);
    return static_cast<std::uint32_t>(mesh_.vertices.size() - 1);
  }
  // Two triangles a, b, c and a, c, d, wound so that their normal points
  // away from `inside`.
  void quad(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d, const Vec3& inside) {
    const Vec3& pa = mesh_.vertices[a];
    const Vec3 n = (mesh_.vertices[b] - pa).cross(mesh_.vertices[c] - pa);
    const bool outward = n.dot(pa - inside) >= 0.0;
    mesh_.triangles.push_back(outward ? std::array<std::uint32_t, 3>{a, b, c} : std::array<std::uint32_t, 3>{a, c, b});
    mesh_.triangles.push_back(outward ? std::array<std::uint32_t, 3>{a, c, d} : std::array<std::uint32_t, 3>{a, d, c});
  }

 private:
  TriangleMeshData& mesh_;
};

}  // namespace

Scene make_city(const SceneParams& params) {
  Scene scene = start_scene("city", params);
  SceneRandom rng(params.seed);
  const int n = params.n > 0 ? params.n : kDefaultDebris;
  const int blocks = std::max(3, static_cast<int>(std::ceil(std::sqrt(n / 22.0))));
  const double pitch = kBlock + kStreet;
  const double half = 0.5 * blocks * pitch + kStreet;  // the ground spans [-half, half] in x and z
  auto mesh = std::make_shared<TriangleMeshData>();
  MeshBuilder build(*mesh);
  // The ground: a grid of kGroundQuad squares at y = 0, facing up.
  const int quads = static_cast<int>(std::ceil(2.0 * half / kGroundQuad));
  const double side = quads * kGroundQuad;
  const std::uint32_t first = static_cast<std::uint32_t>(mesh->vertices.size());
  for (int j = 0; j <= quads; ++j)
    for (int i = 0; i <= quads; ++i) build.vertex(-0.5 * side + i * kGroundQuad, 0.0, -0.5 * side + j * kGroundQuad);
  const auto at = [&](int i, int j) { return first + static_cast<std::uint32_t>(j * (quads + 1) + i); };
  for (int j = 0; j < quads; ++j)
    for (int i = 0; i < quads; ++i) build.quad(at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1), Vec3(0, -1, 0));
  // Buildings: a closed box (roof and four walls) per block, 4 to 14 m high.
  for (int bj = 0; bj < blocks; ++bj)
    for (int bi = 0; bi < blocks; ++bi) {
      const double x0 = -0.5 * blocks * pitch + 0.5 * kStreet + bi * pitch, x1 = x0 + kBlock;
      const double z0 = -0.5 * blocks * pitch + 0.5 * kStreet + bj * pitch, z1 = z0 + kBlock;
      const double h = std::round(rng.uniform(4.0, 14.0));
      const Vec3 inside(0.5 * (x0 + x1), 0.5 * h, 0.5 * (z0 + z1));
      const std::uint32_t b00 = build.vertex(x0, 0, z0), b10 = build.vertex(x1, 0, z0), b11 = build.vertex(x1, 0, z1),
                          b01 = build.vertex(x0, 0, z1);
      const std::uint32_t t00 = build.vertex(x0, h, z0), t10 = build.vertex(x1, h, z0), t11 = build.vertex(x1, h, z1),
                          t01 = build.vertex(x0, h, z1);
      build.quad(t00, t10, t11, t01, inside);  // roof
      build.quad(b00, b10, t10, t00, inside);  // walls
      build.quad(b10, b11, t11, t10, inside);
      build.quad(b11, b01, t01, t11, inside);
      build.quad(b01, b00, t00, t01, inside);
    }
  Body city;
  city.id = 0;
  city.is_static = true;
  city.friction = 0.7;
  city.shape = Shape::triangle_mesh(std::move(mesh));
  scene.bodies.push_back(std::move(city));
  // Debris: boxes, slabs and rubble (convex hulls) in layers from 20 m up,
  // over the whole grid, turned at random.
  const int per_side = std::max(1, static_cast<int>(2.0 * (half - kStreet) / kDebrisPitch));
  for (int i = 0; i < n; ++i) {
    const int layer = i / (per_side * per_side), row = (i / per_side) % per_side, col = i % per_side;
    Body b;
    b.id = static_cast<BodyId>(i + 1);
    b.friction = 0.6;
    const double size = rng.uniform(0.25, 0.6);
    switch (i % 3) {
      case 0: b.shape = Shape::box(Vec3(size, size, size)); break;
      case 1: b.shape = Shape::box(Vec3(1.3 * size, 0.3 * size, 0.9 * size)); break;
      default: {
        std::vector<Vec3> points;
        for (int k = 0; k < 8; ++k) points.push_back(rng.rotation() * Vec3::UnitX() * size * rng.uniform(0.7, 1.0));
        b.shape = Shape::convex_hull(std::move(points));
      }
    }
    b.mass = 30.0 * size * size * size;
    b.position = Vec3(-half + kStreet + kDebrisPitch * (col + 0.5), 20.0 + kDebrisPitch * layer + rng.uniform(0.0, 3.0),
                      -half + kStreet + kDebrisPitch * (row + 0.5));
    b.orientation = rng.rotation();
    scene.bodies.push_back(std::move(b));
  }
  return scene;
}

}  // namespace soda::detail

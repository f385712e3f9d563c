// A heightfield's triangles as a static triangle mesh, for tests that
// compare the two shapes (tests/runtime/terrain_test.cpp) or measure what
// a mesh of the same valley costs (tests/worlds/shared_mesh_test.cpp).
#pragma once

#include <cstdint>
#include <memory>

#include "soda/scene/scene.h"

namespace soda::test {

// Two triangles a quad, as Bullet splits them (btHeightfieldTerrainShape
// without flip or diamond subdivision), wound counter-clockwise seen from
// above.
inline std::shared_ptr<const TriangleMeshData> mesh_of(const HeightfieldData& hf) {
  auto mesh = std::make_shared<TriangleMeshData>();
  for (int j = 0; j < hf.rows; ++j)
    for (int i = 0; i < hf.columns; ++i)
      mesh->vertices.emplace_back((i - 0.5 * (hf.columns - 1)) * hf.spacing.x(),
                                  hf.heights[static_cast<std::size_t>(j) * hf.columns + i] * hf.spacing.y(),
                                  (j - 0.5 * (hf.rows - 1)) * hf.spacing.z());
  for (int j = 0; j + 1 < hf.rows; ++j)
    for (int i = 0; i + 1 < hf.columns; ++i) {
      const auto a = static_cast<std::uint32_t>(j * hf.columns + i), b = a + 1,
                 c = a + static_cast<std::uint32_t>(hf.columns), d = c + 1;
      mesh->triangles.push_back({a, c, b});
      mesh->triangles.push_back({b, c, d});
    }
  return mesh;
}

}  // namespace soda::test

// Shared static mesh and heightfield shapes (concave_shapes.h).
#include "concave_shapes.h"

#include <map>
#include <mutex>
#include <stdexcept>
#include <vector>

#include <BulletCollision/CollisionShapes/btHeightfieldTerrainShape.h>

namespace soda {
namespace {

// Quantized BVH nodes keep a triangle's index in 21 bits and its part in
// 10: a mesh is cut into parts of at most this many triangles.
constexpr std::size_t kTrianglesPerPart = std::size_t{1} << 20;

struct MeshHolder {
  std::shared_ptr<const TriangleMeshData> data;  // keeps the cache's key alive
  std::vector<btScalar> vertices;                // x, y, z per vertex
  std::vector<int> indices;                      // 3 per triangle
  btTriangleIndexVertexArray array;
  std::unique_ptr<btBvhTriangleMeshShape> shape;

  explicit MeshHolder(std::shared_ptr<const TriangleMeshData> d) : data(std::move(d)) {
    vertices.reserve(3 * data->vertices.size());
    for (const Vec3& v : data->vertices)
      for (int k = 0; k < 3; ++k) vertices.push_back(btScalar(v[k]));
    indices.reserve(3 * data->triangles.size());
    for (const auto& t : data->triangles)
      for (std::uint32_t i : t) indices.push_back(static_cast<int>(i));
    for (std::size_t first = 0; first < data->triangles.size(); first += kTrianglesPerPart) {
      btIndexedMesh part;
      part.m_numTriangles = static_cast<int>(std::min(kTrianglesPerPart, data->triangles.size() - first));
      part.m_triangleIndexBase = reinterpret_cast<const unsigned char*>(indices.data() + 3 * first);
      part.m_triangleIndexStride = 3 * static_cast<int>(sizeof(int));
      part.m_numVertices = static_cast<int>(data->vertices.size());
      part.m_vertexBase = reinterpret_cast<const unsigned char*>(vertices.data());
      part.m_vertexStride = 3 * static_cast<int>(sizeof(btScalar));
      part.m_vertexType = sizeof(btScalar) == sizeof(double) ? PHY_DOUBLE : PHY_FLOAT;
      array.addIndexedMesh(part, PHY_INTEGER);
    }
    shape = std::make_unique<btBvhTriangleMeshShape>(&array, true, true);
  }
};

struct HeightfieldHolder {
  std::shared_ptr<const HeightfieldData> data;
  std::vector<btScalar> heights;
  std::unique_ptr<btHeightfieldTerrainShape> shape;

  explicit HeightfieldHolder(std::shared_ptr<const HeightfieldData> d) : data(std::move(d)) {
    heights.reserve(data->heights.size());
    btScalar top(0);
    for (double h : data->heights) {
      heights.push_back(btScalar(h));
      top = std::max(top, btFabs(heights.back()));
    }
    // Heights from -top to top: Bullet centres the shape's AABB on the
    // body's origin, so a symmetric range keeps height 0 at the origin.
    shape = std::make_unique<btHeightfieldTerrainShape>(data->columns, data->rows, heights.data(), -top, top, 1,
                                                        false);
    shape->setLocalScaling(btVector3(btScalar(data->spacing.x()), btScalar(data->spacing.y()),
                                     btScalar(data->spacing.z())));
  }
};

std::mutex cache_mutex;
std::map<const void*, std::weak_ptr<btCollisionShape>> cache;  // by the data's address

template <class Holder, class Data>
std::shared_ptr<btCollisionShape> cached(const std::shared_ptr<const Data>& data) {
  if (!data) throw std::invalid_argument("shared_concave_shape: a mesh or heightfield shape without its data");
  std::lock_guard<std::mutex> lock(cache_mutex);
  auto it = cache.find(data.get());
  if (it != cache.end())
    if (std::shared_ptr<btCollisionShape> s = it->second.lock()) return s;
  for (auto e = cache.begin(); e != cache.end();) e = e->second.expired() ? cache.erase(e) : std::next(e);
  auto holder = std::make_shared<Holder>(data);
  std::shared_ptr<btCollisionShape> s(holder, holder->shape.get());
  cache[data.get()] = s;
  return s;
}

}  // namespace

std::shared_ptr<btCollisionShape> shared_concave_shape(const Shape& shape) {
  if (shape.kind == ShapeKind::TriangleMesh) return cached<MeshHolder>(shape.mesh);
  if (shape.kind == ShapeKind::Heightfield) return cached<HeightfieldHolder>(shape.heightfield);
  throw std::invalid_argument("shared_concave_shape: not a triangle mesh or heightfield");
}

std::size_t concave_shape_bytes(const Shape& shape) {
  if (shape.kind == ShapeKind::Heightfield)
    return shape.heightfield ? shape.heightfield->heights.size() * sizeof(btScalar) + sizeof(btHeightfieldTerrainShape)
                             : 0;
  if (shape.kind != ShapeKind::TriangleMesh || !shape.mesh) return 0;
  const std::shared_ptr<btCollisionShape> s = shared_concave_shape(shape);
  auto* mesh = static_cast<btBvhTriangleMeshShape*>(s.get());
  btOptimizedBvh* bvh = mesh->getOptimizedBvh();
  const std::size_t nodes =
      bvh ? static_cast<std::size_t>(bvh->getQuantizedNodeArray().capacity()) * sizeof(btQuantizedBvhNode) +
                static_cast<std::size_t>(bvh->getSubtreeInfoArray().capacity()) * sizeof(btBvhSubtreeInfo)
          : 0;
  return shape.mesh->vertices.size() * 3 * sizeof(btScalar) + shape.mesh->triangles.size() * 3 * sizeof(int) +
         nodes + sizeof(btBvhTriangleMeshShape) + sizeof(btOptimizedBvh);
}

}  // namespace soda

// Shared static mesh and heightfield shapes (concave_shapes.h).
#include "concave_shapes.h"

#include <algorithm>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include <BulletCollision/CollisionShapes/btHeightfieldTerrainShape.h>
#include <LinearMath/btAabbUtil2.h>

namespace soda {
namespace {

// Quantized BVH nodes keep a triangle's index in 21 bits and its part in
// 10: a mesh is cut into parts of at most this many triangles.
constexpr int kPartBits = 20;
constexpr std::size_t kTrianglesPerPart = std::size_t{1} << kPartBits;

// A triangle mesh that visits the triangles under a box (those
// TestTriangleAgainstAabb2 accepts) in the order of their index in the
// whole mesh, and reports them by it (Bullet's part and
// index of the whole), whether it holds the whole mesh or a part
// (MeshCut). Bullet's own order is its BVH's, a function of every triangle
// the tree holds, so a part's would differ from the whole's; a sorted
// visit is the same for both wherever the part holds the triangles under
// the box (docs/scene-format.md, "Triangle meshes and heightfields").
class CanonicalMesh final : public btBvhTriangleMeshShape {
 public:
  CanonicalMesh(btStridingMeshInterface* mesh, const MeshCut* cut, bool sorted)
      : btBvhTriangleMeshShape(mesh, true, true), cut_(cut), sorted_(sorted) {
    if (!cut) return;
    // The whole mesh's box, as Bullet computes it from the whole's extreme
    // vertices (a stand-in mesh with those alone).
    btScalar corners[6];
    for (int k = 0; k < 3; ++k) corners[k] = btScalar(cut->lo[k]), corners[3 + k] = btScalar(cut->hi[k]);
    int triangle[3] = {0, 1, 0};
    btTriangleIndexVertexArray stand_in(1, triangle, 3 * sizeof(int), 2, corners, 3 * sizeof(btScalar));
    const CanonicalMesh whole_box(&stand_in);
    m_localAabbMin = whole_box.m_localAabbMin;
    m_localAabbMax = whole_box.m_localAabbMax;
  }

  void processAllTriangles(btTriangleCallback* callback, const btVector3& lo, const btVector3& hi) const override {
    if (!sorted_) return btBvhTriangleMeshShape::processAllTriangles(callback, lo, hi);
    // The triangles under the box itself: the tree's nodes are a
    // function of every triangle it holds and visit more.
    struct Collect final : btTriangleCallback {
      Collect(const MeshCut* c, const btVector3& l, const btVector3& h) : cut(c), lo(l), hi(h) {}
      void processTriangle(btVector3* t, int part, int index) override {
        if (!TestTriangleAgainstAabb2(t, lo, hi)) return;
        const std::size_t local = static_cast<std::size_t>(part) * kTrianglesPerPart + static_cast<std::size_t>(index);
        visits.push_back({cut ? cut->whole_index[local] : static_cast<std::uint32_t>(local), {t[0], t[1], t[2]}});
      }
      const MeshCut* cut;
      btVector3 lo, hi;
    } collect(cut_, lo, hi);
    const std::size_t first = visits.size();  // visits of an enclosing call stay
    struct Restore {
      std::size_t size;
      ~Restore() { visits.resize(size); }
    } restore{first};
    btBvhTriangleMeshShape::processAllTriangles(&collect, lo, hi);
    std::sort(visits.begin() + static_cast<std::ptrdiff_t>(first), visits.end(),
              [](const Visit& a, const Visit& b) { return a.id < b.id; });
    for (std::size_t i = first; i < visits.size(); ++i) {
      btVector3 t[3] = {visits[i].corners[0], visits[i].corners[1], visits[i].corners[2]};
      const std::uint32_t id = visits[i].id;
      callback->processTriangle(t, static_cast<int>(id >> kPartBits),
                                static_cast<int>(id & (kTrianglesPerPart - 1)));
    }
  }

 private:
  explicit CanonicalMesh(btStridingMeshInterface* mesh)
      : btBvhTriangleMeshShape(mesh, true, false), cut_(nullptr), sorted_(false) {}

  struct Visit {
    std::uint32_t id;
    btVector3 corners[3];
  };
  static thread_local std::vector<Visit> visits;
  const MeshCut* cut_;
  bool sorted_;  // false: Bullet's own order (the stock world's), for a whole mesh only
};

thread_local std::vector<CanonicalMesh::Visit> CanonicalMesh::visits;

struct MeshHolder {
  std::shared_ptr<const TriangleMeshData> data;  // keeps the cache's key alive
  std::vector<btScalar> vertices;                // x, y, z per vertex
  std::vector<int> indices;                      // 3 per triangle
  btTriangleIndexVertexArray array;
  std::unique_ptr<CanonicalMesh> shape;

  MeshHolder(std::shared_ptr<const TriangleMeshData> d, bool sorted) : data(std::move(d)) {
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
    shape = std::make_unique<CanonicalMesh>(&array, data->cut.get(), sorted);
  }
};

// A heightfield window (HeightfieldData::window) answers for the whole
// grid's samples it holds; a sample outside it is a bug in the cut, never
// read silently.
class WindowedHeightfield final : public btHeightfieldTerrainShape {
 public:
  WindowedHeightfield(const HeightfieldData& data, const btScalar* heights, btScalar top)
      : btHeightfieldTerrainShape(data.columns, data.rows, heights, -top, top, 1, false), w_(data.window),
        heights_(heights) {}

  btScalar getRawHeightFieldValue(int x, int y) const override {
    if (w_.columns == 0) return heights_[static_cast<std::size_t>(y) * m_heightStickWidth + x];
    if (x < w_.column || x >= w_.column + w_.columns || y < w_.row || y >= w_.row + w_.rows)
      throw std::logic_error("heightfield: sample (" + std::to_string(x) + ", " + std::to_string(y) +
                             ") is outside the window this process holds (columns " + std::to_string(w_.column) +
                             "+" + std::to_string(w_.columns) + ", rows " + std::to_string(w_.row) + "+" +
                             std::to_string(w_.rows) + ")");
    return heights_[static_cast<std::size_t>(y - w_.row) * w_.columns + (x - w_.column)];
  }

 private:
  HeightfieldData::Window w_;
  const btScalar* heights_;
};

struct HeightfieldHolder {
  std::shared_ptr<const HeightfieldData> data;
  std::vector<btScalar> heights;
  std::unique_ptr<btHeightfieldTerrainShape> shape;

  HeightfieldHolder(std::shared_ptr<const HeightfieldData> d, bool) : data(std::move(d)) {
    heights.reserve(data->heights.size());
    for (double h : data->heights) heights.push_back(btScalar(h));
    // Heights from -top to top: Bullet centres the shape's AABB on the
    // body's origin, so a symmetric range keeps height 0 at the origin.
    // The largest |height| of the whole grid, a window's too.
    const btScalar top = btScalar(data->max_abs_raw_height());
    shape = std::make_unique<WindowedHeightfield>(*data, heights.data(), top);
    shape->setLocalScaling(btVector3(btScalar(data->spacing.x()), btScalar(data->spacing.y()),
                                     btScalar(data->spacing.z())));
  }
};

std::mutex cache_mutex;
// By the data's address and the order (sorted or Bullet's).
std::map<std::pair<const void*, bool>, std::weak_ptr<btCollisionShape>> cache;

template <class Holder, class Data>
std::shared_ptr<btCollisionShape> cached(const std::shared_ptr<const Data>& data, bool sorted) {
  if (!data) throw std::invalid_argument("shared_concave_shape: a mesh or heightfield shape without its data");
  std::lock_guard<std::mutex> lock(cache_mutex);
  const std::pair<const void*, bool> key(data.get(), sorted);
  auto it = cache.find(key);
  if (it != cache.end())
    if (std::shared_ptr<btCollisionShape> s = it->second.lock()) return s;
  for (auto e = cache.begin(); e != cache.end();) e = e->second.expired() ? cache.erase(e) : std::next(e);
  auto holder = std::make_shared<Holder>(data, sorted);
  std::shared_ptr<btCollisionShape> s(holder, holder->shape.get());
  cache[key] = s;
  return s;
}

std::shared_ptr<btCollisionShape> concave_shape(const Shape& shape, bool sorted) {
  if (shape.kind == ShapeKind::TriangleMesh) return cached<MeshHolder>(shape.mesh, sorted);
  if (shape.kind == ShapeKind::Heightfield) return cached<HeightfieldHolder>(shape.heightfield, true);
  throw std::invalid_argument("shared_concave_shape: not a triangle mesh or heightfield");
}

}  // namespace

std::shared_ptr<btCollisionShape> shared_concave_shape(const Shape& shape) { return concave_shape(shape, true); }

std::shared_ptr<btCollisionShape> stock_concave_shape(const Shape& shape) {
  if (shape.mesh && shape.mesh->cut) throw std::invalid_argument("stock_concave_shape: a part of a mesh");
  return concave_shape(shape, false);
}

std::size_t concave_shape_bytes(const Shape& shape) {
  if (shape.kind == ShapeKind::Heightfield)
    return shape.heightfield ? shape.heightfield->heights.size() * sizeof(btScalar) + sizeof(btHeightfieldTerrainShape)
                             : 0;
  if (shape.kind != ShapeKind::TriangleMesh || !shape.mesh) return 0;
  const std::shared_ptr<btCollisionShape> s = shared_concave_shape(shape);
  auto* mesh = static_cast<btBvhTriangleMeshShape*>(s.get());
  const std::size_t whole_index = shape.mesh->cut ? shape.mesh->cut->whole_index.size() * sizeof(std::uint32_t) : 0;
  btOptimizedBvh* bvh = mesh->getOptimizedBvh();
  const std::size_t nodes =
      bvh ? static_cast<std::size_t>(bvh->getQuantizedNodeArray().capacity()) * sizeof(btQuantizedBvhNode) +
                static_cast<std::size_t>(bvh->getSubtreeInfoArray().capacity()) * sizeof(btBvhSubtreeInfo)
          : 0;
  return shape.mesh->vertices.size() * 3 * sizeof(btScalar) + shape.mesh->triangles.size() * 3 * sizeof(int) +
         whole_index + nodes + sizeof(btBvhTriangleMeshShape) + sizeof(btOptimizedBvh);
}

}  // namespace soda

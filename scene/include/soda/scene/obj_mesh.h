// Wavefront OBJ files as static triangle meshes (docs/scene-format.md,
// "Triangle meshes and heightfields").
#pragma once

#include <memory>
#include <string>

#include "soda/scene/scene.h"

namespace soda {

/// The triangles of an OBJ file: its `v x y z` vertices and its `f` faces
/// (a face of more than three corners as a fan around its first; corners
/// as `i`, `i/t`, `i//n` or `i/t/n`, negative indices counted back from
/// the last vertex so far). Every other line (normals, texture
/// coordinates, groups, materials, comments) is ignored. `name` is what
/// the mesh keeps as its file (TriangleMeshData::file). Throws SceneError
/// naming the path and the line on a file that cannot be read, a malformed
/// number or an index out of range.
std::shared_ptr<const TriangleMeshData> read_obj_mesh(const std::string& path, const std::string& name);

}  // namespace soda

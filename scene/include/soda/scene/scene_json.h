// The JSON scene file format (docs/scene-format.md): loader and writer.
#pragma once

#include <string>

#include "soda/scene/scene.h"

namespace soda {

/// Reads and validates a scene file. Throws SceneError with a message naming
/// the file, the body (index and id) and the field for: unreadable file,
/// malformed JSON, missing or mistyped fields, unknown shape, NaN/Inf (the
/// strings "nan"/"inf" are not numbers in JSON; numbers too large to be
/// finite doubles are refused), non-positive mass on a dynamic body, zero or
/// negative extents, duplicate ids, ids >= 2^31, and bodies Bullet would
/// silently disable. Never drops a body.
Scene load_scene_file(const std::string& path);

/// Parses a scene from JSON text; `source` names it in error messages.
Scene parse_scene_json(const std::string& text, const std::string& source);

/// Serialises a scene to JSON text (numbers printed so that they read back
/// bit-identical).
std::string scene_to_json(const Scene& scene);

/// Writes scene_to_json(scene) to `path`. Throws SceneError if it cannot.
void write_scene_file(const Scene& scene, const std::string& path);

}  // namespace soda

// One registry of named, seeded scene generators, shared by examples, tests
// and benchmarks (docs/scenes.md; definitions in ../shared BENCHMARKS.md).
// A scene is a function of its parameters and seed, nothing else.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "soda/scene/input_file.h"
#include "soda/scene/scene.h"

namespace soda {

struct SceneParams {
  int n = 0;                    // size (bodies, boxes, ...; see docs/scenes.md); 0: the scene's default
  std::uint64_t seed = 1;       // every random choice derives from it
  bool random_scale = false;    // falling-cubes: edges uniform in [0.2, 1.3] m
};

struct SceneGenerator {
  std::string name;
  std::string description;
  std::function<Scene(const SceneParams&)> make;
  /// The user inputs the scene is defined with (bodies added over time:
  /// rain), sorted by step; empty (no function) for most scenes. A run of
  /// the scene applies them through the embedding API (Simulation's
  /// add_body, ...) or `soda run --inputs` (inputs_to_json writes the file).
  std::function<std::vector<UserInput>(const SceneParams&)> inputs = {};
};

/// All registered generators, in a fixed order.
const std::vector<SceneGenerator>& scene_registry();

/// Finds a generator by name; nullptr if none.
const SceneGenerator* find_scene_generator(const std::string& name);

/// Generates the named scene. Throws SceneError for an unknown name (listing
/// the known ones) or bad parameters (n < 0).
Scene make_scene(const std::string& name, const SceneParams& params);

/// The inputs of the named scene (SceneGenerator::inputs; empty for a scene
/// without, for a file, and for an unknown name). The same parameters as
/// make_scene; ids follow the scene's. Pure function.
std::vector<UserInput> scene_inputs(const std::string& name, const SceneParams& params);

/// A name from the registry, or else a path to a scene file (*.json).
Scene load_or_make_scene(const std::string& name_or_file, const SceneParams& params);

}  // namespace soda

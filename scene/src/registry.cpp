#include "soda/scene/registry.h"

#include <string>

#include "generators.h"
#include "soda/scene/scene_json.h"
#include "soda/scene/validate.h"

namespace soda {

const std::vector<SceneGenerator>& scene_registry() {
  static const std::vector<SceneGenerator> registry = {
      {"falling-cubes",
       "N unit cubes (or --random-scale edges in [0.2, 1.3] m) scattered over an L x L footprint "
       "(L = 2 sqrt(N) m) at heights 1..21 m, falling on a static ground: many small islands",
       detail::make_falling_cubes},
      {"cube-pile",
       "N unit cubes in columns 1.5 m apart, 10 layers from y = 2 m, falling into one connected "
       "heap: one giant island",
       detail::make_cube_pile},
  };
  return registry;
}

const SceneGenerator* find_scene_generator(const std::string& name) {
  for (const SceneGenerator& g : scene_registry())
    if (g.name == name) return &g;
  return nullptr;
}

Scene make_scene(const std::string& name, const SceneParams& params) {
  const SceneGenerator* g = find_scene_generator(name);
  if (g == nullptr) {
    std::string known;
    for (const SceneGenerator& s : scene_registry()) known += (known.empty() ? "" : ", ") + s.name;
    throw SceneError("unknown scene '" + name + "' (known scenes: " + known +
                     "; or give a path to a .json scene file)");
  }
  if (params.n < 0) throw SceneError(name + ": --n must be >= 0, got " + std::to_string(params.n));
  if (static_cast<std::uint64_t>(params.n) >= kMaxBodyId)
    throw SceneError(name + ": --n must be below 2^31, got " + std::to_string(params.n));
  Scene scene = g->make(params);
  validate_scene(scene, name);
  return scene;
}

Scene load_or_make_scene(const std::string& name_or_file, const SceneParams& params) {
  const bool is_file = name_or_file.size() > 5 &&
                       name_or_file.compare(name_or_file.size() - 5, 5, ".json") == 0;
  if (is_file || find_scene_generator(name_or_file) == nullptr) {
    if (is_file || name_or_file.find('/') != std::string::npos) return load_scene_file(name_or_file);
  }
  return make_scene(name_or_file, params);
}

}  // namespace soda

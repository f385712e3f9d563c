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
      {"heap",
       "cube-pile without its initial overlaps: columns and layers 1.8 m apart (> sqrt(3) m, so "
       "no two cubes touch at the start), falling into one connected heap: one giant island",
       detail::make_heap},
      // Border scenes (small; contacts on the borders x = 0 / z = 0).
      {"seam-stack",
       "two towers of N unit boxes (default 8, N <= 50) 1 mm apart: one on the plane x = 0, one on "
       "the corner x = 0, z = 0 where four territories of grid:2x1x2 meet",
       detail::make_seam_stack},
      {"cross-traffic",
       "12 unit boxes sliding at 5 m/s (mu 0.1): 8 from a ring of radius 6 m to the centre, 4 "
       "tangentially across x = 0 and z = 0 (N ignored)",
       detail::make_cross_traffic},
      {"projectile",
       "a sphere (r 0.25 m) at 20 m/s bouncing (restitution 0.8) in a 30 x 30 m walled arena, "
       "4 unit boxes in its way (N ignored)",
       detail::make_projectile},
      {"thrown-ball",
       "a sphere (r 0.2 m, 0.4 m cells) thrown at N m/s (0 for the default 40) through a row of 6 "
       "small 1 kg bricks in a 12 x 12 m walled arena: crosses several cells per step",
       detail::make_thrown_ball},
      {"chain",
       "a row of N touching unit boxes (default 16, N <= 200) centred on x = 0, the first pushed at "
       "3 m/s along +x: one island across every territory of grid:8x1x1",
       detail::make_chain},
      // Load scenes (the cost moves between regions over time).
      {"alternating-load",
       "N unit cubes (default 6000) in columns of 3 on landing spots left and right of a 16 m gap at "
       "x = 0, launched upwards so that the load alternates between the halves every 150 steps: left "
       "columns land, right columns land, then small boxes wake the left, then the right columns",
       detail::make_alternating_load},
      {"hotspot",
       "N unit cubes (default 400) in a square block sliding together at 8 m/s along +x on a "
       "low-friction ground, 0.25 m apart, into a catch row at the end of a track 3 block lengths "
       "long, where they jam into a pile and sleep: the load travels across the grid",
       detail::make_hotspot},
      {"drift",
       "N unit cubes (default 400) in a square block sliding together at 8 m/s along +x, 0.25 m "
       "apart, coming to rest by friction alone two block lengths on, gaps kept: with grid:2x1x1 "
       "the load drifts from one half to the other, every cube its own island",
       detail::make_drift},
      {"avalanche",
       "N unit cubes (default 400) resting 0.25 m apart on a 30 degree slope (mu 0.4) slide down "
       "and pile up on the run-out at its foot: the load flows downhill",
       detail::make_avalanche},
      {"rain",
       "N unit cubes (default 400) falling into a bin at one end of a floor in 16 waves, 30 steps "
       "apart; the first wave is in the scene, the others are add_body inputs (scene_inputs): the "
       "load grows in one region",
       detail::make_rain, detail::make_rain_inputs},
      // Soak scenes (one mechanism many times).
      {"border-shuttle",
       "N spheres (default 200, r 0.25 m) sliding frictionless at 4..8 m/s in a walled box 1 m long "
       "per 4 spheres, bouncing elastically: with grid:Kx1x1 they cross borders back and forth "
       "(migrations; docs/soak.md)",
       detail::make_border_shuttle},
      // Skip what a scene does not need (docs/skip.md).
      {"sleepers",
       "N unit cubes (default 100,000) created asleep (Body::asleep) on the ground 1.5 m apart, and "
       "ceil(N / 100) active unit cubes in columns 1.8 m apart, 5 layers from y = 3 m, falling onto the "
       "middle of the field and waking the sleepers they hit",
       detail::make_sleepers},
      {"idle-territories",
       "eight regions along x (cut them with --territories 8 --partition grid:8x1x1), 16 m of bare "
       "ground apart: in the first, N unit cubes (default 200) falling in columns 1.8 m apart, 5 layers "
       "from y = 3 m; in each of the seven others, N unit cubes created asleep 1.5 m apart: activity in "
       "one territory, the others idle",
       detail::make_idle_territories},
      // Joint scenes (docs/scenes.md, "Joint scenes").
      {"pendulums",
       "4 chains of N links (default 16, N <= 200; boxes 0.5 x 0.2 x 0.2 m, 1 kg) joined by point-to-point "
       "joints, hanging from static anchors at x = 0, held out along +x: they swing down through x = 0",
       detail::make_pendulums},
      {"chain-bridge",
       "a bridge of N planks (default 24, N <= 400; 1 x 0.2 x 2 m, 5 kg) hinged edge to edge between two static "
       "pillars 5 m up, spanning x = -N/2 .. N/2, and N / 2 boxes of 0.5 m dropped on it",
       detail::make_chain_bridge},
      {"ragdolls",
       "N ragdolls (default 16) of 11 capsules each, joined by cone-twist (neck, shoulders, hips) and hinge "
       "(waist, elbows, knees) joints, standing in columns 2 m apart and layers 2 m apart, falling into a pile",
       detail::make_ragdolls},
      {"hanging-chain",
       "N links (default 100, N <= 1000; boxes 0.1 x 0.5 x 0.1 m, 1 kg) joined by point-to-point joints, hanging "
       "straight down from a static anchor, the lowest pushed sideways at 2 m/s: the chain sways",
       detail::make_hanging_chain},
      {"heavy-chain",
       "a box of 0.5 m and N kg (default 100) under a chain of 10 links (boxes 0.1 x 0.5 x 0.1 m, 1 kg) joined by "
       "point-to-point joints, hanging from a static anchor, the box pushed sideways at 1 m/s: a mass ratio of "
       "N : 1 across a joint",
       detail::make_heavy_chain},
      {"motor-hinge",
       "two arms (1 x 0.1 x 0.1 m, 1 kg) hinged at one end to static posts and driven by hinge motors: the first "
       "free at N rad/s (default 2), the second limited to [-pi/2, 0] at -1 rad/s, lifted to the vertical and held",
       detail::make_motor_hinge},
      // Stress scenes (numerical stability).
      {"tower", "N unit boxes (default 10, N <= 100) stacked exactly resting on the origin",
       detail::make_tower},
      {"pyramid",
       "a 2-D pyramid of unit boxes with base N (default 10, N <= 50): N (N + 1) / 2 boxes",
       detail::make_pyramid},
      {"mass-ratio", "a 1 kg unit box under a unit box of N kg (N >= 1, 0 for the default 100)",
       detail::make_mass_ratio},
      {"bullet-vs-wall",
       "a sphere of radius 0.05 m at N m/s (0 for the default 200) against a static wall 0.1 m "
       "thick: tunnels without CCD",
       detail::make_bullet_vs_wall},
      {"far-origin",
       "cube-pile with 50 cubes (same seed, same pile) moved N m along x (0 for the default 1e4)",
       detail::make_far_origin},
      {"dense-pile",
       "N cubes of edge 0.5 m (0 for the default 1000) tilted slightly, dropped into a 4 x 4 m bin",
       detail::make_dense_pile},
      {"card-house",
       "N storeys (default 5, N <= 20) of two upright planks 0.1 x 1 x 1 m on their thin edge under a lid "
       "plank 1.2 x 0.1 x 1 m, each resting exactly on the one below",
       detail::make_card_house},
      {"heavy-drop",
       "a tower of N unit boxes of 1 kg (default 10, N <= 50) and a 100 kg unit box dropped on it from 1 m",
       detail::make_heavy_drop},
      {"sphere-chain",
       "N touching spheres of radius 0.5 m in a row along x (default 100, N <= 1000); the first pushed "
       "into the others at 5 m/s",
       detail::make_sphere_chain},
      {"mixed-sizes",
       "a 10 m box of 1000 kg with N x N boxes of 0.05 m and 0.1 kg resting on it and N x N on the "
       "ground beside it (default N 5, N <= 20)",
       detail::make_mixed_sizes},
      {"big-bodies",
       "N unit cubes (default 300) in a loose block, and bodies of 2 m, 5 m and 20 m across (boxes, "
       "capsules, convex hulls; 5 kg per m^3 of bounding box) falling into it across territory borders",
       detail::make_big_bodies},
      {"compounds",
       "N chairs and tables made of boxes (compound shapes; default 200, every third a table) falling in a loose "
       "block onto a ground and two static tables, across territory borders",
       detail::make_compounds},
      {"terrain",
       "N boulders (convex hulls), balls and boxes (default 200) in a block on the high slope of a valley, a static "
       "heightfield 80 x 40 m sampled every 0.5 m (both sides grow as sqrt(N / 200) above 200), rolling down "
       "across territory borders into its basin",
       detail::make_terrain},
      {"city",
       "N pieces of debris (boxes, slabs, rubble hulls; default 200) falling from 20 m onto a street grid: one static "
       "triangle mesh of ground and buildings (8 m blocks 4 to 14 m high, 6 m streets; at least 3 x 3 blocks, more "
       "as N grows)",
       detail::make_city},
      {"conveyor",
       "N boxes (default 120) on kinematic platforms moving along looping paths across territory borders: four "
       "pallets shuttling along x at 2 m/s, a turntable and an elevator, over a ground they drop boxes on",
       detail::make_conveyor},
      {"plank-pile",
       "a plank N m long (default 8, N <= 40; 0.2 x 0.6 m, 40 kg) dropped end first from 0.5 m onto a pile of "
       "4 x 4 x 3 unit cubes",
       detail::make_plank_pile},
      {"heavy-slide",
       "a 5 m box of 10 t sliding at N m/s (default 6) along +x on a ground (friction 0.4) until friction stops "
       "it, across the borders of grid:Kx1x1, into two rows of unit cubes",
       detail::make_heavy_slide},
      // Analytic scenes (closed-form answers; N ignored).
      {"free-fall", "one sphere falling from y = 100 m; 180 steps of free flight",
       detail::make_free_fall},
      {"incline",
       "a unit box sliding down a 30 degree incline with mu = 0.3: a = g (sin 30 - 0.3 cos 30)",
       detail::make_incline},
      {"resting-stack", "3 unit boxes stacked exactly resting: drift should be zero",
       detail::make_resting_stack},
      {"rolling-sphere", "a sphere (r 0.5 m) rolling without slipping at 2 m/s from x = -10 m",
       detail::make_rolling_sphere},
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

std::vector<UserInput> scene_inputs(const std::string& name, const SceneParams& params) {
  const SceneGenerator* g = find_scene_generator(name);
  if (g == nullptr || !g->inputs) return {};
  return g->inputs(params);
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

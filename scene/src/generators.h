// The scene generators of the registry (definitions: BENCHMARKS.md, docs/scenes.md).
#pragma once

#include "soda/scene/registry.h"

namespace soda::detail {

// Shared by the generators (declared once: every scene means the same by them).
/// The ground is a static box whose top face is at y = 0, covering the
/// dynamic bodies' footprint plus this margin on every side (m), so bodies
/// that tumble off a cluster still land.
inline constexpr double kGroundMargin = 10.0;
/// The ground's id in every generated scene.
inline constexpr BodyId kGroundId = 0;
/// Half extents of a unit box (m).
inline const Vec3 kUnitHalf = Vec3::Constant(0.5);
/// A rotation by `angle` (rad) about +y.
inline Quat yaw(double angle) { return Quat(Eigen::AngleAxisd(angle, Vec3::UnitY())); }

// The sleepers and idle-territories scenes: sleepers are unit cubes 1.5 m
// apart (0.5 m gaps, wider than twice the contact breaking threshold, so no
// two share a contact or a broadphase pair); active cubes stand in columns
// 1.8 m apart (> sqrt(3): randomly oriented unit cubes cannot touch at the
// start), in kActiveLayers layers 1.8 m apart from y = kFirstActiveY.
inline constexpr double kSleeperSpacing = 1.5;
inline constexpr double kActiveSpacing = 1.8;
inline constexpr int kActiveLayers = 5;
inline constexpr double kFirstActiveY = 3.0;

// generators.cpp: the thesis' scenes.
Scene make_falling_cubes(const SceneParams& params);
Scene make_cube_pile(const SceneParams& params);
/// cube-pile at 1.8 m spacing: no cubes in contact at the start.
Scene make_heap(const SceneParams& params);

// border_scenes.cpp: small scenes that put contacts on territory borders.
Scene make_seam_stack(const SceneParams& params);
Scene make_cross_traffic(const SceneParams& params);
Scene make_projectile(const SceneParams& params);
Scene make_thrown_ball(const SceneParams& params);
Scene make_chain(const SceneParams& params);

// load_scenes.cpp: the cost moves between regions over time.
Scene make_alternating_load(const SceneParams& params);

// moving_load_scenes.cpp, rain_scene.cpp: load-balance experiments (the
// load moves or grows in one region).
Scene make_hotspot(const SceneParams& params);
Scene make_drift(const SceneParams& params);
Scene make_avalanche(const SceneParams& params);
Scene make_rain(const SceneParams& params);
/// rain's later waves: add_body inputs at their steps (ids after the scene's).
std::vector<UserInput> make_rain_inputs(const SceneParams& params);

// soak_scenes.cpp: long runs of one mechanism.
Scene make_border_shuttle(const SceneParams& params);

// sleepers_scene.cpp: most of the scene asleep (docs/skip.md).
Scene make_sleepers(const SceneParams& params);
/// Active cubes of a sleepers scene with this many sleepers: ceil(n / 100).
int sleepers_active_count(int sleepers);
// idle_territories_scene.cpp: eight regions along x, activity in one (docs/skip.md).
Scene make_idle_territories(const SceneParams& params);

// joint_scenes.cpp: scenes with joints (docs/scenes.md, "Joint scenes").
Scene make_pendulums(const SceneParams& params);
Scene make_chain_bridge(const SceneParams& params);
Scene make_ragdolls(const SceneParams& params);
Scene make_hanging_chain(const SceneParams& params);
Scene make_heavy_chain(const SceneParams& params);
Scene make_motor_hinge(const SceneParams& params);

// stress_scenes.cpp: numerical stability (stress) and closed-form answers
// (analytic).
Scene make_tower(const SceneParams& params);
Scene make_pyramid(const SceneParams& params);
Scene make_mass_ratio(const SceneParams& params);
Scene make_bullet_vs_wall(const SceneParams& params);
Scene make_far_origin(const SceneParams& params);
Scene make_dense_pile(const SceneParams& params);
Scene make_card_house(const SceneParams& params);
Scene make_heavy_drop(const SceneParams& params);
Scene make_sphere_chain(const SceneParams& params);
Scene make_mixed_sizes(const SceneParams& params);
// big_bodies_scene.cpp: bodies of 2, 5 and 20 m across among unit cubes; a
// long plank dropped on a pile; a heavy 5 m box sliding across borders.
Scene make_big_bodies(const SceneParams& params);
// compounds_scene.cpp: chairs and tables made of boxes (compound shapes).
Scene make_compounds(const SceneParams& params);
// terrain_scene.cpp: boulders, balls and boxes rolling down a heightfield valley.
Scene make_terrain(const SceneParams& params);
// city_scene.cpp: debris falling onto a triangle-mesh street grid.
Scene make_city(const SceneParams& params);
// conveyor_scene.cpp: kinematic platforms carrying boxes across borders.
Scene make_conveyor(const SceneParams& params);
Scene make_plank_pile(const SceneParams& params);
Scene make_heavy_slide(const SceneParams& params);
Scene make_free_fall(const SceneParams& params);
Scene make_incline(const SceneParams& params);
Scene make_resting_stack(const SceneParams& params);
Scene make_rolling_sphere(const SceneParams& params);

// Building blocks shared by border_scenes.cpp and stress_scenes.cpp (defined
// in border_scenes.cpp). Units: metres, kilograms.

/// default_n when n = 0, n when 1 <= n <= max_n; a larger n is a SceneError
/// (never silently replaced): scenes whose n is a small count (a tower's height).
int count_or_default(const SceneParams& params, int default_n, int max_n);
/// n when n >= 1, else default_n: scenes whose n is a magnitude (a speed, a
/// distance, a mass ratio) take any positive n, the CLI's 1000 included.
int magnitude_or_default(const SceneParams& params, int default_n);
/// An empty scene with this name and the params' seed (stress scenes).
Scene start_scene(const char* name, const SceneParams& params);
/// Static ground box, id 0, top face at y = 0, centred under (centre_x, 0),
/// half_footprint in x and z.
Body flat_ground(double half_footprint, double friction, double centre_x = 0.0,
                 double half_thickness = 0.5);
/// Static box (walls, inclines); friction 0.5, restitution 0.
Body static_box(BodyId id, const Vec3& half_extents, const Vec3& position,
                const Quat& orientation = Quat::Identity());
/// Dynamic box at rest; friction 0.5, restitution 0.
Body dynamic_box(BodyId id, const Vec3& half_extents, double mass, const Vec3& position,
                 const Quat& orientation = Quat::Identity());
/// Dynamic sphere at rest; friction 0.5, restitution 0.
Body dynamic_sphere(BodyId id, double radius, double mass, const Vec3& position);

}  // namespace soda::detail

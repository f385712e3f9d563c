// lb_replay: what a load-balancing policy would decide on a scene, replayed
// offline (docs/loadbalance.md, "Replaying a policy"). One canonical world
// runs the scene; at every balance step the cells' bodies, awake bodies and
// contact pairs are gathered into a LoadView for the current territory map,
// each world's busy time is the prior cost model's prediction for what it
// holds (not a measurement: no threads, no timing noise), the policy
// decides and its moves are applied to the map. Prints the mean over
// balance steps of max / mean busy (the imbalance) and the cells moved.
//
//   lb_replay SCENE N K POLICY PARTITION [PERIOD [MAX_CELLS [verbose]]]
//   lb_replay hotspot 400 8 diffusive grid:8x1x1 20 16
//
// A tool for tuning policies before a run; the runtime's `--lb` decides on
// measured busy times.
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "soda/grid/partition.h"
#include "soda/loadbalance/cost_model.h"
#include "soda/loadbalance/policy.h"
#include "soda/scene/registry.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/world_snapshot.h"

using namespace soda;

int main(int argc, char** argv) {
  if (argc < 6) {
    std::fprintf(stderr, "usage: %s SCENE N K POLICY PARTITION [PERIOD [MAX_CELLS [verbose]]]\n", argv[0]);
    return 2;
  }
  try {
    const std::string scene_name = argv[1], policy_name = argv[4], partition = argv[5];
    const int n = std::atoi(argv[2]), k = std::atoi(argv[3]);
    BalanceOptions options;
    options.policy = policy_name;
    if (argc > 6) options.period = std::atoi(argv[6]);
    if (argc > 7) options.max_cells_per_move = std::atoi(argv[7]);
    const bool verbose = argc > 8;
    const Scene scene = make_scene(scene_name, {n, 1, false});
    TerritoryMap map = make_partition(partition, scene, k, GridOptions{});
    auto policy = make_balance_policy(options);
    CanonicalWorld world(scene);
    std::set<BodyId> dynamic;
    for (const Body& b : scene.bodies)
      if (!b.is_static) dynamic.insert(b.id);
    const CostModel cost;  // the prior stands in for measured busy times
    double imbalance_sum = 0;
    int balance_steps = 0;
    long moved = 0;
    for (int s = 1; s <= scene.settings.steps; ++s) {
      world.step();
      if (s % options.period != 0) continue;
      const CellBox& box = map.box();
      std::map<BodyId, CellCoord> home;
      std::map<CellCoord, CellLoad> cells;
      for (const BodyState& b : world.body_states()) {
        if (dynamic.count(b.id) == 0) continue;
        const CellCoord c = box.clamp(map.grid().cell_of(Vec3(b.origin[0], b.origin[1], b.origin[2])));
        home[b.id] = c;
        CellLoad& cell = cells[c];
        cell.cell = c;
        cell.owner = map.owner(c);
        ++cell.bodies;
        if (b.activation_state == 1 || b.activation_state == 3) ++cell.awake_bodies;  // ACTIVE_TAG, WANTS_DEACTIVATION
      }
      for (const ManifoldState& m : world.contact_state()) {  // key body: the lower dynamic id
        const bool d0 = dynamic.count(m.id0) != 0, d1 = dynamic.count(m.id1) != 0;
        ++cells[home[d0 && d1 ? std::min(m.id0, m.id1) : (d0 ? m.id0 : m.id1)]].contact_pairs;
      }
      LoadView view;
      view.step = s;
      view.map = &map;
      view.worlds.resize(static_cast<std::size_t>(k));
      for (WorldId w = 0; w < k; ++w) {
        view.worlds[static_cast<std::size_t>(w)].world = w;
        view.worlds[static_cast<std::size_t>(w)].steps = options.period;
        view.worlds[static_cast<std::size_t>(w)].cells = map.cell_count(w);
      }
      for (const auto& [c, cell] : cells) {
        view.cells.push_back(cell);
        WorldLoad& w = view.worlds[static_cast<std::size_t>(cell.owner)];
        w.bodies += cell.bodies;
        w.awake_bodies += cell.awake_bodies;
        w.contact_pairs += cell.contact_pairs;
      }
      double top = 0, sum = 0;
      for (WorldLoad& w : view.worlds) {
        w.busy = cost.predict(w);
        top = std::max(top, w.busy);
        sum += w.busy;
      }
      const double imbalance = top / (sum / k);
      imbalance_sum += imbalance;
      ++balance_steps;
      const std::vector<CellMove> moves = policy->decide(view);
      moved += static_cast<long>(moves.size());
      std::vector<std::pair<CellCoord, WorldId>> changes;
      for (const CellMove& m : moves) changes.emplace_back(m.cell, m.to);
      map = map.reassigned(changes);
      if (verbose) {
        std::printf("step %d imbalance %.2f moves %zu busy (us):", s, imbalance, moves.size());
        for (const WorldLoad& w : view.worlds) std::printf(" %.0f", w.busy * 1e6);
        std::printf("\n");
      }
    }
    std::printf("%s n=%d K=%d %s %s period %d max_cells %d: mean imbalance %.3f over %d balance steps, cells moved %ld\n",
                scene_name.c_str(), n, k, policy_name.c_str(), partition.c_str(), options.period,
                options.max_cells_per_move, imbalance_sum / std::max(1, balance_steps), balance_steps, moved);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lb_replay: %s\n", e.what());
    return 2;
  }
}

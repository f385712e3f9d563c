// One world's merge of border islands (world_process.h, Merging): the
// fragments' headers spread until each island is complete, its data climbs
// the island's tree to the root, which solves it, and the result descends.
#include <algorithm>
#include <map>
#include <set>
#include <stdexcept>
#include <string>

#include "step/world_process.h"

namespace soda {

void PartitionedWorld::Process::flush_merger() {
  for (auto& [n, fragments] : s_.merger.take_outgoing()) {
    ++sums_.relay_messages_sent;
    send(n, Message{.payload = FragmentBatch{std::move(fragments)}});
  }
  for (const std::vector<const Fragment*>& island : s_.merger.take_closed()) close_island(island);
}

// An island is complete here. Its root is the world whose fragments weigh
// most (owned bodies + manifolds held: the least data to gather, and the
// roots of many islands spread over their worlds in proportion to their
// shares), ties to the owner of the smallest body; its tree is the BFS tree
// of its worlds (joined by its links, ascending) from the root. Every world
// sees the same headers, so every world names the same root; the solve is on
// copies in id order, so which world solves changes no bit.
void PartitionedWorld::Process::close_island(const std::vector<const Fragment*>& island) {
  std::map<WorldId, std::set<WorldId>> adjacent;
  std::map<WorldId, std::uint64_t> weight;
  BodyId smallest = kNoBody;
  WorldId smallest_owner = kNoWorld;
  for (const Fragment* f : island) {
    adjacent[f->world];
    weight[f->world] += f->weight;
    for (const LinkOut& l : f->links_out) adjacent[f->world].insert(l.owner), adjacent[l.owner].insert(f->world);
    for (const LinkIn& l : f->links_in) adjacent[f->world].insert(l.world), adjacent[l.world].insert(f->world);
    if (f->first_body < smallest) {
      smallest = f->first_body;
      smallest_owner = f->world;
    }
  }
  WorldId root = smallest_owner;
  for (const auto& [w, units] : weight)  // ascending world: ties to the smallest body's owner
    if (units > weight[root]) root = w;
  ++sums_.merged_islands;
  clock_.count(Stage::Merge, 1);
  sums_.merged_island_worlds_sum += adjacent.size();
  sums_.merged_island_worlds_max = std::max<std::uint64_t>(sums_.merged_island_worlds_max, adjacent.size());
  if (solve_everywhere_) {
    StageClock::Scope solve(clock_, Stage::Solve);
    s_.world->apply_island_result(s_.world->solve_border_island(island));
    return;
  }
  std::map<WorldId, WorldId> parent{{root, root}};
  std::map<WorldId, std::uint64_t> depth{{root, 0}};
  std::vector<WorldId> queue{root};
  for (std::size_t i = 0; i < queue.size(); ++i)
    for (WorldId n : adjacent[queue[i]])
      if (parent.emplace(n, queue[i]).second) {
        queue.push_back(n);
        depth[n] = depth[queue[i]] + 1;
      }
  clock_.island_depth(depth[queue.back()]);  // BFS: the last world is the deepest
  WorldStep::Island& is = s_.islands[smallest];
  is.root = root;
  is.parent = parent.at(s_.world->id());
  for (const auto& [w, p] : parent)
    if (p == s_.world->id() && w != s_.world->id()) is.children.push_back(w);
  is.data = s_.merger.take_mine(island);  // moved, not copied: the merger is done with them
  is.gathers_missing = is.children.size();
  auto early = s_.early_gathers.find(smallest);
  if (early != s_.early_gathers.end()) {
    std::vector<Fragment> fragments = std::move(early->second);
    s_.early_gathers.erase(early);
    take_gather(smallest, std::move(fragments));  // may complete the gather
    return;
  }
  if (is.gathers_missing == 0) gathered(smallest);
}

// A child's subtree data; data arriving before the island is complete here
// waits. A child's Gather always holds the child's own fragments, so the
// children heard from are the children with a fragment in the data.
void PartitionedWorld::Process::take_gather(BodyId island, std::vector<Fragment> fragments) {
  auto it = s_.islands.find(island);
  if (it == s_.islands.end()) {
    std::vector<Fragment>& e = s_.early_gathers[island];
    e.insert(e.end(), std::make_move_iterator(fragments.begin()), std::make_move_iterator(fragments.end()));
    return;
  }
  WorldStep::Island& is = it->second;
  for (Fragment& f : fragments) is.data.push_back(std::move(f));
  std::set<WorldId> worlds;
  for (const Fragment& f : is.data) worlds.insert(f.world);
  std::size_t heard = 0;
  for (WorldId c : is.children) heard += worlds.count(c);
  is.gathers_missing = is.children.size() - heard;
  if (is.gathers_missing == 0) gathered(island);
}

// The subtree's data is here: the root solves, the others pass it up.
void PartitionedWorld::Process::gathered(BodyId island) {
  WorldStep::Island& is = s_.islands.at(island);
  if (is.root != s_.world->id()) {
    ++sums_.relay_messages_sent;
    send(is.parent, Message{.payload = GatherBatch{island, std::move(is.data)}});
    is.data.clear();
    return;
  }
  std::sort(is.data.begin(), is.data.end(), [](const Fragment& a, const Fragment& b) {
    return std::make_pair(a.world, a.root) < std::make_pair(b.world, b.root);
  });
  std::vector<const Fragment*> fragments;
  for (const Fragment& f : is.data) fragments.push_back(&f);
  std::shared_ptr<const IslandResult> result;
  {
    StageClock::Scope solve(clock_, Stage::Solve);
    result = std::make_shared<const IslandResult>(s_.world->solve_border_island(fragments));
  }
  take_result(std::move(result));
}

// A solved island: keep this world's part and pass it down the tree. (It
// cannot arrive before the island is complete here: the root needs this
// world's data first.)
void PartitionedWorld::Process::take_result(std::shared_ptr<const IslandResult> result) {
  auto it = s_.islands.find(result->island);
  if (it == s_.islands.end())
    throw std::logic_error("world " + std::to_string(s_.world->id()) + ": result for island " +
                           std::to_string(result->island) + ", which is not complete here");
  // Children first: they apply their part while this world applies its own.
  for (WorldId child : it->second.children) {
    ++sums_.relay_messages_sent;
    send(child, Message{.payload = ResultBatch{{result}}});
  }
  s_.islands.erase(it);
  s_.world->apply_island_result(*result);
}

}  // namespace soda

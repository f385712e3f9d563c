// Internal: merge_islands for one world and one step — joining the fragments
// of border islands across worlds by flooding them along island links, and
// knowing locally, without any barrier, when an island is complete.
//
// A fragment's links (border_records.h) are facts both ends know after the
// glue exchange: a ghost g of world N in my fragment F (link out) is the same
// fact as "my body g is glued by F" in N's fragment (link in). So a set of
// fragments is a whole island exactly when it is closed: every link out of a
// fragment in the set is matched by a link in of a fragment in the set, and
// every link in names a fragment in the set.
//
// Flooding: whenever a world learns fragments, it sends every fragment of the
// learnt fragments' component that a neighbour does not know yet (neither sent
// to it nor received from it) to each neighbour its own fragments of that
// component link to. A world that finds its component closed has already sent
// it whole to those neighbours, so every world of the island closes. Each
// world stops listening when all of its fragments' islands are closed; late
// fragments for that step are dropped by the caller.
#pragma once

#include <deque>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "soda/worlds/border_records.h"
#include "soda/worlds/disjoint_sets.h"

namespace soda {

class IslandMerger {
 public:
  using FragmentId = std::pair<WorldId, BodyId>;  // (world, root)

  /// Starts a step with this world's fragments (ascending root). With
  /// carry_data, fragments travel with their bodies and manifolds; without,
  /// only their headers (ids, first body, links) do.
  void start(WorldId me, std::vector<Fragment> mine, bool carry_data);
  /// Fragments from a neighbour.
  void receive(WorldId from, std::vector<Fragment> fragments);
  /// Fragments to send, per neighbour, since the last call.
  std::vector<std::pair<WorldId, std::vector<Fragment>>> take_outgoing();
  /// Islands completed since the last call: every fragment of each, ordered
  /// by (world, root); this world's own with their data, the others' with
  /// data only under carry_data. Pointers stay valid until the next start().
  std::vector<std::vector<const Fragment*>> take_closed();
  /// This world's fragments of a closed island, moved out of the merger
  /// (their nodes keep the headers only). Without carry_data only: then the
  /// merger never sends a fragment's data, and a closed component is never
  /// sent again, so the data is read once, by the caller. Saves copying a
  /// root's own part of a large merged island every step.
  std::vector<Fragment> take_mine(const std::vector<const Fragment*>& island);
  /// True when every fragment of this world belongs to a completed island.
  bool done() const { return open_ == 0; }
  /// For a deadlock's report: the open components holding a fragment of
  /// this world, each as its fragments and its unresolved link count.
  std::string describe_open() const;

  std::size_t fragments_received() const { return received_; }
  std::size_t fragments_relayed() const { return relayed_; }  // sent fragments of other worlds

 private:
  struct Node {
    Fragment fragment;
    bool mine = false;
  };
  // At component roots:
  struct Component {
    std::vector<int> members;       // node indices
    int unresolved = 0;             // links whose other end is not known yet
    std::vector<WorldId> targets;   // neighbours my fragments in it link to, ascending
    bool has_mine = false;
    bool closed = false;
  };

  int add(Fragment fragment, bool mine);
  int find(int i) { return sets_.find(i); }
  int unite(int a, int b);
  void update();

  WorldId me_ = kNoWorld;
  bool carry_data_ = true;
  std::deque<Node> nodes_;                          // stable addresses
  DisjointSets sets_;                               // over nodes_, a component per root
  std::map<FragmentId, int> index_;
  // (owner world, holder world, holder root, body) -> the owner's fragment
  // holding `body` with that link in.
  std::map<std::tuple<WorldId, WorldId, BodyId, BodyId>, int> by_link_in_;
  std::map<int, Component> components_;             // by root
  std::set<int> dirty_;                             // roots changed since the last update
  std::map<WorldId, std::vector<char>> told_;       // per neighbour: node known to it
  std::size_t open_ = 0;                            // my fragments not in a closed island
  std::map<WorldId, std::vector<Fragment>> outgoing_;
  std::vector<std::vector<const Fragment*>> closed_;
  std::size_t received_ = 0;
  std::size_t relayed_ = 0;
};

}  // namespace soda

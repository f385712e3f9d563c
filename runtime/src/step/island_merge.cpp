#include "step/island_merge.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace soda {

void IslandMerger::start(WorldId me, std::vector<Fragment> mine, bool carry_data) {
  me_ = me;
  carry_data_ = carry_data;
  nodes_.clear();
  sets_.reset(0);
  index_.clear();
  by_link_in_.clear();
  components_.clear();
  dirty_.clear();
  told_.clear();
  outgoing_.clear();
  closed_.clear();
  open_ = 0;
  received_ = relayed_ = 0;
  for (Fragment& f : mine) {
    if (f.world != me) throw std::logic_error("IslandMerger: a fragment of another world given as mine");
    add(std::move(f), true);
  }
  update();
}

void IslandMerger::receive(WorldId from, std::vector<Fragment> fragments) {
  received_ += fragments.size();
  std::vector<char>& told = told_[from];
  for (Fragment& f : fragments) {
    const FragmentId id{f.world, f.root};
    auto it = index_.find(id);
    // A fragment already known is identical: one world makes each fragment.
    const int i = it != index_.end() ? it->second : add(std::move(f), false);
    if (told.size() <= static_cast<std::size_t>(i)) told.resize(static_cast<std::size_t>(i) + 1, 0);
    told[static_cast<std::size_t>(i)] = 1;
  }
  update();
}

int IslandMerger::unite(int a, int b) {
  a = find(a), b = find(b);
  if (a == b) return a;
  Component& ca = components_.at(a);
  Component& cb = components_.at(b);
  if (ca.members.size() < cb.members.size()) return unite(b, a);
  sets_.attach(b, a);
  ca.members.insert(ca.members.end(), cb.members.begin(), cb.members.end());
  ca.unresolved += cb.unresolved;
  std::vector<WorldId> targets;
  std::set_union(ca.targets.begin(), ca.targets.end(), cb.targets.begin(), cb.targets.end(),
                 std::back_inserter(targets));
  ca.targets = std::move(targets);
  ca.has_mine = ca.has_mine || cb.has_mine;
  components_.erase(b);
  dirty_.erase(b);
  dirty_.insert(a);
  return a;
}

// A new fragment: its links to known fragments resolve (on both ends) and
// join their components; the others stay unresolved.
int IslandMerger::add(Fragment f, bool mine) {
  const int i = static_cast<int>(nodes_.size());
  const FragmentId id{f.world, f.root};
  nodes_.push_back(Node{std::move(f), mine});
  sets_.add();
  const Fragment& frag = nodes_.back().fragment;
  index_.emplace(id, i);
  Component c;
  c.members.push_back(i);
  c.has_mine = mine;
  if (mine) {
    ++open_;
    for (const LinkOut& l : frag.links_out) c.targets.push_back(l.owner);
    for (const LinkIn& l : frag.links_in) c.targets.push_back(l.world);
    std::sort(c.targets.begin(), c.targets.end());
    c.targets.erase(std::unique(c.targets.begin(), c.targets.end()), c.targets.end());
  }
  components_.emplace(i, std::move(c));
  dirty_.insert(i);
  std::vector<int> partners;
  int unresolved = 0;
  for (const LinkOut& l : frag.links_out) {
    auto p = by_link_in_.find({l.owner, frag.world, frag.root, l.body});
    if (p == by_link_in_.end()) {
      ++unresolved;
    } else {
      partners.push_back(p->second);
    }
  }
  for (const LinkIn& l : frag.links_in) {
    by_link_in_[{frag.world, l.world, l.fragment_root, l.body}] = i;
    auto p = index_.find(FragmentId{l.world, l.fragment_root});
    if (p == index_.end()) {
      ++unresolved;
    } else {
      partners.push_back(p->second);
    }
  }
  components_.at(i).unresolved = unresolved;
  // Each partner had this link counted as unresolved on its end.
  for (int p : partners) --components_.at(find(p)).unresolved;
  for (int p : partners) unite(i, p);
  return i;
}

// Forward what changed to my neighbours in each changed component that holds
// a fragment of mine; complete the closed ones.
void IslandMerger::update() {
  for (int root : std::vector<int>(dirty_.begin(), dirty_.end())) {
    auto it = components_.find(root);
    if (it == components_.end()) continue;
    Component& c = it->second;
    if (!c.has_mine || c.closed) continue;
    for (WorldId n : c.targets) {
      std::vector<char>& told = told_[n];
      if (told.size() < nodes_.size()) told.resize(nodes_.size(), 0);
      for (int m : c.members) {
        if (told[static_cast<std::size_t>(m)]) continue;
        told[static_cast<std::size_t>(m)] = 1;
        const Fragment& f = nodes_[static_cast<std::size_t>(m)].fragment;
        if (carry_data_) {
          outgoing_[n].push_back(f);
        } else {
          outgoing_[n].push_back(Fragment{f.world, f.root, f.first_body, f.weight, f.links_out, f.links_in, {}, {}, {}});
        }
        if (f.world != me_) ++relayed_;
      }
    }
    if (c.unresolved < 0) throw std::logic_error("IslandMerger: a link resolved twice");
    if (c.unresolved == 0) {
      c.closed = true;
      std::vector<const Fragment*> island;
      for (int m : c.members) {
        island.push_back(&nodes_[static_cast<std::size_t>(m)].fragment);
        if (nodes_[static_cast<std::size_t>(m)].mine) --open_;
      }
      std::sort(island.begin(), island.end(), [](const Fragment* a, const Fragment* b) {
        return std::make_pair(a->world, a->root) < std::make_pair(b->world, b->root);
      });
      closed_.push_back(std::move(island));
    }
  }
  dirty_.clear();
}

std::vector<std::pair<WorldId, std::vector<Fragment>>> IslandMerger::take_outgoing() {
  std::vector<std::pair<WorldId, std::vector<Fragment>>> out;
  for (auto& [n, fs] : outgoing_)
    if (!fs.empty()) out.emplace_back(n, std::move(fs));
  outgoing_.clear();
  return out;
}

std::vector<std::vector<const Fragment*>> IslandMerger::take_closed() {
  std::vector<std::vector<const Fragment*>> out = std::move(closed_);
  closed_.clear();
  return out;
}

std::vector<Fragment> IslandMerger::take_mine(const std::vector<const Fragment*>& island) {
  if (carry_data_) throw std::logic_error("IslandMerger::take_mine: fragments carry their data");
  std::vector<Fragment> out;
  for (const Fragment* f : island) {
    if (f->world != me_) continue;
    auto it = index_.find(FragmentId{f->world, f->root});
    if (it == index_.end() || &nodes_[static_cast<std::size_t>(it->second)].fragment != f)
      throw std::logic_error("IslandMerger::take_mine: a fragment not held here");
    Node& node = nodes_[static_cast<std::size_t>(it->second)];
    if (!components_.at(find(it->second)).closed)
      throw std::logic_error("IslandMerger::take_mine: the island is not closed");
    out.push_back(std::move(node.fragment));
    // The node keeps its header (update() and later lookups read it).
    node.fragment = Fragment{out.back().world, out.back().root, out.back().first_body, out.back().weight,
                             out.back().links_out,
                             out.back().links_in, {}, {}, {}};
  }
  return out;
}

std::string IslandMerger::describe_open() const {
  std::string out = std::to_string(open_) + " fragments of its own open";
  for (const auto& [root, c] : components_) {
    if (!c.has_mine || c.closed) continue;
    out += "; {";
    for (int m : c.members) {
      const Fragment& f = nodes_[static_cast<std::size_t>(m)].fragment;
      out += " " + std::to_string(f.world) + ":" + std::to_string(f.root) + "(out";
      for (const LinkOut& l : f.links_out) out += " " + std::to_string(l.owner) + "/" + std::to_string(l.body);
      out += "; in";
      for (const LinkIn& l : f.links_in)
        out += " " + std::to_string(l.world) + ":" + std::to_string(l.fragment_root) + "/" + std::to_string(l.body);
      out += ")";
    }
    out += " } " + std::to_string(c.unresolved) + " links unresolved";
  }
  return out;
}

}  // namespace soda

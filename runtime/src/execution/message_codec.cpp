// Messages <-> bytes (message_codec.h).
#include "soda/runtime/message_codec.h"

#include <algorithm>
#include <cstring>
#include <string>

#include "soda/scene/fnv1a.h"
#include "soda/worlds/value_codec.h"

namespace soda {
namespace {

constexpr char kMagic[8] = {'S', 'O', 'D', 'A', 'M', 'S', 'G', '1'};
constexpr std::uint32_t kVersion = 9;  // 2: epoch, Control; 3: a fragment's weight; 4: collision filters; 5: compound shapes;
                                       // 6: a body's user data; 7: its sensor flag; 8: joints (fragments,
                                       // island results, migrants); 9: rewinds
constexpr std::size_t kMinRecordBytes = kMinBodyBytes + 6 * sizeof(btScalar);

[[noreturn]] void raise_message_error(const std::string& message) { throw MessageFormatError(message); }

void write_record(ByteWriter& w, const BodyRecord& r) {
  write_body(w, r.body);
  w.put(r.total_force);
  w.put(r.total_torque);
}

BodyRecord read_record(ByteReader& r) {
  BodyRecord rec;
  rec.body = read_body(r);
  if (rec.body.description.is_static) r.fail("a static body in a message");
  r.get(rec.total_force);
  r.get(rec.total_torque);
  return rec;
}

void write_manifolds(ByteWriter& w, const std::vector<ManifoldState>& ms) {
  w.count(ms.size());
  for (const ManifoldState& m : ms) write_manifold(w, m);
}

std::vector<ManifoldState> read_manifolds(ByteReader& r) {
  std::vector<ManifoldState> ms(r.count(kMinManifoldBytes));
  for (std::size_t i = 0; i < ms.size(); ++i) {
    ms[i] = read_manifold(r);
    if (i > 0 && !(std::make_pair(ms[i - 1].id0, ms[i - 1].id1) < std::make_pair(ms[i].id0, ms[i].id1)))
      r.fail("manifolds not sorted by (id0, id1)");
  }
  return ms;
}

WorldId read_world(ByteReader& r) {
  const auto w = r.get<WorldId>();
  if (w < 0) r.fail("negative world id");
  return w;
}

BodyId read_id(ByteReader& r) {
  const auto id = r.get<BodyId>();
  if (id > kMaxBodyId) r.fail("body id above kMaxBodyId");
  return id;
}

void write_joints(ByteWriter& w, const std::vector<JointSnapshot>& joints) {
  w.count(joints.size());
  for (const JointSnapshot& j : joints) write_joint(w, j);
}

std::vector<JointSnapshot> read_joints(ByteReader& r) {
  std::vector<JointSnapshot> joints(r.count(kMinJointBytes));
  for (std::size_t i = 0; i < joints.size(); ++i) {
    joints[i] = read_joint(r);
    if (i > 0 && !(joints[i - 1].description.id < joints[i].description.id)) r.fail("joints not sorted by id");
  }
  return joints;
}

template <class T, class Less>
void check_sorted(ByteReader& r, const std::vector<T>& v, Less less, const char* what) {
  for (std::size_t i = 1; i < v.size(); ++i)
    if (!less(v[i - 1], v[i])) r.fail(std::string(what) + " not in ascending order");
}

// --- payloads ---------------------------------------------------------------

void write_payload(ByteWriter& w, const GhostBatch& b) {
  w.count(b.ghosts.size());
  for (const GhostRecord& g : b.ghosts) {
    write_record(w, g.record);
    w.count(g.sent_to.size());
    for (WorldId x : g.sent_to) w.put(x);
  }
  write_manifolds(w, b.kept_manifolds);
}

GhostBatch read_ghosts(ByteReader& r) {
  GhostBatch b;
  b.ghosts.resize(r.count(kMinRecordBytes));
  for (GhostRecord& g : b.ghosts) {
    g.record = read_record(r);
    g.sent_to.resize(r.count(sizeof(WorldId)));
    for (WorldId& x : g.sent_to) x = read_world(r);
    check_sorted(r, g.sent_to, std::less<WorldId>(), "ghost targets");
  }
  check_sorted(r, b.ghosts, [](const GhostRecord& a, const GhostRecord& c) {
    return a.record.body.description.id < c.record.body.description.id;
  }, "ghosts");
  b.kept_manifolds = read_manifolds(r);
  return b;
}

void write_payload(ByteWriter& w, const GlueBatch& b) {
  w.count(b.entries.size());
  for (const GlueEntry& e : b.entries) w.put(e.body), w.put(e.fragment_root);
}

GlueBatch read_glue(ByteReader& r) {
  GlueBatch b;
  b.entries.resize(r.count(2 * sizeof(BodyId)));
  for (GlueEntry& e : b.entries) {
    e.body = read_id(r);
    e.fragment_root = read_id(r);
  }
  return b;
}

void write_fragments(ByteWriter& w, const std::vector<Fragment>& fragments) {
  w.count(fragments.size());
  for (const Fragment& f : fragments) {
    w.put(f.world), w.put(f.root), w.put(f.first_body), w.put(f.weight);
    w.count(f.links_out.size());
    for (const LinkOut& l : f.links_out) w.put(l.owner), w.put(l.body);
    w.count(f.links_in.size());
    for (const LinkIn& l : f.links_in) w.put(l.world), w.put(l.fragment_root), w.put(l.body);
    w.count(f.bodies.size());
    for (const BodyRecord& rec : f.bodies) write_record(w, rec);
    write_manifolds(w, f.manifolds);
    w.count(f.joints.size());
    for (const Joint& j : f.joints) write_joint(w, JointSnapshot{j, false});
  }
}

std::vector<Fragment> read_fragment_list(ByteReader& r) {
  std::vector<Fragment> fragments(r.count(4 + 4 + 4 + 4 + 5 * 4));
  for (Fragment& f : fragments) {
    f.world = read_world(r);
    f.root = read_id(r);
    f.first_body = r.get<BodyId>();
    if (f.first_body != kNoBody && f.first_body > kMaxBodyId) r.fail("bad first body id");
    f.weight = r.get<std::uint32_t>();
    f.links_out.resize(r.count(8));
    for (LinkOut& l : f.links_out) l.owner = read_world(r), l.body = read_id(r);
    check_sorted(r, f.links_out, std::less<LinkOut>(), "fragment links out");
    f.links_in.resize(r.count(12));
    for (LinkIn& l : f.links_in) l.world = read_world(r), l.fragment_root = read_id(r), l.body = read_id(r);
    check_sorted(r, f.links_in, std::less<LinkIn>(), "fragment links in");
    f.bodies.resize(r.count(kMinRecordBytes));
    for (BodyRecord& rec : f.bodies) rec = read_record(r);
    check_sorted(r, f.bodies, [](const BodyRecord& a, const BodyRecord& c) {
      return a.body.description.id < c.body.description.id;
    }, "fragment bodies");
    f.manifolds = read_manifolds(r);
    for (JointSnapshot& j : read_joints(r)) {
      if (j.broken) r.fail("a broken joint in a fragment");
      f.joints.push_back(std::move(j.description));
    }
    if (!f.bodies.empty() && f.bodies.front().body.description.id != f.first_body)
      r.fail("fragment's first body differs from its bodies");
    if ((!f.bodies.empty() || !f.manifolds.empty()) && f.weight != f.bodies.size() + f.manifolds.size())
      r.fail("fragment's weight differs from its bodies and manifolds");
  }
  return fragments;
}

void write_payload(ByteWriter& w, const FragmentBatch& b) { write_fragments(w, b.fragments); }
FragmentBatch read_fragments(ByteReader& r) { return FragmentBatch{read_fragment_list(r)}; }

void write_payload(ByteWriter& w, const GatherBatch& b) {
  w.put(b.island);
  write_fragments(w, b.fragments);
}

GatherBatch read_gather(ByteReader& r) {
  GatherBatch b;
  b.island = read_id(r);
  b.fragments = read_fragment_list(r);
  return b;
}

void write_payload(ByteWriter& w, const MigrantBatch& b) {
  w.count(b.migrants.size());
  for (const Migrant& m : b.migrants) {
    write_body(w, m.body);
    write_manifolds(w, m.kept_manifolds);
  }
  write_joints(w, b.joints);
}

MigrantBatch read_migrants(ByteReader& r) {
  MigrantBatch b;
  b.migrants.resize(r.count(kMinBodyBytes));
  for (Migrant& m : b.migrants) {
    m.body = read_body(r);
    if (m.body.description.is_static) r.fail("a static body migrates");
    m.kept_manifolds = read_manifolds(r);
  }
  check_sorted(r, b.migrants, [](const Migrant& a, const Migrant& c) {
    return a.body.description.id < c.body.description.id;
  }, "migrants");
  b.joints = read_joints(r);
  return b;
}

void write_payload(ByteWriter& w, const ResultBatch& b) {
  w.count(b.results.size());
  for (const std::shared_ptr<const IslandResult>& p : b.results) {
    const IslandResult& r = *p;
    w.put(r.island);
    w.count(r.bodies.size());
    for (const BodyResult& x : r.bodies) {
      w.put(x.id);
      w.put(x.linear_velocity), w.put(x.angular_velocity), w.put(x.basis), w.put(x.origin);
      w.put(x.activation_state), w.put(x.deactivation_time);
    }
    write_manifolds(w, r.manifolds);
    w.count(r.broken_joints.size());
    for (JointId j : r.broken_joints) w.put(j);
  }
}

ResultBatch read_results(ByteReader& r) {
  constexpr std::size_t kBodyResultBytes = 4 + 18 * sizeof(btScalar) + 4 + sizeof(btScalar);
  ResultBatch b;
  const std::size_t count = r.count(4 + 4 + 4 + 4);
  b.results.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    IslandResult res;
    res.island = read_id(r);
    res.bodies.resize(r.count(kBodyResultBytes));
    for (BodyResult& x : res.bodies) {
      x.id = read_id(r);
      r.get(x.linear_velocity), r.get(x.angular_velocity), r.get(x.basis), r.get(x.origin);
      x.activation_state = r.get<std::int32_t>();
      if (x.activation_state < 1 || x.activation_state > 5) r.fail("bad activation state");
      x.deactivation_time = r.get<btScalar>();
    }
    check_sorted(r, res.bodies, [](const BodyResult& a, const BodyResult& c) { return a.id < c.id; },
                 "island result bodies");
    if (res.bodies.empty() || res.bodies.front().id != res.island) r.fail("island result without its first body");
    res.manifolds = read_manifolds(r);
    res.broken_joints.resize(r.count(sizeof(JointId)));
    for (JointId& j : res.broken_joints) j = r.get<JointId>();
    check_sorted(r, res.broken_joints, std::less<JointId>(), "island result broken joints");
    b.results.push_back(std::make_shared<const IslandResult>(std::move(res)));
  }
  return b;
}

void write_payload(ByteWriter& w, const Control& c) {
  w.put(static_cast<std::uint8_t>(c.type));
  w.put(c.seq);
  w.put(c.rolled_to);
  w.put(c.pinned);
}

Control read_control(ByteReader& r) {
  Control c;
  const auto type = r.get<std::uint8_t>();
  if (type < 1 || type > 2) r.fail("unknown control type " + std::to_string(type));
  c.type = static_cast<Control::Type>(type);
  c.seq = r.get<std::uint64_t>();
  c.rolled_to = r.get<std::int64_t>();
  c.pinned = r.get<std::int64_t>();
  if (c.rolled_to < -1 || c.pinned < -1) r.fail("control message with a step below -1");
  return c;
}

}  // namespace

const char* message_kind_name(MessageKind kind) {
  switch (kind) {
    case MessageKind::Ghosts: return "Ghosts";
    case MessageKind::Glue: return "Glue";
    case MessageKind::Fragments: return "Fragments";
    case MessageKind::Migrants: return "Migrants";
    case MessageKind::Results: return "Results";
    case MessageKind::Gather: return "Gather";
    case MessageKind::Control: return "Control";
  }
  return "Unknown";
}

std::string describe(const Message& m) {
  std::string kind = message_kind_name(m.kind());
  if (const Control* c = std::get_if<Control>(&m.payload)) {
    kind = c->type == Control::Type::Notice ? "Notice" : "Wake";
    if (c->type != Control::Type::Wake) kind += "#" + std::to_string(c->seq) + "[" + std::to_string(c->rolled_to) + "]";
  }
  return kind + "(" + std::to_string(m.step) + ") " + std::to_string(m.from) + "->" + std::to_string(m.to) +
         (m.epoch ? " epoch " + std::to_string(m.epoch) : "") +
         (m.rewinds ? " rewind " + std::to_string(m.rewinds) : "");
}

std::vector<std::uint8_t> encode_message(const Message& m) {
  ByteWriter w;
  write_header(w, kMagic, kVersion);
  w.put(static_cast<std::uint8_t>(m.kind()));
  w.put(m.from), w.put(m.to), w.put(m.step), w.put(m.epoch), w.put(m.rewinds);
  std::visit([&w](const auto& payload) { write_payload(w, payload); }, m.payload);
  return std::move(w.bytes);
}

std::uint64_t message_digest(const Message& m) {
  thread_local ByteWriter w;
  w.bytes.clear();
  write_header(w, kMagic, kVersion);
  w.put(static_cast<std::uint8_t>(m.kind()));
  w.put(m.from), w.put(m.to), w.put(m.step);
  std::visit([](const auto& payload) { write_payload(w, payload); }, m.payload);
  return fnv1a(w.bytes.data(), w.bytes.size());
}

Message decode_message(const std::vector<std::uint8_t>& bytes) {
  ByteReader r(bytes, "decode_message", raise_message_error);
  read_header(r, kMagic, kVersion, "message");
  const auto kind = r.get<std::uint8_t>();
  Message m;
  m.from = read_world(r);
  m.to = read_world(r);
  m.step = r.get<std::int64_t>();
  if (m.step < 0) r.fail("negative step");
  m.epoch = r.get<std::uint32_t>();
  m.rewinds = r.get<std::uint32_t>();
  switch (kind) {
    case static_cast<std::uint8_t>(MessageKind::Ghosts): m.payload = read_ghosts(r); break;
    case static_cast<std::uint8_t>(MessageKind::Glue): m.payload = read_glue(r); break;
    case static_cast<std::uint8_t>(MessageKind::Fragments): m.payload = read_fragments(r); break;
    case static_cast<std::uint8_t>(MessageKind::Migrants): m.payload = read_migrants(r); break;
    case static_cast<std::uint8_t>(MessageKind::Results): m.payload = read_results(r); break;
    case static_cast<std::uint8_t>(MessageKind::Gather): m.payload = read_gather(r); break;
    case static_cast<std::uint8_t>(MessageKind::Control): m.payload = read_control(r); break;
    default: r.fail("unknown message kind " + std::to_string(kind));
  }
  if (!r.done()) r.fail("trailing bytes");
  return m;
}

}  // namespace soda

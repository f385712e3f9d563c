// SceneQuery: ray casts, sweeps and overlaps at a committed step, in a
// collision world of the query's own.
//
// Why the answers are the same for every K: the frame of a step is the same
// bits for every K (SceneReader); each body is placed from its frame pose
// alone (position, and the basis of the frame's quaternion) and its shape
// from its description; each body's ray or sweep test is Bullet's
// single-object test, a function of that shape and pose and of the query;
// every hit is collected (no early cut that would depend on the broadphase's
// order) and the hits are sorted by (fraction, id). The broadphase only
// culls: which bodies it visits first never changes what is reported.
#include "soda/runtime/scene_query.h"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>

#include <btBulletCollisionCommon.h>

#include "embedding/simulation_core.h"
#include "soda/worlds/bullet_bodies.h"

namespace soda {

struct SceneQuery::World {
  // Queries walk the broadphase tree and never ask for pairs: moving a body
  // only updates its leaf (deferred collide: no pair search per moved body,
  // which cost the query thread a third of its time on falling-cubes
  // 16000), and no pair is ever stored.
  World() : broadphase(&pairs), dispatcher(&config), world(&dispatcher, &broadphase, &config) {
    broadphase.m_deferedcollide = true;
  }
  ~World() {
    for (auto& [id, object] : objects) world.removeCollisionObject(&object.body);
  }

  struct Object {
    std::shared_ptr<btCollisionShape> shape;
    btCollisionObject body;
    bool is_static = false;
    bool fixed = false;  // static and not kinematic: it never moves
    bool sensor = false;
    std::uint32_t mask = kAllCollisionGroups;  // a sensor's: the groups it reports
  };

  btNullPairCache pairs;
  btDbvtBroadphase broadphase;
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher;
  btCollisionWorld world;
  std::map<BodyId, Object> objects;  // node-stable: Bullet holds pointers to the objects
  std::int64_t step = -1;            // the frame the world holds

  Object& add(const Body& description) {
    Object& o = objects[description.id];
    o.shape = make_collision_shape(description.shape);
    o.body.setCollisionShape(o.shape.get());
    o.body.setUserIndex(static_cast<int>(description.id));
    o.body.setWorldTransform(to_bt_transform(description.position, description.orientation));
    o.is_static = description.is_static;
    o.fixed = description.is_static && !description.kinematic;
    o.body.setCollisionFlags(o.is_static ? btCollisionObject::CF_STATIC_OBJECT : 0);
    o.sensor = description.sensor;
    o.mask = description.collision_mask;
    if (o.sensor) mark_sensor(o.body);
    // The proxy carries the body's collision group (QueryFilter::mask reads
    // it); queries never ask for pairs, so its mask is unused.
    world.addCollisionObject(&o.body, static_cast<int>(description.collision_group), btBroadphaseProxy::AllFilter);
    return o;
  }
};

namespace {

btVector3 bt(const Vec3& v) { return btVector3(btScalar(v.x()), btScalar(v.y()), btScalar(v.z())); }
Vec3 vec(const btVector3& v) { return Vec3(double(v.x()), double(v.y()), double(v.z())); }

void check_finite(const Vec3& v, const char* what) {
  if (!v.allFinite()) throw std::invalid_argument(std::string("SceneQuery: ") + what + " must be finite");
}

BodyId id_of(const btCollisionObject* o) { return static_cast<BodyId>(o->getUserIndex()); }

// The filter as Bullet's callbacks ask it: statics, dynamics, the body's
// collision group against the query's mask, ignored ids.
bool wanted(const QueryFilter& f, const btCollisionObject* o) {
  if (o->isStaticObject() ? !f.statics : !f.dynamics) return false;
  if (!o->hasContactResponse() && !f.sensors) return false;  // a sensor (mark_sensor)
  if ((static_cast<std::uint32_t>(o->getBroadphaseHandle()->m_collisionFilterGroup) & f.mask) == 0) return false;
  return std::find(f.ignore.begin(), f.ignore.end(), id_of(o)) == f.ignore.end();
}

bool by_fraction_then_id(const QueryHit& a, const QueryHit& b) {
  return a.fraction != b.fraction ? a.fraction < b.fraction : a.id < b.id;
}

// Every hit, never narrowing the ray (m_closestHitFraction stays 1): the
// set reported cannot depend on the order the broadphase visits bodies in.
struct AllRayHits final : btCollisionWorld::RayResultCallback {
  AllRayHits(const btVector3& from, const btVector3& to, const QueryFilter& filter)
      : from(from), to(to), filter(filter) {}
  bool needsCollision(btBroadphaseProxy* proxy) const override {
    return wanted(filter, static_cast<const btCollisionObject*>(proxy->m_clientObject));
  }
  btScalar addSingleResult(btCollisionWorld::LocalRayResult& r, bool normal_in_world) override {
    const btCollisionObject* o = r.m_collisionObject;
    const btVector3 n = normal_in_world ? r.m_hitNormalLocal : o->getWorldTransform().getBasis() * r.m_hitNormalLocal;
    btVector3 p;
    p.setInterpolate3(from, to, r.m_hitFraction);
    hits.push_back(QueryHit{id_of(o), double(r.m_hitFraction), vec(p), vec(n)});
    return m_closestHitFraction;
  }
  btVector3 from, to;
  const QueryFilter& filter;
  std::vector<QueryHit> hits;
};

struct AllSweepHits final : btCollisionWorld::ConvexResultCallback {
  explicit AllSweepHits(const QueryFilter& filter) : filter(filter) {}
  bool needsCollision(btBroadphaseProxy* proxy) const override {
    return wanted(filter, static_cast<const btCollisionObject*>(proxy->m_clientObject));
  }
  btScalar addSingleResult(btCollisionWorld::LocalConvexResult& r, bool normal_in_world) override {
    const btCollisionObject* o = r.m_hitCollisionObject;
    const btVector3 n = normal_in_world ? r.m_hitNormalLocal : o->getWorldTransform().getBasis() * r.m_hitNormalLocal;
    hits.push_back(QueryHit{id_of(o), double(r.m_hitFraction), vec(r.m_hitPointLocal), vec(n)});
    return m_closestHitFraction;
  }
  const QueryFilter& filter;
  std::vector<QueryHit> hits;
};

struct Touching final : btCollisionWorld::ContactResultCallback {
  Touching(const btCollisionObject* probe, const QueryFilter& filter) : probe(probe), filter(filter) {}
  bool needsCollision(btBroadphaseProxy* proxy) const override {
    const auto* o = static_cast<const btCollisionObject*>(proxy->m_clientObject);
    return o != probe && wanted(filter, o);
  }
  btScalar addSingleResult(btManifoldPoint& cp, const btCollisionObjectWrapper* a, int, int,
                           const btCollisionObjectWrapper* b, int, int) override {
    if (cp.getDistance() > 0) return 0;
    const btCollisionObject* o = a->getCollisionObject() == probe ? b->getCollisionObject() : a->getCollisionObject();
    ids.push_back(id_of(o));
    return 0;
  }
  const btCollisionObject* probe;
  const QueryFilter& filter;
  std::vector<BodyId> ids;
};

struct InBox final : btBroadphaseAabbCallback {
  InBox(const btVector3& lo, const btVector3& hi, const QueryFilter& filter) : lo(lo), hi(hi), filter(filter) {}
  bool process(const btBroadphaseProxy* proxy) override {
    const auto* o = static_cast<const btCollisionObject*>(proxy->m_clientObject);
    if (!wanted(filter, o)) return true;
    btVector3 a, b;
    o->getCollisionShape()->getAabb(o->getWorldTransform(), a, b);  // the shape's own box, not the broadphase's
    if (TestAabbAgainstAabb2(a, b, lo, hi)) ids.push_back(id_of(o));
    return true;
  }
  btVector3 lo, hi;
  const QueryFilter& filter;
  std::vector<BodyId> ids;
};

void place(btCollisionObject& body, const ScenePose& p) {
  const btQuaternion q(p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3]);
  body.setWorldTransform(btTransform(q, btVector3(p.position[0], p.position[1], p.position[2])));
}

void sort_unique(std::vector<BodyId>& ids) {
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
}

}  // namespace

SceneQuery::SceneQuery(std::shared_ptr<SimulationCore> core, SceneReader reader)
    : core_(std::move(core)), reader_(std::move(reader)), world_(std::make_unique<World>()) {
  for (const Body& b : core_->census.statics()) world_->add(b);
}

SceneQuery::SceneQuery(SceneQuery&&) noexcept = default;
SceneQuery& SceneQuery::operator=(SceneQuery&&) noexcept = default;
SceneQuery::~SceneQuery() = default;

std::int64_t SceneQuery::last_step() const { return world_ ? world_->step : -1; }

// The frame of τ's step placed in the world: bodies that left it removed,
// new ones added from their descriptions, every pose set from the frame.
SceneQuery::World* SceneQuery::at(double time, bool wait) {
  if (!world_) throw std::logic_error("SceneQuery: used after being moved from");
  const std::int64_t step = core_->step_at(time);
  if (step == world_->step) return world_.get();
  const std::optional<SceneFrame> frame = wait ? reader_.read_at(time) : reader_.try_read_at(time);
  if (!frame) return nullptr;
  World& w = *world_;
  std::size_t i = 0;
  for (auto it = w.objects.begin(); it != w.objects.end();) {
    if (it->second.is_static) {
      ++it;
      continue;
    }
    while (i < frame->poses.size() && frame->poses[i].id < it->first) ++i;
    if (i < frame->poses.size() && frame->poses[i].id == it->first) {
      ++it;
    } else {
      w.world.removeCollisionObject(&it->second.body);
      it = w.objects.erase(it);
    }
  }
  for (const ScenePose& p : frame->poses) {
    auto it = w.objects.find(p.id);
    World::Object* o = it != w.objects.end() ? &it->second : nullptr;
    if (!o) {
      const Body* d = core_->census.description(p.id);
      if (!d) throw std::logic_error("SceneQuery: body " + std::to_string(p.id) + " of step " +
                                     std::to_string(frame->step) + " has no description");
      o = &w.add(*d);
    }
    place(o->body, p);
  }
  // Kinematic bodies are statics of the query world that move.
  for (const ScenePose& p : frame->kinematic)
    if (auto it = w.objects.find(p.id); it != w.objects.end()) place(it->second.body, p);
  w.world.updateAabbs();
  w.step = frame->step;
  return &w;
}

std::optional<QueryResult<QueryHit>> SceneQuery::ray_cast_all(double time, const Vec3& from, const Vec3& to,
                                                              const QueryFilter& filter) {
  check_finite(from, "the ray's start");
  check_finite(to, "the ray's end");
  World* w = at(time);
  if (!w) return std::nullopt;
  AllRayHits hits(bt(from), bt(to), filter);
  w->world.rayTest(hits.from, hits.to, hits);
  std::sort(hits.hits.begin(), hits.hits.end(), by_fraction_then_id);
  return QueryResult<QueryHit>{w->step, std::move(hits.hits)};
}

std::optional<QueryResult<QueryHit>> SceneQuery::ray_cast(double time, const Vec3& from, const Vec3& to,
                                                          const QueryFilter& filter) {
  std::optional<QueryResult<QueryHit>> all = ray_cast_all(time, from, to, filter);
  if (all && all->items.size() > 1) all->items.resize(1);
  return all;
}

std::optional<QueryResult<QueryHit>> SceneQuery::sweep(double time, const Shape& shape, const Vec3& from,
                                                       const Vec3& to, const Quat& orientation,
                                                       const QueryFilter& filter) {
  check_finite(from, "the sweep's start");
  check_finite(to, "the sweep's end");
  const std::shared_ptr<btCollisionShape> cast = make_collision_shape(shape);
  if (!cast->isConvex()) throw std::invalid_argument("SceneQuery::sweep: the shape must be convex");
  World* w = at(time);
  if (!w) return std::nullopt;
  AllSweepHits hits(filter);
  w->world.convexSweepTest(static_cast<const btConvexShape*>(cast.get()), to_bt_transform(from, orientation),
                           to_bt_transform(to, orientation), hits);
  std::sort(hits.hits.begin(), hits.hits.end(), by_fraction_then_id);
  return QueryResult<QueryHit>{w->step, std::move(hits.hits)};
}

std::optional<QueryResult<BodyId>> SceneQuery::overlap(double time, const Shape& shape, const Vec3& position,
                                                       const Quat& orientation, const QueryFilter& filter) {
  check_finite(position, "the shape's position");
  const std::shared_ptr<btCollisionShape> probe_shape = make_collision_shape(shape);
  World* w = at(time);
  if (!w) return std::nullopt;
  btCollisionObject probe;
  probe.setCollisionFlags(0);
  probe.setCollisionShape(probe_shape.get());
  probe.setWorldTransform(to_bt_transform(position, orientation));
  Touching touching(&probe, filter);
  w->world.contactTest(&probe, touching);
  sort_unique(touching.ids);
  return QueryResult<BodyId>{w->step, std::move(touching.ids)};
}

std::optional<QueryResult<BodyId>> SceneQuery::overlap_aabb(double time, const Vec3& lo, const Vec3& hi,
                                                            const QueryFilter& filter) {
  check_finite(lo, "the box's lower corner");
  check_finite(hi, "the box's upper corner");
  World* w = at(time);
  if (!w) return std::nullopt;
  InBox in_box(bt(lo), bt(hi), filter);
  w->broadphase.aabbTest(in_box.lo, in_box.hi, in_box);
  sort_unique(in_box.ids);
  return QueryResult<BodyId>{w->step, std::move(in_box.ids)};
}

// Each sensor's contact test against the bodies it may report: the same
// Touching test as overlap(), with the sensor itself as the probe (Bullet's
// contactTest skips the probe), so a pair's answer is a function of the two
// shapes and poses alone.
std::optional<std::vector<std::pair<BodyId, BodyId>>> SceneQuery::sensor_overlaps(std::int64_t step, bool wait) {
  World* w = at(core_->time_of(step), wait);
  if (!w) return std::nullopt;
  std::vector<std::pair<BodyId, BodyId>> out;
  for (auto& [id, o] : w->objects) {
    if (!o.sensor) continue;
    QueryFilter filter;
    filter.mask = o.mask;
    Touching touching(&o.body, filter);
    w->world.contactTest(&o.body, touching);
    sort_unique(touching.ids);
    // Two bodies that never move: their overlap never changes.
    if (o.fixed)
      std::erase_if(touching.ids, [&](BodyId b) { return w->objects.at(b).fixed; });
    for (BodyId b : touching.ids) out.emplace_back(id, b);
  }
  return out;  // objects go by id: ascending
}

}  // namespace soda

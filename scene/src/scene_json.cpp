#include "soda/scene/scene_json.h"

#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "soda/scene/validate.h"

namespace soda {
namespace {

using nlohmann::json;

constexpr const char* kFormat = "soda-scene";
constexpr int kVersion = 1;

// Where in the file we are, for messages: "file.json: body #3 (id 17)".
struct Context {
  std::string where;

  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw SceneError(where + ": field '" + field + "': " + what);
  }

  void only_known(const json& obj, std::initializer_list<const char*> known) const {
    const std::set<std::string> names(known.begin(), known.end());
    for (auto it = obj.begin(); it != obj.end(); ++it)
      if (!names.count(it.key())) fail(it.key(), "unknown field");
  }

  const json* find(const json& obj, const char* field, bool required) const {
    auto it = obj.find(field);
    if (it == obj.end()) {
      if (required) fail(field, "missing");
      return nullptr;
    }
    return &*it;
  }

  double number(const json& obj, const char* field, bool required, double fallback) const {
    const json* v = find(obj, field, required);
    if (!v) return fallback;
    if (!v->is_number()) fail(field, std::string("must be a number, got ") + v->type_name());
    return v->get<double>();
  }

  std::int64_t integer(const json& obj, const char* field, bool required, std::int64_t fallback) const {
    const json* v = find(obj, field, required);
    if (!v) return fallback;
    if (!v->is_number_integer()) fail(field, std::string("must be an integer, got ") + v->type_name());
    if (v->is_number_unsigned() && v->get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX))
      fail(field, "integer out of range");
    return v->get<std::int64_t>();
  }

  std::string string(const json& obj, const char* field, bool required, std::string fallback) const {
    const json* v = find(obj, field, required);
    if (!v) return fallback;
    if (!v->is_string()) fail(field, std::string("must be a string, got ") + v->type_name());
    return v->get<std::string>();
  }

  Eigen::VectorXd numbers(const json& v, const std::string& field, int count) const {
    if (!v.is_array() || static_cast<int>(v.size()) != count)
      fail(field, "must be an array of " + std::to_string(count) + " numbers");
    Eigen::VectorXd out(count);
    for (int i = 0; i < count; ++i) {
      if (!v[static_cast<std::size_t>(i)].is_number())
        fail(field, "must be an array of " + std::to_string(count) + " numbers");
      out[i] = v[static_cast<std::size_t>(i)].get<double>();
    }
    return out;
  }

  Vec3 vec3(const json& obj, const char* field, bool required, const Vec3& fallback) const {
    const json* v = find(obj, field, required);
    if (!v) return fallback;
    return Vec3(numbers(*v, field, 3));
  }
};

ShapeKind parse_shape_kind(const Context& ctx, const std::string& name) {
  for (ShapeKind k : {ShapeKind::Box, ShapeKind::Sphere, ShapeKind::Capsule, ShapeKind::Cylinder,
                      ShapeKind::ConvexHull})
    if (name == shape_kind_name(k)) return k;
  ctx.fail("shape.type", "unknown shape '" + name +
                             "' (known: box, sphere, capsule, cylinder, convex_hull)");
}

Shape parse_shape(const Context& body_ctx, const json& j) {
  if (!j.is_object()) body_ctx.fail("shape", "must be an object");
  Context ctx{body_ctx.where};
  // Field names inside the shape are reported as shape.<name>.
  auto field = [](const char* f) { return std::string("shape.") + f; };
  auto it = j.find("type");
  if (it == j.end()) ctx.fail("shape.type", "missing");
  if (!it->is_string()) ctx.fail("shape.type", "must be a string");
  Shape s;
  s.kind = parse_shape_kind(ctx, it->get<std::string>());
  auto need = [&](const char* f) -> const json& {
    auto v = j.find(f);
    if (v == j.end()) ctx.fail(field(f), "missing");
    return *v;
  };
  auto scalar = [&](const char* f) {
    const json& v = need(f);
    if (!v.is_number()) ctx.fail(field(f), std::string("must be a number, got ") + v.type_name());
    return v.get<double>();
  };
  std::set<std::string> allowed{"type"};
  switch (s.kind) {
    case ShapeKind::Box:
    case ShapeKind::Cylinder:
      s.half_extents = Vec3(ctx.numbers(need("half_extents"), field("half_extents"), 3));
      allowed.insert("half_extents");
      break;
    case ShapeKind::Sphere:
      s.radius = scalar("radius");
      allowed.insert("radius");
      break;
    case ShapeKind::Capsule:
      s.radius = scalar("radius");
      s.height = scalar("height");
      allowed.insert({"radius", "height"});
      break;
    case ShapeKind::ConvexHull: {
      const json& pts = need("points");
      if (!pts.is_array()) ctx.fail(field("points"), "must be an array of [x, y, z] points");
      for (const json& p : pts) s.points.emplace_back(ctx.numbers(p, field("points"), 3));
      allowed.insert("points");
      break;
    }
  }
  for (auto f = j.begin(); f != j.end(); ++f)
    if (!allowed.count(f.key()))
      ctx.fail(field(f.key().c_str()), std::string("unknown field for a ") + shape_kind_name(s.kind));
  return s;
}

Body parse_body(const std::string& source, std::size_t index, const json& j) {
  Context ctx{source + ": body #" + std::to_string(index)};
  if (!j.is_object()) ctx.fail("(body)", "must be an object");
  const std::int64_t id = ctx.integer(j, "id", true, 0);
  if (id < 0 || id > static_cast<std::int64_t>(kMaxBodyId)) ctx.fail("id", "must be in [0, 2^31)");
  Body b;
  b.id = static_cast<BodyId>(id);
  ctx.where += " (id " + std::to_string(id) + ")";
  ctx.only_known(j, {"id", "type", "shape", "mass", "friction", "restitution", "position",
                     "orientation", "linear_velocity", "angular_velocity"});
  const std::string type = ctx.string(j, "type", true, "");
  if (type != "static" && type != "dynamic") ctx.fail("type", "must be \"static\" or \"dynamic\"");
  b.is_static = type == "static";
  b.shape = parse_shape(ctx, *ctx.find(j, "shape", true));
  b.mass = ctx.number(j, "mass", !b.is_static, 0.0);
  b.friction = ctx.number(j, "friction", false, b.friction);
  b.restitution = ctx.number(j, "restitution", false, b.restitution);
  b.position = ctx.vec3(j, "position", true, Vec3::Zero());
  if (const json* q = ctx.find(j, "orientation", false)) {
    const Eigen::VectorXd v = ctx.numbers(*q, "orientation", 4);
    b.orientation = Quat(v[3], v[0], v[1], v[2]);  // file order x, y, z, w
  }
  b.linear_velocity = ctx.vec3(j, "linear_velocity", false, Vec3::Zero());
  b.angular_velocity = ctx.vec3(j, "angular_velocity", false, Vec3::Zero());
  if (b.is_static && (!b.linear_velocity.isZero(0.0) || !b.angular_velocity.isZero(0.0)))
    ctx.fail("linear_velocity", "a static body cannot move");
  return b;
}

// Walks the document with a SAX handler that keeps the path to the current
// value, to say where a parse error (malformed text, number overflow) is:
// "body #3 (id 17): field 'position'" rather than a byte offset alone.
class PathTracker : public nlohmann::json_sax<json> {
 public:
  std::string location;  // filled at the error

  bool null() override { return value(); }
  bool boolean(bool) override { return value(); }
  bool number_integer(number_integer_t v) override { return record_id(static_cast<double>(v)); }
  bool number_unsigned(number_unsigned_t v) override { return record_id(static_cast<double>(v)); }
  bool number_float(number_float_t, const string_t&) override { return value(); }
  bool string(string_t&) override { return value(); }
  bool binary(binary_t&) override { return value(); }
  bool start_object(std::size_t) override { return open(false); }
  bool end_object() override { return close(); }
  bool start_array(std::size_t) override { return open(true); }
  bool end_array() override { return close(); }
  bool key(string_t& k) override {
    frames_.back().key = k;
    return true;
  }
  bool parse_error(std::size_t byte, const std::string&, const nlohmann::detail::exception&) override {
    std::string where;
    std::string field;
    for (std::size_t i = 0; i < frames_.size(); ++i) {
      const Frame& f = frames_[i];
      if (i == 1 && frames_[0].key == "bodies" && f.is_array) {
        where = "body #" + std::to_string(f.index);
        if (i + 1 < frames_.size() && frames_[i + 1].id >= 0)
          where.append(" (id ").append(std::to_string(static_cast<long long>(frames_[i + 1].id))).append(")");
        continue;
      }
      if (f.is_array) {
        if (!field.empty()) field.append("[").append(std::to_string(f.index)).append("]");
      } else if (!f.key.empty()) {
        if (!(i == 0 && f.key == "bodies")) field.append(field.empty() ? "" : ".").append(f.key);
      }
    }
    location = where;
    if (!field.empty()) location += (location.empty() ? "" : ": ") + std::string("field '") + field + "'";
    location += (location.empty() ? "" : ", ") + std::string("at byte ") + std::to_string(byte);
    return false;
  }

 private:
  struct Frame {
    bool is_array = false;
    std::size_t index = 0;  // next element index in an array
    std::string key;        // current key in an object
    double id = -1;         // "id" seen in this object
  };
  std::vector<Frame> frames_;

  bool value() {
    if (!frames_.empty() && frames_.back().is_array) ++frames_.back().index;
    return true;
  }
  bool record_id(double v) {
    if (!frames_.empty() && !frames_.back().is_array && frames_.back().key == "id") frames_.back().id = v;
    return value();
  }
  bool open(bool is_array) {
    frames_.push_back(Frame{is_array, 0, {}, -1});
    return true;
  }
  bool close() {
    frames_.pop_back();
    return value();
  }
};

json vec_json(const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }

}  // namespace

Scene parse_scene_json(const std::string& text, const std::string& source) {
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::exception& e) {
    PathTracker tracker;
    json::sax_parse(text, &tracker);
    throw SceneError(source + ": " + tracker.location + ": not valid JSON (" + e.what() +
                     "); numbers must be finite: JSON has no NaN or Infinity");
  }
  Context ctx{source};
  if (!doc.is_object()) ctx.fail("(top level)", "must be an object");
  ctx.only_known(doc, {"format", "version", "name", "seed", "settings", "bodies"});
  if (ctx.string(doc, "format", true, "") != kFormat)
    ctx.fail("format", std::string("must be \"") + kFormat + "\"");
  if (ctx.integer(doc, "version", true, 0) != kVersion)
    ctx.fail("version", "unsupported version (this build reads version " + std::to_string(kVersion) + ")");
  Scene scene;
  scene.name = ctx.string(doc, "name", false, "scene");
  scene.seed = static_cast<std::uint64_t>(ctx.integer(doc, "seed", false, 0));
  if (const json* st = ctx.find(doc, "settings", false)) {
    Context sc{source + ": settings"};
    if (!st->is_object()) ctx.fail("settings", "must be an object");
    sc.only_known(*st, {"dt", "substeps", "iterations", "gravity", "steps"});
    SceneSettings& s = scene.settings;
    s.dt = sc.number(*st, "dt", false, s.dt);
    s.substeps = static_cast<int>(sc.integer(*st, "substeps", false, s.substeps));
    s.iterations = static_cast<int>(sc.integer(*st, "iterations", false, s.iterations));
    s.gravity = sc.vec3(*st, "gravity", false, s.gravity);
    s.steps = static_cast<int>(sc.integer(*st, "steps", false, s.steps));
  }
  const json* bodies = ctx.find(doc, "bodies", true);
  if (!bodies->is_array()) ctx.fail("bodies", "must be an array");
  scene.bodies.reserve(bodies->size());
  for (std::size_t i = 0; i < bodies->size(); ++i) scene.bodies.push_back(parse_body(source, i, (*bodies)[i]));
  validate_scene(scene, source);
  return scene;
}

Scene load_scene_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(path + ": cannot open scene file for reading");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw SceneError(path + ": read error");
  return parse_scene_json(text.str(), path);
}

std::string scene_to_json(const Scene& scene) {
  json doc;
  doc["format"] = kFormat;
  doc["version"] = kVersion;
  doc["name"] = scene.name;
  doc["seed"] = scene.seed;
  const SceneSettings& s = scene.settings;
  doc["settings"] = {{"dt", s.dt},
                     {"substeps", s.substeps},
                     {"iterations", s.iterations},
                     {"gravity", vec_json(s.gravity)},
                     {"steps", s.steps}};
  json bodies = json::array();
  for (const Body& b : scene.bodies) {
    json shape = {{"type", shape_kind_name(b.shape.kind)}};
    switch (b.shape.kind) {
      case ShapeKind::Box:
      case ShapeKind::Cylinder: shape["half_extents"] = vec_json(b.shape.half_extents); break;
      case ShapeKind::Sphere: shape["radius"] = b.shape.radius; break;
      case ShapeKind::Capsule:
        shape["radius"] = b.shape.radius;
        shape["height"] = b.shape.height;
        break;
      case ShapeKind::ConvexHull: {
        json pts = json::array();
        for (const Vec3& p : b.shape.points) pts.push_back(vec_json(p));
        shape["points"] = pts;
        break;
      }
    }
    json jb = {{"id", b.id},
               {"type", b.is_static ? "static" : "dynamic"},
               {"shape", shape},
               {"friction", b.friction},
               {"restitution", b.restitution},
               {"position", vec_json(b.position)},
               {"orientation",
                json::array({b.orientation.x(), b.orientation.y(), b.orientation.z(), b.orientation.w()})}};
    if (!b.is_static) {
      jb["mass"] = b.mass;
      jb["linear_velocity"] = vec_json(b.linear_velocity);
      jb["angular_velocity"] = vec_json(b.angular_velocity);
    }
    bodies.push_back(std::move(jb));
  }
  doc["bodies"] = std::move(bodies);
  return doc.dump(1) + "\n";
}

void write_scene_file(const Scene& scene, const std::string& path) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw SceneError(path + ": cannot open for writing");
  out << scene_to_json(scene);
  out.close();
  if (!out) throw SceneError(path + ": write failed");
}

}  // namespace soda

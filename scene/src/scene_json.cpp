#include "soda/scene/scene_json.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <new>
#include <vector>

#include <nlohmann/json.hpp>

#include "json_context.h"
#include "scene_sax.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

using detail::vec_json;
using nlohmann::json;

constexpr const char* kFormat = "soda-scene";
constexpr int kVersion = 1;

// The scene from what the SAX reader kept: the top-level fields, checked
// here, and the bodies, checked one by one as they were read.
Scene finish_scene(detail::SceneSax& sax, const std::string& source) {
  using detail::Context;
  const json& doc = sax.top;
  Context ctx{source};
  ctx.only_known(doc, {"format", "version", "name", "seed", "settings", "bodies", "joints"});
  if (ctx.string(doc, "format", true, "") != kFormat)
    ctx.fail("format", std::string("must be \"") + kFormat + "\"");
  if (ctx.integer(doc, "version", true, 0) != kVersion)
    ctx.fail("version", "unsupported version (this build reads version " + std::to_string(kVersion) + ")");
  if (!sax.saw_bodies) {
    ctx.find(doc, "bodies", true);
    ctx.fail("bodies", "must be an array");
  }
  Scene scene;
  scene.name = ctx.string(doc, "name", false, "scene");
  const std::int64_t seed = ctx.integer(doc, "seed", false, 0);
  if (seed < 0) ctx.fail("seed", "must be >= 0");
  scene.seed = static_cast<std::uint64_t>(seed);
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
  scene.bodies = std::move(sax.bodies);
  if (const json* joints = ctx.find(doc, "joints", false)) {
    if (!joints->is_array()) ctx.fail("joints", "must be an array");
    scene.joints.reserve(joints->size());
    for (std::size_t i = 0; i < joints->size(); ++i)
      scene.joints.push_back(detail::parse_joint(source + ": joint #" + std::to_string(i), (*joints)[i]));
  }
  validate_scene(scene, source);
  return scene;
}

// Reads a scene from `input` (text or stream) without a document of it.
template <class Input>
Scene read_scene(Input&& input, const std::string& source) {
  detail::SceneSax sax(source);
  if (!json::sax_parse(std::forward<Input>(input), &sax)) throw SceneError(source + ": " + sax.error());
  return finish_scene(sax, source);
}

}  // namespace

Scene parse_scene_json(const std::string& text, const std::string& source) { return read_scene(text, source); }

Scene load_scene_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw SceneError(path + ": is a directory, not a scene file");
  std::ifstream in;
  std::vector<char> buffer(std::size_t{1} << 20);  // read in 1 MiB blocks
  in.rdbuf()->pubsetbuf(buffer.data(), static_cast<std::streamsize>(buffer.size()));
  in.open(path, std::ios::binary);
  if (!in) throw SceneError(path + ": cannot open scene file for reading");
  std::size_t read = 0;
  try {
    Scene scene = read_scene(in, path);
    if (in.bad()) throw SceneError(path + ": read error");
    return scene;
  } catch (const std::bad_alloc&) {
    read = static_cast<std::size_t>(std::max<std::streamoff>(0, in.tellg()));
  }
  // Everything the parse held is freed by now: this message can be built.
  throw SceneError(path + ": out of memory while reading the scene file (at byte " + std::to_string(read) +
                   "): the scene does not fit in the memory this process may use");
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
  for (const Body& b : scene.bodies) bodies.push_back(detail::body_json(b));
  doc["bodies"] = std::move(bodies);
  if (!scene.joints.empty()) {  // a scene without joints is written as before
    json joints = json::array();
    for (const Joint& j : scene.joints) joints.push_back(detail::joint_json(j));
    doc["joints"] = std::move(joints);
  }
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

// Internal: reading fields of a parsed JSON value with messages that name
// the file, the entry (body, input) and the field. Shared by the scene and
// the input file readers.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "soda/scene/scene.h"
#include "soda/scene/validate.h"

namespace soda::detail {

using nlohmann::json;

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

/// The lexer's token at a parse error looks like the start of NaN,
/// Infinity, nan or inf (with a sign): the text holds a non-finite number,
/// which JSON cannot express. ("n" alone is the start of null.)
bool looks_non_finite(const std::string& token);

/// A vector as scene and input files write it: [x, y, z].
inline json vec_json(const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }

/// A body as the scene file writes it (numbers read back bit-identical).
json body_json(const Body& b);

/// A body in the scene file's format (docs/scene-format.md). `where` names
/// it in messages, e.g. "cubes.json: body #3"; " (id N)" is appended.
/// A triangle mesh's file is read from `base_dir` (the scene file's folder).
Body parse_body(std::string where, const json& j, const std::string& base_dir = "");

/// A 32-bit collision group or mask in field `field` of `j` (an integer in
/// [0, 2^32)), or `fallback` when absent (body_json.cpp).
std::uint32_t filter_bits(const Context& ctx, const json& j, const char* field, std::uint32_t fallback);

/// A joint as the scene file writes it (joint_json.cpp).
json joint_json(const Joint& joint);

/// A joint in the scene file's format (docs/scene-format.md, "Joints").
/// `where` names it in messages, e.g. "chain.json: joint #3"; " (id N)" is
/// appended. Which bodies it names is checked by validate_scene.
Joint parse_joint(std::string where, const json& j);

}  // namespace soda::detail

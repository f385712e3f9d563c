#include "scene_sax.h"

#include <filesystem>

#include <cctype>

namespace soda::detail {

bool looks_non_finite(const std::string& last_read) {
  // The lexer's "last read" text may hold what came before the token
  // ("0, N"): the token is its trailing run of letters and signs.
  std::size_t i = last_read.size();
  while (i > 0 && (std::isalpha(static_cast<unsigned char>(last_read[i - 1])) || last_read[i - 1] == '-' ||
                   last_read[i - 1] == '+'))
    --i;
  while (i < last_read.size() && (last_read[i] == '-' || last_read[i] == '+')) ++i;
  if (i >= last_read.size()) return false;
  const char c = last_read[i];
  if (c == 'N' || c == 'I' || c == 'i') return true;
  return c == 'n' && i + 1 < last_read.size() && (last_read[i + 1] == 'a' || last_read[i + 1] == 'A');
}

bool SceneSax::null() { return scalar(json(nullptr)); }
bool SceneSax::boolean(bool v) { return scalar(json(v)); }
bool SceneSax::number_float(number_float_t v, const string_t&) { return scalar(json(v)); }
bool SceneSax::string(string_t& v) { return scalar(json(std::move(v))); }
bool SceneSax::binary(binary_t&) { return scalar(json()); }  // never in JSON text

bool SceneSax::number_integer(number_integer_t v) {
  if (!frames_.empty() && !frames_.back().is_array && frames_.back().key == "id") frames_.back().id = static_cast<double>(v);
  return scalar(json(v));
}

bool SceneSax::number_unsigned(number_unsigned_t v) {
  if (!frames_.empty() && !frames_.back().is_array && frames_.back().key == "id") frames_.back().id = static_cast<double>(v);
  return scalar(json(v));
}

bool SceneSax::key(string_t& k) {
  if (frames_.size() == 1 && (k == "bodies" ? saw_bodies || top.contains(k) : top.contains(k)))
    throw SceneError(source_ + ": field '" + k + "': given twice");
  frames_.back().key = k;
  key_ = k;
  return true;
}

json* SceneSax::insert(json v) {
  json& parent = *dom_.back();
  if (parent.is_array()) {
    parent.push_back(std::move(v));
    return &parent.back();
  }
  json& slot = parent[key_];
  slot = std::move(v);
  return &slot;
}

void SceneSax::counted() {
  if (!frames_.empty() && frames_.back().is_array) ++frames_.back().index;
}

bool SceneSax::open(bool is_array) {
  const std::size_t depth = frames_.size();
  if (depth == 0) {
    if (is_array) throw SceneError(source_ + ": field '(top level)': must be an object");
    top = json::object();
    dom_.assign({&top});
  } else if (depth == 1 && is_array && frames_[0].key == "bodies") {
    streaming_ = saw_bodies = true;  // its elements are built one by one in body_
  } else if (in_bodies()) {
    body_ = is_array ? json::array() : json::object();
    dom_.assign({&body_});
  } else {
    dom_.push_back(insert(is_array ? json::array() : json::object()));
  }
  frames_.push_back(Frame{is_array, 0, {}, -1});
  return true;
}

bool SceneSax::close() {
  const bool closes_bodies = streaming_ && frames_.size() == 2;
  frames_.pop_back();
  if (closes_bodies) {
    streaming_ = false;
    dom_.assign({&top});
  } else {
    dom_.pop_back();
    if (in_bodies()) finish_body();
  }
  counted();
  return true;
}

bool SceneSax::scalar(json v) {
  if (frames_.empty()) throw SceneError(source_ + ": field '(top level)': must be an object");
  if (in_bodies()) {
    body_ = std::move(v);
    finish_body();  // refused: a body must be an object
  } else {
    insert(std::move(v));
  }
  counted();
  return true;
}

void SceneSax::finish_body() {
  bodies.push_back(parse_body(source_ + ": body #" + std::to_string(frames_.back().index), body_,
                              std::filesystem::path(source_).parent_path().string()));
  body_ = json();
}

std::string SceneSax::location(std::size_t byte) const {
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
  std::string out = where;
  if (!field.empty()) out += (out.empty() ? "" : ": ") + std::string("field '") + field + "'";
  out += (out.empty() ? "" : ", ") + std::string("at byte ") + std::to_string(byte);
  return out;
}

bool SceneSax::parse_error(std::size_t byte, const std::string& last_token, const nlohmann::detail::exception& e) {
  error_ = location(byte) + ": not valid JSON (" + e.what() + ")";
  if (looks_non_finite(last_token)) error_ += "; numbers must be finite: JSON has no NaN or Infinity";
  else if (e.id == 406) error_ += "; numbers must be finite doubles";  // number overflow (1e400)
  return false;
}

}  // namespace soda::detail

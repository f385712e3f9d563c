// Internal: reads a scene file as a stream of SAX events, never as a whole
// document. Each body is built as a small JSON value, turned into a Body and
// dropped, so reading N bodies holds the Scene and one body's JSON, never
// the file's text nor its document (a 10-million-body file needed both, and
// died of a second bad_alloc). The top-level fields but `bodies` are small
// and kept as a document. On malformed text it knows the path to the bad
// value ("body #3 (id 17): field 'position[1]'").
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "json_context.h"

namespace soda::detail {

class SceneSax : public nlohmann::json_sax<json> {
 public:
  explicit SceneSax(std::string source) : source_(std::move(source)) {}

  /// The top-level object without `bodies`.
  json top;
  /// The bodies of the `bodies` array, in file order.
  std::vector<Body> bodies;
  /// `bodies` was an array (streamed into `bodies`).
  bool saw_bodies = false;

  /// After a parse error: the message to throw ("not valid JSON (...)",
  /// with the path to the bad value).
  const std::string& error() const { return error_; }

  bool null() override;
  bool boolean(bool v) override;
  bool number_integer(number_integer_t v) override;
  bool number_unsigned(number_unsigned_t v) override;
  bool number_float(number_float_t v, const string_t& text) override;
  bool string(string_t& v) override;
  bool binary(binary_t& v) override;
  bool start_object(std::size_t) override { return open(false); }
  bool end_object() override { return close(); }
  bool start_array(std::size_t) override { return open(true); }
  bool end_array() override { return close(); }
  bool key(string_t& k) override;
  bool parse_error(std::size_t byte, const std::string& last_token, const nlohmann::detail::exception& e) override;

 private:
  struct Frame {
    bool is_array = false;
    std::size_t index = 0;  // next element index in an array
    std::string key;        // current key in an object
    double id = -1;         // "id" seen in this object
  };
  bool open(bool is_array);
  bool close();
  bool scalar(json v);
  json* insert(json v);
  void counted();                 // a value of the current frame is complete
  bool in_bodies() const { return streaming_ && frames_.size() == 2; }  // at an element of `bodies`
  void finish_body();
  std::string location(std::size_t byte) const;

  std::string source_;
  std::vector<Frame> frames_;     // path to the current value
  std::vector<json*> dom_;        // open containers of the value being built
  std::string key_;               // key of the next value in an object
  bool streaming_ = false;        // inside the `bodies` array
  json body_;                     // the body being built
  std::string error_;
};

}  // namespace soda::detail

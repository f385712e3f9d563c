// Shared by the scene tests: what parsing a scene file refuses.
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "soda/scene/scene_json.h"
#include "soda/scene/validate.h"

namespace soda::test {

/// Parses `text` as the scene file `source` and returns the error message;
/// fails the test if it is accepted.
inline std::string scene_error_of(const std::string& text, const std::string& source = "bad.json") {
  try {
    parse_scene_json(text, source);
  } catch (const SceneError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no error for:\n" << text;
  return "";
}

}  // namespace soda::test

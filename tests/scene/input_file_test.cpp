// The input file format (docs/inputs.md): a good file reads back as the
// inputs it holds, sorted by step; every error names the file, the entry
// and the field.
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "soda/scene/input_file.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

std::string file(const std::string& entries) {
  return R"({"format": "soda-inputs", "version": 1, "inputs": [)" + entries + "]}";
}

std::string error_of(const std::string& text) {
  try {
    parse_inputs_json(text, "in.json");
  } catch (const SceneError& e) {
    std::printf("refused: %s\n", e.what());
    return e.what();
  }
  ADD_FAILURE() << "no error for:\n" << text;
  return "";
}

TEST(InputFile, GoodFileReadsInStepOrder) {
  const auto in = parse_inputs_json(file(R"(
    {"type": "remove_body", "step": 120, "id": 3},
    {"type": "add_body", "step": 40, "body": {"id": 500, "type": "dynamic", "mass": 1,
      "shape": {"type": "box", "half_extents": [0.5, 0.5, 0.5]}, "position": [0, 12, 0]}},
    {"type": "set_velocity", "step": 60, "id": 3, "linear_velocity": [3, 4, 0], "angular_velocity": [0, 1, 0]},
    {"type": "apply_impulse", "step": 60, "id": 500, "impulse": [-2, 0, 1]})"),
                                    "in.json");
  ASSERT_EQ(in.size(), 4u);
  EXPECT_EQ(in[0].kind, UserInput::Kind::AddBody);
  EXPECT_EQ(in[0].body.id, 500u);
  EXPECT_EQ(in[0].sequence, 1u);  // the file's order: entry #1
  EXPECT_EQ(in[1].kind, UserInput::Kind::SetVelocity);  // step 60, entry #2 before #3
  EXPECT_EQ(in[1].linear, Vec3(3, 4, 0));
  EXPECT_EQ(in[1].angular, Vec3(0, 1, 0));
  EXPECT_EQ(in[2].kind, UserInput::Kind::ApplyImpulse);
  EXPECT_EQ(in[2].linear, Vec3(-2, 0, 1));
  EXPECT_EQ(in[3].kind, UserInput::Kind::RemoveBody);
  EXPECT_EQ(in[3].sequence, 0u);
  // Round trip, bit for bit.
  const auto back = parse_inputs_json(inputs_to_json(in), "back.json");
  ASSERT_EQ(back.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    EXPECT_EQ(back[i].kind, in[i].kind);
    EXPECT_EQ(back[i].step, in[i].step);
    EXPECT_EQ(back[i].linear, in[i].linear);
    EXPECT_EQ(back[i].body.position, in[i].body.position);
  }
}

TEST(InputFile, ErrorsNameTheEntryAndTheField) {
  EXPECT_NE(error_of(file(R"({"type": "teleport", "step": 1, "id": 3})")).find("in.json: input #0: field 'type'"),
            std::string::npos);
  EXPECT_NE(error_of(file(R"({"type": "remove_body", "step": -1, "id": 3})")).find("field 'step'"), std::string::npos);
  EXPECT_NE(error_of(file(R"({"type": "remove_body", "step": 1, "id": 3},
                              {"type": "apply_impulse", "step": 5, "id": 3})"))
                .find("in.json: input #1 (apply_impulse at step 5): field 'impulse': missing"),
            std::string::npos);
  EXPECT_NE(error_of(file(R"({"type": "set_velocity", "step": 5, "id": 3, "linear_velocity": [1, 2]})"))
                .find("field 'linear_velocity'"),
            std::string::npos);
  EXPECT_NE(error_of(file(R"({"type": "remove_body", "step": 5, "id": 3, "speed": 1})")).find("field 'speed': unknown"),
            std::string::npos);
  EXPECT_NE(error_of(file(R"({"type": "add_body", "step": 5, "body": {"id": 9, "type": "dynamic", "mass": -1,
      "shape": {"type": "sphere", "radius": 1}, "position": [0, 2, 0]}})"))
                .find("in.json: input #0 (add_body at step 5): body (id 9): field 'mass'"),
            std::string::npos);
  EXPECT_NE(error_of(file(R"({"type": "add_body", "step": 5, "body": {"id": 9, "type": "static",
      "shape": {"type": "sphere", "radius": 1}, "position": [0, 2, 0]}})"))
                .find("field 'body.type'"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"format": "soda-inputs", "version": 2, "inputs": []})").find("field 'version'"),
            std::string::npos);
  const std::string nan = error_of(file(R"({"type": "apply_impulse", "step": 5, "id": 3, "impulse": [NaN, 0, 0]})"));
  EXPECT_NE(nan.find("no NaN or Infinity"), std::string::npos) << nan;
  const std::string empty = error_of("");
  EXPECT_EQ(empty.find("NaN"), std::string::npos) << empty;
}

}  // namespace
}  // namespace soda

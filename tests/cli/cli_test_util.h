// The `soda` binary run as a user runs it (tests/cli): its exit code and
// output, a scratch directory per test, bad-scene helpers.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace soda_cli_test {

struct Outcome {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

/// `shell_prefix`: /bin/sh commands run before the CLI (e.g. "ulimit -v N;").
inline Outcome run_cli(const std::string& args, const std::string& shell_prefix = "") {
  const std::string cmd = shell_prefix + "exec " + std::string(SODA_CLI_PATH) + " " + args + " 2>&1";
  Outcome o;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return o;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) o.output.append(buf, n);
  const int status = pclose(p);
  o.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return o;
}

class CliTest : public ::testing::Test {
 protected:
  std::filesystem::path dir_;
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("soda_cli_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) {
    const auto path = (dir_ / name).string();
    std::ofstream(path) << text;
    return path;
  }

  // A scene file with one bad dynamic body.
  std::string bad_scene(const std::string& body) {
    return write("bad.json", R"({"format": "soda-scene", "version": 1, "bodies": [
      {"id": 0, "type": "static", "shape": {"type": "box", "half_extents": [10, 0.5, 10]}, "position": [0, -0.5, 0]},
      )" + body + "]}");
  }

  void expect_bad_input(const std::string& path, const std::string& needle) {
    const Outcome o = run_cli("run --scene " + path + " --steps 1");
    EXPECT_EQ(o.exit_code, 2) << o.output;
    EXPECT_NE(o.output.find(path), std::string::npos) << o.output;
    EXPECT_NE(o.output.find(needle), std::string::npos) << o.output;
  }
};

/// The state hash a `soda run` printed ("" if none).
inline std::string hash_of(const Outcome& o) {
  const auto at = o.output.find("state_hash ");
  return at == std::string::npos ? "" : o.output.substr(at + 11, 16);
}

}  // namespace soda_cli_test

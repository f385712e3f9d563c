// replay/ — replay files (docs/replay-format.md). This header: the errors.
#pragma once

#include <stdexcept>
#include <string>

namespace soda::replay {

/// A replay file could not be written or read. what() is
/// "<path>: <what is wrong>"; path() names the file.
class ReplayError : public std::runtime_error {
 public:
  ReplayError(const std::string& path, const std::string& what)
      : std::runtime_error(path + ": " + what), path_(path) {}
  const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
};

/// A file that is not a readable replay of this version: missing,
/// unreadable, wrong magic or version, truncated, corrupted (checksum),
/// inconsistent contents. Bad input (the CLI exits with code 2).
class ReplayFormatError : public ReplayError {
 public:
  using ReplayError::ReplayError;
};

}  // namespace soda::replay

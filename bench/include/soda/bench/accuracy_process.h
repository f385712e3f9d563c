// bench/ — running the other precision. Float and double are separate
// binaries (soda, soda-double), never one: a float run that needs a double
// reference (or the other way round) spawns the sibling binary, which writes
// a trace file (accuracy.h) that this process reads. docs/accuracy.md.
#pragma once

#include <string>
#include <vector>

namespace soda {

/// The binary of the other precision, next to this executable:
/// soda-double when this is the float build, soda when it is the double one.
/// Empty when /proc/self/exe cannot be read.
std::string default_sibling_binary();

/// Name of the precision this build is not ("double" in the float build).
const char* other_precision_name();

/// Runs `argv` (argv[0] a path) as a child process, stdin from /dev/null,
/// its stdout and stderr both to this process's stderr, and waits. Throws std::runtime_error with the command
/// line when it cannot start, or does not exit with status 0.
void run_process(const std::vector<std::string>& argv);

/// True when `path` names an executable file.
bool is_executable(const std::string& path);

}  // namespace soda

// CSV output shared by the benchmarks (accuracy sweep, stress suite, CLI).
#pragma once

#include <string>

namespace soda {

/// One CSV field (RFC 4180): returned as is unless it holds a comma, a quote
/// or a newline, then quoted with inner quotes doubled.
std::string csv_field(const std::string& s);

}  // namespace soda

// scene/ — how a 64-bit hash is written for people and JSON: the one format
// every library prints (state hashes in `soda run`, replay files, the
// viewer's frames). Here, in the precision-independent base library, so the
// float and double worlds and the precision-free viewer share it.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

namespace soda {

/// `hash` as 16 lower-case hex digits, zero-padded ("00000000000000ff").
/// Pure; safe from any thread.
inline std::string hash_hex(std::uint64_t hash) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(hash));
  return std::string(text);
}

}  // namespace soda

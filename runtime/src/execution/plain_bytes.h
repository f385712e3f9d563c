// Internal: trivially copyable values as plain bytes, for readouts gathered
// over a ProcessGroup's ranks (partitioned_ranks.cpp, run.cpp). Every rank
// runs the same build, so no byte order or layout is converted; messages
// between worlds go through the message codec instead (message_codec.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace soda {

/// Appends the bytes of `v` to `out`.
template <class T>
void put_plain(std::vector<std::uint8_t>& out, const T& v) {
  static_assert(std::is_trivially_copyable_v<T>);
  const std::size_t at = out.size();
  out.resize(at + sizeof(T));
  std::memcpy(out.data() + at, &v, sizeof(T));
}

/// The T at `in[at]`, advancing `at` past it. Throws std::logic_error
/// naming `what` if fewer than sizeof(T) bytes are left.
template <class T>
T take_plain(const std::vector<std::uint8_t>& in, std::size_t& at, const char* what) {
  static_assert(std::is_trivially_copyable_v<T>);
  if (at + sizeof(T) > in.size()) throw std::logic_error(std::string(what) + " is truncated");
  T v;
  std::memcpy(&v, in.data() + at, sizeof(T));
  at += sizeof(T);
  return v;
}

}  // namespace soda

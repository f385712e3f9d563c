// scene/ — FNV-1a, the one byte hash behind the project's hashes: the state
// hash (worlds/body_state), the contact-state hash (snapshots), the contact
// event stream hash, the checksum of checkpoint files and the message hash
// of the codec tests. Written once so that they cannot drift apart.
//
//   std::uint64_t h = soda::kFnv1aOffset;
//   soda::fnv1a_mix(h, &value, sizeof value);   // any number of times
//   std::uint64_t whole = soda::fnv1a(bytes.data(), bytes.size());
#pragma once

#include <cstddef>
#include <cstdint>

namespace soda {

inline constexpr std::uint64_t kFnv1aOffset = 1469598103934665603ull;
inline constexpr std::uint64_t kFnv1aPrime = 1099511628211ull;

/// Mixes `size` bytes at `data` into `h`, one byte at a time.
inline void fnv1a_mix(std::uint64_t& h, const void* data, std::size_t size) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < size; ++i) {
    h ^= p[i];
    h *= kFnv1aPrime;
  }
}

/// FNV-1a of `size` bytes.
inline std::uint64_t fnv1a(const void* data, std::size_t size) {
  std::uint64_t h = kFnv1aOffset;
  fnv1a_mix(h, data, size);
  return h;
}

}  // namespace soda

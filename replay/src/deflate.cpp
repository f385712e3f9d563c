// zlib (Debian's zlib1g-dev): chunk compression and checksums.
#include <string>

#include <zlib.h>

#include "byte_io.h"
#include "replay_codec.h"

namespace soda::replay {

std::vector<std::uint8_t> deflate_bytes(std::span<const std::uint8_t> raw, int level) {
  uLongf size = compressBound(static_cast<uLong>(raw.size()));
  std::vector<std::uint8_t> out(size);
  const int rc = compress2(out.data(), &size, raw.data(), static_cast<uLong>(raw.size()), level);
  if (rc != Z_OK) throw std::runtime_error("zlib compress2 failed (code " + std::to_string(rc) + ")");
  out.resize(size);
  return out;
}

std::vector<std::uint8_t> inflate_bytes(std::span<const std::uint8_t> stored, std::size_t raw_size) {
  std::vector<std::uint8_t> out(raw_size);
  uLongf size = static_cast<uLongf>(raw_size);
  const int rc = uncompress(out.data(), &size, stored.data(), static_cast<uLong>(stored.size()));
  if (rc != Z_OK)
    throw FormatError(std::string("does not decompress (zlib: ") + (rc == Z_DATA_ERROR ? "data error" : rc == Z_BUF_ERROR ? "larger than its stated size" : "error " + std::to_string(rc)) + ")");
  if (size != raw_size)
    throw FormatError("decompresses to " + std::to_string(size) + " bytes, stated " + std::to_string(raw_size));
  return out;
}

std::uint32_t crc32_of(std::span<const std::uint8_t> bytes) {
  return static_cast<std::uint32_t>(crc32(0L, bytes.data(), static_cast<uInt>(bytes.size())));
}

}  // namespace soda::replay

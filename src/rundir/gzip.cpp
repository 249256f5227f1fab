#include "rundir/gzip.h"

#include <zlib.h>

#include <cstdlib>
#include <stdexcept>

namespace granary::rundir {

std::string GzipMember(std::string_view text, int level) {
  z_stream z{};
  // windowBits 15 + 16: a gzip header and trailer instead of zlib's.
  if (deflateInit2(&z, level, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error("zlib: deflateInit2 failed");
  std::string out(deflateBound(&z, static_cast<uLong>(text.size())), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data()));
  z.avail_in = static_cast<uInt>(text.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  if (rc != Z_STREAM_END) throw std::runtime_error("zlib: deflate did not finish");
  return out;
}

void WriteBlock(std::FILE* out, bool gzip, const std::function<void(std::FILE*)>& write) {
  if (!gzip) {
    write(out);
    return;
  }
  char* buf = nullptr;
  std::size_t len = 0;
  std::FILE* mem = open_memstream(&buf, &len);
  if (!mem) throw std::runtime_error("open_memstream failed");
  write(mem);
  std::fclose(mem);
  const std::string gz = GzipMember(std::string_view(buf, len));
  std::free(buf);
  if (std::fwrite(gz.data(), 1, gz.size(), out) != gz.size())
    throw std::runtime_error("cannot write a compressed block");
}

std::int64_t BlockBytes(bool gzip, const std::function<void(std::FILE*)>& write) {
  char* buf = nullptr;
  std::size_t len = 0;
  std::FILE* mem = open_memstream(&buf, &len);
  if (!mem) throw std::runtime_error("open_memstream failed");
  write(mem);
  std::fclose(mem);
  const std::int64_t bytes =
      gzip ? static_cast<std::int64_t>(GzipMember(std::string_view(buf, len)).size()) : static_cast<std::int64_t>(len);
  std::free(buf);
  return bytes;
}

}  // namespace granary::rundir

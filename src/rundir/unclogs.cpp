// See unclogs.h.
#include "rundir/unclogs.h"

#include <cmath>
#include <cstdio>
#include <fstream>

#include "rundir/dump_text.h"
#include "rundir/layout.h"

namespace granary::rundir {
namespace {

constexpr char kHeader[] = "time,step,clog,attempt,method,bodies\n";

// The bodies as ids separated by spaces (one CSV field).
std::string Row(const UnclogEvent& e) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.10g,%lld,%d,%d,", e.time, static_cast<long long>(e.step), e.clog, e.attempt);
  std::string row = buf;
  row += e.method;
  row += ',';
  for (std::size_t k = 0; k < e.bodies.size(); ++k) {
    if (k) row += ' ';
    row += std::to_string(e.bodies[k]);
  }
  row += '\n';
  return row;
}

}  // namespace

UnclogWriter UnclogWriter::Create(const std::filesystem::path& file) {
  UnclogWriter w;
  w.file_ = OutputFile(file);
  std::fputs(kHeader, w.file_.Get());
  return w;
}

UnclogWriter UnclogWriter::ContinueAt(const std::filesystem::path& file, std::int64_t offset) {
  if (!std::filesystem::exists(file)) return Create(file);
  UnclogWriter w;
  w.file_ = OutputFile(file, offset);
  return w;
}

void UnclogWriter::Write(const UnclogEvent& e) {
  const std::string row = Row(e);
  std::fwrite(row.data(), 1, row.size(), file_.Get());
}

std::vector<UnclogEvent> ReadUnclogs(const std::filesystem::path& file) {
  using detail::Where;
  std::vector<UnclogEvent> out;
  if (!std::filesystem::exists(file)) return out;
  std::ifstream in(file);
  if (!in) throw ReadError(file.string() + ": cannot open");
  std::string line;
  std::int64_t line_no = 0;
  std::vector<std::string_view> f, ids;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line == "\r") continue;
    if (line_no == 1) {
      if (line + "\n" != kHeader)
        throw ReadError(Where(file, line_no) + ": header must be '" + std::string(kHeader, sizeof kHeader - 2) +
                        "' (got '" + line + "')");
      continue;
    }
    detail::Split(line, ',', f);
    if (f.size() != 6)
      throw ReadError(Where(file, line_no) + ": expected 6 fields, got " + std::to_string(f.size()) + " ('" + line +
                      "')");
    UnclogEvent e;
    std::int64_t iv = 0;
    if (!detail::ToDouble(f[0], e.time) || !std::isfinite(e.time))
      throw ReadError(Where(file, line_no) + ": time '" + std::string(f[0]) + "' is not a number");
    if (!detail::ToInt(f[1], e.step))
      throw ReadError(Where(file, line_no) + ": step '" + std::string(f[1]) + "' is not an integer");
    if (!detail::ToInt(f[2], iv) || iv < 1)
      throw ReadError(Where(file, line_no) + ": clog '" + std::string(f[2]) + "' is not a clog number (1, 2, ...)");
    e.clog = static_cast<int>(iv);
    if (!detail::ToInt(f[3], iv) || iv < 1)
      throw ReadError(Where(file, line_no) + ": attempt '" + std::string(f[3]) +
                      "' is not an attempt number (1, 2, ...)");
    e.attempt = static_cast<int>(iv);
    e.method = std::string(f[4]);
    if (e.method != "remove_arch" && e.method != "kick")
      throw ReadError(Where(file, line_no) + ": method '" + e.method + "' is not remove_arch or kick");
    detail::Split(f[5], ' ', ids);
    for (std::string_view id : ids) {
      if (id.empty()) continue;
      if (!detail::ToInt(id, iv) || iv < 0)
        throw ReadError(Where(file, line_no) + ": body '" + std::string(id) + "' is not a body id");
      e.bodies.push_back(iv);
    }
    out.push_back(std::move(e));
  }
  return out;
}

}  // namespace granary::rundir

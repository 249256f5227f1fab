// See events.h.
#include "rundir/events.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "rundir/layout.h"
#include "rundir/dump_text.h"

namespace granary::rundir {
namespace {

constexpr char kHeader[] = "time,body,shape,mass,outlet\n";

// One row; time to 10 significant digits (steps of dt), mass to full precision.
void AppendEvent(std::string& out, const ExitEvent& e) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g,%lld,", e.time, static_cast<long long>(e.body));
  out += buf;
  out += e.shape;
  std::snprintf(buf, sizeof buf, ",%.17g,%d\n", e.mass, e.outlet);
  out += buf;
}

}  // namespace

EventWriter EventWriter::Create(const std::filesystem::path& file) {
  EventWriter w;
  w.file_ = OutputFile(file);
  std::fputs(kHeader, w.file_.Get());
  return w;
}

EventWriter EventWriter::ContinueAt(const std::filesystem::path& file, std::int64_t offset) {
  EventWriter w;
  w.file_ = OutputFile(file, offset);
  return w;
}

void EventWriter::Write(const ExitEvent& e) {
  std::string row;
  AppendEvent(row, e);
  std::fwrite(row.data(), 1, row.size(), file_.Get());
}

void WriteEvents(const std::filesystem::path& file, const std::vector<ExitEvent>& events) {
  std::string text = kHeader;
  for (const ExitEvent& e : events) AppendEvent(text, e);
  WriteAtomically(file, text);
}

std::vector<ExitEvent> ReadEvents(const std::filesystem::path& file) {
  using detail::Where;
  std::ifstream in(file);
  if (!in) throw ReadError(file.string() + ": cannot open");
  std::string line;
  std::int64_t line_no = 0;
  std::vector<std::string_view> f;
  std::vector<std::string> names;
  while (names.empty() && std::getline(in, line)) {
    ++line_no;
    detail::Split(line, ',', f);
    if (f.size() == 1 && f[0].empty()) continue;
    for (auto n : f) names.emplace_back(n);
  }
  std::vector<ExitEvent> events;
  if (names.empty()) return events;  // empty file: no exits yet
  const int c_time = detail::Column(names, "time");
  const int c_body = detail::Column(names, "body");
  const int c_shape = detail::Column(names, "shape");
  const int c_mass = detail::Column(names, "mass");
  const int c_outlet = detail::Column(names, "outlet");
  if (c_time < 0) throw ReadError(Where(file, line_no) + ": header has no 'time' column (got '" + line + "')");
  const std::size_t need = static_cast<std::size_t>(std::max({c_time, c_body, c_shape, c_mass, c_outlet})) + 1;
  auto field = [&](int c) { return f[static_cast<std::size_t>(c)]; };
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line == "\r") continue;
    detail::Split(line, ',', f);
    if (f.size() < need)
      throw ReadError(Where(file, line_no) + ": expected " + std::to_string(names.size()) + " fields, got " +
                      std::to_string(f.size()) + " ('" + line + "')");
    ExitEvent e;
    std::int64_t iv = 0;
    if (!detail::ToDouble(field(c_time), e.time) || !std::isfinite(e.time))
      throw ReadError(Where(file, line_no) + ": time '" + std::string(field(c_time)) + "' is not a number");
    if (c_body >= 0) {
      if (!detail::ToInt(field(c_body), iv))
        throw ReadError(Where(file, line_no) + ": body '" + std::string(field(c_body)) + "' is not an integer");
      e.body = iv;
    }
    if (c_shape >= 0) e.shape = std::string(field(c_shape));
    e.mass = std::nan("");
    if (c_mass >= 0 && !detail::ToDouble(field(c_mass), e.mass))
      throw ReadError(Where(file, line_no) + ": mass '" + std::string(field(c_mass)) + "' is not a number");
    if (c_outlet >= 0) {
      if (!detail::ToInt(field(c_outlet), iv) || iv < 0)
        throw ReadError(Where(file, line_no) + ": outlet '" + std::string(field(c_outlet)) +
                        "' is not an outlet index");
      e.outlet = static_cast<int>(iv);
    }
    events.push_back(std::move(e));
  }
  std::stable_sort(events.begin(), events.end(),
                   [](const ExitEvent& a, const ExitEvent& b) { return a.time < b.time; });
  return events;
}

}  // namespace granary::rundir

// See contacts.h.
#include "rundir/contacts.h"

#include <algorithm>
#include <string_view>

#include "rundir/dump_text.h"
#include "rundir/gzip.h"
#include "rundir/layout.h"

namespace granary::rundir {

using detail::Column;
using detail::Split;
using detail::ToDouble;
using detail::ToInt;

ContactWriter ContactWriter::Create(const std::filesystem::path& file, bool gzip) {
  ContactWriter w;
  if (file.extension() == ".gsd") {
    w.gsd_ = gsd::GsdContactWriter::Create(file);
    return w;
  }
  w.file_ = OutputFile(file);
  w.gzip_ = gzip;
  return w;
}

ContactWriter ContactWriter::ContinueAt(const std::filesystem::path& file, std::int64_t offset, bool gzip) {
  ContactWriter w;
  if (file.extension() == ".gsd") {
    w.gsd_ = gsd::GsdContactWriter::ContinueAt(file, offset);
    return w;
  }
  w.file_ = OutputFile(file, offset);
  w.gzip_ = gzip;
  return w;
}

namespace {

// The block of one contact frame, as ContactWriter::Write writes it and ContactBytes counts it.
void WriteContactBlock(std::FILE* f, const ContactFrame& frame, std::string& t) {
  detail::WriteDumpHeader(f, frame.timestep, frame.time, "NUMBER OF ENTRIES", frame.contacts.size(), frame.box);
  std::fputs("ITEM: ENTRIES body_i body_j xi yi xj yj cx cy fx fy\n", f);
  // "%lld %lld %.10g %.10g %.10g %.10g %.10g %.10g %.10g %.10g\n" per contact
  std::size_t rows = 0;
  for (const ContactRow& c : frame.contacts) {
    detail::AppendInt(t, c.body_i);
    t += ' ';
    detail::AppendInt(t, c.body_j);
    for (const double v : {c.xi, c.yi, c.xj, c.yj, c.cx, c.cy, c.fx, c.fy}) t += ' ', detail::AppendG10(t, v);
    t += '\n';
    if (++rows % detail::kRowsPerWrite == 0) detail::Drain(t, f);
  }
  detail::Drain(t, f);
}

}  // namespace

void ContactWriter::Write(const ContactFrame& frame) {
  if (gsd_.IsOpen()) return gsd_.Write(frame);
  WriteBlock(file_.Get(), gzip_, [&](std::FILE* f) { WriteContactBlock(f, frame, text_); });
}

std::int64_t ContactBytes(const ContactFrame& frame, bool gzip) {
  std::string text;
  return BlockBytes(gzip, [&](std::FILE* f) { WriteContactBlock(f, frame, text); });
}

ContactReader::ContactReader(const std::filesystem::path& file) : file_(file) {
  if (gsd::IsGsdFile(file))
    gsd_ = std::make_unique<gsd::GsdContactReader>(file);
  else
    state_ = std::make_unique<detail::DumpState>(file);
}

ContactReader::~ContactReader() = default;
ContactReader::ContactReader(ContactReader&&) noexcept = default;
ContactReader& ContactReader::operator=(ContactReader&&) noexcept = default;

bool ContactReader::NextHeader(ContactFrame& frame) {
  if (gsd_) return gsd_->NextHeader(frame);
  detail::DumpState& st = *state_;
  frame.contacts.clear();
  if (st.rows_pending && !detail::SkipDumpRows(st)) return false;
  if (!detail::ReadDumpHeader(st.lines, "NUMBER OF ENTRIES", "ITEM: ENTRIES", st.header)) return false;
  st.rows_pending = true;
  frame.timestep = st.header.timestep;
  frame.time = st.header.time;
  std::copy(&st.header.box[0][0], &st.header.box[0][0] + 6, &frame.box[0][0]);
  return true;
}

bool ContactReader::SkipContacts() { return gsd_ ? gsd_->SkipContacts() : detail::SkipDumpRows(*state_); }

bool ContactReader::ReadContacts(ContactFrame& frame) {
  if (gsd_) return gsd_->ReadContacts(frame);
  detail::DumpState& st = *state_;
  detail::DumpLines& in = st.lines;
  const detail::DumpHeader& h = st.header;
  frame.contacts.clear();
  if (!st.rows_pending) return false;
  st.rows_pending = false;
  static const char* kColumns[] = {"body_i", "body_j", "xi", "yi", "xj", "yj", "cx", "cy", "fx", "fy"};
  int cols[10];
  std::size_t need = 0;
  for (int k = 0; k < 10; ++k) {
    cols[k] = Column(h.columns, kColumns[k]);
    if (cols[k] < 0) {
      std::string header = "ITEM: ENTRIES";
      for (const auto& n : h.columns) header += " " + n;
      in.Fail(std::string("entries header has no '") + kColumns[k] + "' column ('" + header + "')");
    }
    need = std::max(need, static_cast<std::size_t>(cols[k] + 1));
  }
  frame.contacts.reserve(static_cast<std::size_t>(h.count));
  // Which of the ten each of the first `need` columns is (-1: none), for rows read in place.
  std::vector<int> slot(need, -1);
  for (int k = 0; k < 10; ++k) slot[static_cast<std::size_t>(cols[k])] = k;
  // A well-formed row, parsed straight from the line; false sends it to the checks below.
  auto fast_row = [&](std::string_view row, ContactRow& c) {
    const char* p = row.data();
    const char* const end = p + row.size();
    double* const out[8] = {&c.xi, &c.yi, &c.xj, &c.yj, &c.cx, &c.cy, &c.fx, &c.fy};
    for (const int k : slot) {
      const bool ok = k < 0    ? !detail::NextField(p, end).empty()
                      : k == 0 ? detail::NextInt(p, end, c.body_i)
                      : k == 1 ? detail::NextInt(p, end, c.body_j)
                               : detail::NextDouble(p, end, *out[k - 2]);
      if (!ok) return false;
    }
    return true;
  };
  std::string_view line;
  std::vector<std::string_view> f;
  for (std::int64_t r = 0; r < h.count; ++r) {
    if (!in.Next(line)) {
      frame.contacts.clear();
      return false;
    }
    if (fast_row(line, frame.contacts.emplace_back())) continue;
    frame.contacts.pop_back();
    Split(line, ' ', f);
    if (f.size() < need && in.AtEnd()) {
      frame.contacts.clear();
      return false;
    }
    if (f.size() < need)
      in.Fail("contact row has " + std::to_string(f.size()) + " fields, expected " + std::to_string(h.columns.size()));
    ContactRow c;
    auto field = [&](int k) { return f[static_cast<std::size_t>(cols[k])]; };
    if (!ToInt(field(0), c.body_i) || !ToInt(field(1), c.body_j))
      in.Fail("body ids in '" + std::string(line) + "' are not integers");
    double* out[8] = {&c.xi, &c.yi, &c.xj, &c.yj, &c.cx, &c.cy, &c.fx, &c.fy};
    for (int k = 0; k < 8; ++k)
      if (!ToDouble(field(k + 2), *out[k]))
        in.Fail(std::string(kColumns[k + 2]) + " '" + std::string(field(k + 2)) + "' is not a number");
    frame.contacts.push_back(c);
  }
  return true;
}

}  // namespace granary::rundir

// See dump_text.h.
#include "rundir/dump_text.h"

#include <zlib.h>

#include <cctype>

#include "rundir/layout.h"

namespace granary::rundir::detail {

DumpLines::DumpLines(const std::filesystem::path& file) : file_(file), in_(file, std::ios::binary) {
  if (!in_) throw ReadError(file.string() + ": cannot open");
  char magic[2] = {0, 0};
  in_.read(magic, 2);
  const bool gzip = in_.gcount() == 2 && magic[0] == '\x1f' && magic[1] == '\x8b';
  in_.clear();
  in_.seekg(0);
  if (!gzip) return;
  in_.close();
  gz_ = gzopen(file.c_str(), "rb");
  if (!gz_) throw ReadError(file.string() + ": cannot open");
  gzbuffer(static_cast<gzFile>(gz_), 1 << 17);
}

DumpLines::~DumpLines() {
  if (gz_) gzclose(static_cast<gzFile>(gz_));
}

bool DumpLines::GzLine(std::string& line) {
  line.clear();
  if (gz_eof_) return false;
  char buf[4096];
  for (;;) {
    if (!gzgets(static_cast<gzFile>(gz_), buf, sizeof buf)) {
      if (line.empty()) return false;
      gz_eof_ = true;  // a last line without '\n', as std::getline reports it
      return true;
    }
    line += buf;
    if (line.back() == '\n') {
      line.pop_back();
      return true;
    }
  }
}

bool DumpLines::Next(std::string& line) {
  if (!(gz_ ? GzLine(line) : static_cast<bool>(std::getline(in_, line)))) return false;
  ++line_no_;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return true;
}

void DumpLines::Fail(const std::string& what) const { throw ReadError(Where(file_, line_no_) + ": " + what); }

bool ReadDumpHeader(DumpLines& in, const char* count_item, const char* columns_item, DumpHeader& h) {
  std::string line;
  // Blank lines between blocks are allowed.
  do {
    if (!in.Next(line)) return false;
  } while (line.find_first_not_of(" \t") == std::string::npos);
  h = DumpHeader();
  // LAMMPS writes ITEM: UNITS and ITEM: TIME before ITEM: TIMESTEP; run directories written
  // before Granary followed that order have TIME after it, which the item loop below reads.
  while (line == "ITEM: UNITS" || line == "ITEM: TIME") {
    const std::string item = line;
    if (!in.Next(line)) return false;
    if (item == "ITEM: TIME" && !ToDouble(std::string_view(line), h.time)) in.Fail("time '" + line + "' is not a number");
    if (!in.Next(line)) return false;
  }
  if (line.rfind("ITEM: TIMESTEP", 0) != 0) in.Fail("expected 'ITEM: TIMESTEP', got '" + line + "'");
  if (!in.Next(line)) return false;
  if (!ToInt(std::string_view(line), h.timestep)) in.Fail("timestep '" + line + "' is not an integer");
  const std::string count_line = std::string("ITEM: ") + count_item;
  const std::string_view columns_prefix(columns_item);
  std::vector<std::string_view> f;
  for (;;) {
    if (!in.Next(line)) return false;
    if (line.rfind("ITEM: ", 0) != 0) in.Fail("expected an 'ITEM:' line, got '" + line + "'");
    if (line.rfind(columns_prefix, 0) == 0) break;
    if (line.rfind("ITEM: TIMESTEP", 0) == 0) in.Fail("'ITEM: TIMESTEP' before the rows of the previous block");
    const std::string item = line;
    if (item.rfind("ITEM: BOX BOUNDS", 0) == 0) {
      for (int k = 0; k < 3; ++k) {
        if (!in.Next(line)) return false;
        Split(line, ' ', f);
        if (f.size() < 2 || !ToDouble(f[0], h.box[k][0]) || !ToDouble(f[1], h.box[k][1]))
          in.Fail("box bounds line '" + line + "' is not two numbers");
      }
      continue;
    }
    if (!in.Next(line)) return false;
    if (item == count_line) {
      if (!ToInt(std::string_view(line), h.count) || h.count < 0) {
        std::string what = count_item;  // "NUMBER OF ATOMS" -> "number of atoms"
        for (char& c : what) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        in.Fail(what + " '" + line + "' is not a count");
      }
    } else if (item == "ITEM: TIME") {
      if (!ToDouble(std::string_view(line), h.time)) in.Fail("time '" + line + "' is not a number");
    }
  }
  if (h.count < 0) in.Fail("frame has no '" + count_line + "'");
  Split(std::string_view(line).substr(columns_prefix.size()), ' ', f);
  for (auto name : f) h.columns.emplace_back(name);
  return true;
}

bool SkipDumpRows(DumpState& state) {
  state.rows_pending = false;
  std::string line;
  for (std::int64_t r = 0; r < state.header.count; ++r)
    if (!state.lines.Next(line)) return false;
  return true;
}

}  // namespace granary::rundir::detail

// See dump_text.h.
#include "rundir/dump_text.h"

#include <zlib.h>

#include <cctype>
#include <cstring>

#include "rundir/layout.h"

namespace granary::rundir::detail {

namespace {
constexpr std::size_t kBlock = std::size_t{1} << 20;  // bytes per read
}  // namespace

DumpLines::DumpLines(const std::filesystem::path& file) : file_(file) {
  plain_ = std::fopen(file.c_str(), "rb");
  if (!plain_) throw ReadError(file.string() + ": cannot open");
  unsigned char magic[2] = {0, 0};
  const bool gzip = std::fread(magic, 1, 2, plain_) == 2 && magic[0] == 0x1f && magic[1] == 0x8b;
  if (gzip) {
    std::fclose(plain_);
    plain_ = nullptr;
    gz_ = gzopen(file.c_str(), "rb");
    if (!gz_) throw ReadError(file.string() + ": cannot open");
    gzbuffer(static_cast<gzFile>(gz_), 1 << 17);
  } else {
    std::rewind(plain_);
    std::setvbuf(plain_, nullptr, _IONBF, 0);  // whole blocks go straight into buffer_
  }
  buffer_.resize(kBlock);
}

DumpLines::~DumpLines() {
  if (gz_) gzclose(static_cast<gzFile>(gz_));
  if (plain_) std::fclose(plain_);
}

bool DumpLines::Refill() {
  if (eof_) return false;
  if (begin_ > 0) {
    std::memmove(buffer_.data(), buffer_.data() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  if (buffer_.size() - end_ < kBlock / 2) buffer_.resize(buffer_.size() + kBlock);  // a line longer than a block
  const std::size_t room = buffer_.size() - end_;
  std::size_t got = 0;
  if (gz_) {
    const int n = gzread(static_cast<gzFile>(gz_), buffer_.data() + end_, static_cast<unsigned>(room));
    if (n < 0) Fail("cannot read (gzip: corrupt or cut short)");
    got = static_cast<std::size_t>(n);
  } else {
    got = std::fread(buffer_.data() + end_, 1, room, plain_);
    if (got == 0 && std::ferror(plain_)) Fail("cannot read");
  }
  end_ += got;
  if (got == 0) eof_ = true;
  return got > 0;
}

bool DumpLines::Next(std::string_view& line) {
  for (;;) {
    const char* const start = buffer_.data() + begin_;
    const void* const nl = std::memchr(start, '\n', end_ - begin_);
    if (nl) {
      const char* const stop = static_cast<const char*>(nl);
      line = std::string_view(start, static_cast<std::size_t>(stop - start));
      begin_ += line.size() + 1;
      break;
    }
    if (Refill()) continue;
    if (begin_ == end_) return false;
    // A last line without '\n', as std::getline reports it.
    line = std::string_view(buffer_.data() + begin_, end_ - begin_);
    begin_ = end_;
    unterminated_ = true;
    break;
  }
  ++line_no_;
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return true;
}

bool DumpLines::Next(std::string& line) {
  std::string_view view;
  if (!Next(view)) return false;
  line.assign(view);
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
    if (item == "ITEM: TIME" && !ToDouble(std::string_view(line), h.time))
      in.Fail("time '" + line + "' is not a number");
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
  std::string_view line;
  for (std::int64_t r = 0; r < state.header.count; ++r)
    if (!state.lines.Next(line)) return false;
  return true;
}

}  // namespace granary::rundir::detail

// See clogs.h.
#include "rundir/clogs.h"

#include <fstream>
#include <string>

#include "rundir/dump_text.h"
#include "rundir/layout.h"

namespace granary::rundir {

namespace fs = std::filesystem;

ClogWriter ClogWriter::Create(const fs::path& dir) {
  ClogWriter w;
  w.frames_ = FrameWriter::Create(dir / kClogFramesFile);
  w.contacts_ = ContactWriter::Create(dir / kClogContactsFile);
  return w;
}

ClogWriter ClogWriter::ContinueAfter(const fs::path& dir, std::int64_t timestep) {
  auto offset = [&](const fs::path& file) { return fs::exists(file) ? DumpOffsetAfter(file, timestep) : 0; };
  ClogWriter w;
  w.frames_ = FrameWriter::ContinueAt(dir / kClogFramesFile, offset(dir / kClogFramesFile));
  w.contacts_ = ContactWriter::ContinueAt(dir / kClogContactsFile, offset(dir / kClogContactsFile));
  return w;
}

void ClogWriter::Write(const ClogState& clog) {
  frames_.Write(clog.frame);
  contacts_.Write(clog.contacts);
  frames_.Offset();  // flushes
  contacts_.Offset();
}

void ClogWriter::Close() {
  frames_.Close();
  contacts_.Close();
}

std::int64_t DumpOffsetAfter(const fs::path& file, std::int64_t timestep) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw ReadError(file.string() + ": cannot open");
  std::string line;
  std::int64_t line_no = 0;
  // One whole line; false at the end of the file or for a last line without its newline.
  auto next = [&]() {
    if (!std::getline(in, line)) return false;
    ++line_no;
    if (in.eof()) return false;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  };
  auto fail = [&](const std::string& what) -> std::int64_t {
    throw ReadError(detail::Where(file, line_no) + ": " + what);
  };
  for (;;) {
    const std::int64_t block_start = static_cast<std::int64_t>(in.tellg());
    if (!next()) return block_start;
    std::int64_t step = -1, count = -1;
    bool rows = false;
    // Header up to the column line.
    for (;;) {
      if (line.rfind("ITEM: ", 0) != 0) return fail("expected an 'ITEM:' line, got '" + line + "'");
      if (line.rfind("ITEM: ATOMS", 0) == 0 || line.rfind("ITEM: ENTRIES", 0) == 0) {
        rows = true;
        break;
      }
      const std::string item = line;
      const int values = item.rfind("ITEM: BOX BOUNDS", 0) == 0 ? 3 : 1;
      for (int k = 0; k < values; ++k)
        if (!next()) return block_start;
      if (item == "ITEM: TIMESTEP" && !detail::ToInt(line, step))
        return fail("timestep '" + line + "' is not an integer");
      if ((item == "ITEM: NUMBER OF ATOMS" || item == "ITEM: NUMBER OF ENTRIES") && !detail::ToInt(line, count))
        return fail("count '" + line + "' is not an integer");
      if (!next()) return block_start;
    }
    if (!rows || step < 0 || count < 0) return fail("block without TIMESTEP or count");
    if (step > timestep) return block_start;
    for (std::int64_t r = 0; r < count; ++r)
      if (!next()) return block_start;
  }
}

ClogReader::ClogReader(const fs::path& dir) : dir_(dir) {
  const bool frames = fs::exists(dir / kClogFramesFile), contacts = fs::exists(dir / kClogContactsFile);
  if (frames != contacts)
    throw ReadError((dir / (frames ? kClogContactsFile : kClogFramesFile)).string() + ": missing beside its pair");
  present_ = frames;
  if (!present_) return;
  frames_ = std::make_unique<FrameReader>(dir / kClogFramesFile);
  contacts_ = std::make_unique<ContactReader>(dir / kClogContactsFile);
}

bool ClogReader::Next(ClogState& clog) {
  if (!present_) return false;
  const bool frame = frames_->Next(clog.frame);
  const bool contacts = contacts_->Next(clog.contacts);
  if (frame && contacts && clog.frame.timestep != clog.contacts.timestep)
    throw ReadError((dir_ / kClogContactsFile).string() + ": a block at timestep " +
                    std::to_string(clog.contacts.timestep) + " beside the configuration at timestep " +
                    std::to_string(clog.frame.timestep));
  if (frame && !contacts)
    throw ReadError((dir_ / kClogContactsFile).string() + ": no block for the clog at timestep " +
                    std::to_string(clog.frame.timestep));
  if (!frame && contacts)
    throw ReadError((dir_ / kClogFramesFile).string() + ": no configuration for the contacts at timestep " +
                    std::to_string(clog.contacts.timestep));
  return frame;
}

std::vector<ClogState> ReadClogs(const fs::path& dir) {
  ClogReader reader(dir);
  std::vector<ClogState> clogs;
  ClogState clog;
  while (reader.Next(clog)) clogs.push_back(clog);
  return clogs;
}

}  // namespace granary::rundir

// See gsd.h. Written from the file layer's documentation (gsd.readthedocs.io, "File layer",
// version 2.0); no code of the GSD library is used.
#include "rundir/gsd.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "rundir/contacts.h"
#include "rundir/frames.h"
#include "rundir/layout.h"
#include "rundir/version.h"

namespace granary::rundir::gsd {
namespace {

constexpr std::uint32_t kGsdVersion = 2u << 16;  // 0xaaaabbbb => aaaa.bbbb: 2.0
constexpr std::size_t kNameSlot = 64;            // the name list is allocated in slots of 64 bytes
constexpr std::uint64_t kFirstIndexEntries = 256;
constexpr std::uint64_t kFirstNameBytes = 16 * kNameSlot;

// The 256-byte header, in the spec's order (tightly packed by every compiler Granary supports).
struct Header {
  std::uint64_t magic = kMagic;
  std::uint64_t index_location = 0;
  std::uint64_t index_allocated_entries = 0;
  std::uint64_t namelist_location = 0;
  std::uint64_t namelist_allocated_entries = 0;  // in 64-byte slots
  std::uint32_t schema_version = 0;
  std::uint32_t gsd_version = kGsdVersion;
  char application[64] = {};
  char schema[64] = {};
  char reserved[80] = {};
};
static_assert(sizeof(Header) == 256);

std::uint32_t MakeVersion(int major, int minor) {
  return (static_cast<std::uint32_t>(major) << 16) | static_cast<std::uint32_t>(minor);
}

std::string ErrnoText() { return std::strerror(errno); }

void PreadAll(int fd, void* out, std::size_t bytes, std::int64_t at, const std::filesystem::path& path) {
  auto* p = static_cast<char*>(out);
  while (bytes > 0) {
    const ssize_t got = ::pread(fd, p, bytes, at);
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0)
      throw ReadError(path.string() + ": cannot read " + std::to_string(bytes) + " bytes at " + std::to_string(at) +
                      (got < 0 ? ": " + ErrnoText() : ": the file ends"));
    p += got;
    bytes -= static_cast<std::size_t>(got);
    at += got;
  }
}

// The three fields of the header Granary reads.
struct FileHead {
  Header header;
  std::vector<std::string> names;
  std::vector<IndexEntry> entries;  // up to the first unused (location 0) entry
};

FileHead ReadHead(int fd, const std::filesystem::path& path, std::int64_t size) {
  FileHead h;
  if (size < static_cast<std::int64_t>(sizeof(Header)))
    throw ReadError(path.string() + ": " + std::to_string(size) + " bytes, shorter than a GSD header (256)");
  PreadAll(fd, &h.header, sizeof(Header), 0, path);
  if (h.header.magic != kMagic) throw ReadError(path.string() + ": not a GSD file (no magic number)");
  const std::uint32_t major = h.header.gsd_version >> 16;
  if (major < 1 || major > 2)
    throw ReadError(path.string() + ": GSD file layer version " + std::to_string(major) + "." +
                    std::to_string(h.header.gsd_version & 0xffff) + " is newer than this build reads (1.x, 2.x)");
  const std::uint64_t name_bytes = h.header.namelist_allocated_entries * kNameSlot;
  const std::uint64_t index_bytes = h.header.index_allocated_entries * sizeof(IndexEntry);
  if (h.header.namelist_location + name_bytes > static_cast<std::uint64_t>(size) ||
      h.header.index_location + index_bytes > static_cast<std::uint64_t>(size))
    throw ReadError(path.string() + ": the header points past the end of the file (" + std::to_string(size) +
                    " bytes)");
  std::string names(name_bytes, '\0');
  PreadAll(fd, names.data(), names.size(), static_cast<std::int64_t>(h.header.namelist_location), path);
  // 1.x: one name per 64-byte slot; 2.x: names end at a 0 byte. Both end at an empty name.
  for (std::size_t at = 0; at < names.size() && names[at] != '\0';) {
    const std::size_t end = std::min(names.find('\0', at), names.size());
    h.names.push_back(names.substr(at, end - at));
    at = major == 1 ? at + kNameSlot : end + 1;
  }
  h.entries.resize(h.header.index_allocated_entries);
  if (index_bytes > 0)
    PreadAll(fd, h.entries.data(), index_bytes, static_cast<std::int64_t>(h.header.index_location), path);
  const auto used =
      std::find_if(h.entries.begin(), h.entries.end(), [](const IndexEntry& e) { return e.location == 0; });
  h.entries.erase(used, h.entries.end());
  return h;
}

std::int64_t FileSize(int fd, const std::filesystem::path& path) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw ReadError(path.string() + ": " + ErrnoText());
  return static_cast<std::int64_t>(st.st_size);
}

}  // namespace

std::size_t SizeOf(Type type) {
  switch (type) {
    case Type::kUint8:
    case Type::kInt8:
    case Type::kCharacter: return 1;
    case Type::kUint16:
    case Type::kInt16: return 2;
    case Type::kUint32:
    case Type::kInt32:
    case Type::kFloat: return 4;
    case Type::kUint64:
    case Type::kInt64:
    case Type::kDouble: return 8;
  }
  return 0;
}

bool IsGsdFile(const std::filesystem::path& file) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  std::uint64_t magic = 0;
  const bool yes = ::pread(fd, &magic, sizeof magic, 0) == static_cast<ssize_t>(sizeof magic) && magic == kMagic;
  ::close(fd);
  return yes;
}

// ---- GsdFile -----------------------------------------------------------------------------

GsdFile::~GsdFile() {
  if (fd_ >= 0) ::close(fd_);
}

GsdFile::GsdFile(GsdFile&& other) noexcept { *this = std::move(other); }

GsdFile& GsdFile::operator=(GsdFile&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    path_ = std::move(other.path_);
    fd_ = std::exchange(other.fd_, -1);
    schema_ = std::move(other.schema_);
    schema_version_ = other.schema_version_;
    names_ = std::move(other.names_);
    ids_ = std::move(other.ids_);
    names_location_ = other.names_location_;
    names_capacity_ = other.names_capacity_;
    names_used_ = other.names_used_;
    index_location_ = other.index_location_;
    index_capacity_ = other.index_capacity_;
    index_ = std::move(other.index_);
    pending_ = std::move(other.pending_);
    frame_ = other.frame_;
    end_ = other.end_;
    dry_ = other.dry_;
  }
  return *this;
}

GsdFile GsdFile::Create(const std::filesystem::path& file, const std::string& schema, int major, int minor) {
  GsdFile g;
  g.path_ = file;
  g.fd_ = ::open(file.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (g.fd_ < 0) throw std::runtime_error("cannot create " + file.string() + ": " + ErrnoText());
  g.schema_ = schema;
  g.schema_version_ = MakeVersion(major, minor);
  g.Begin();
  return g;
}

// The header, the first name list and the first index block of a new file.
void GsdFile::Begin() {
  end_ = sizeof(Header);
  names_capacity_ = kFirstNameBytes;
  WriteNames(true);
  WriteIndex(kFirstIndexEntries, true);
}

// Follows, without writing, what writing `kept` (a file's first entries, whole frames) into a
// new file does: the name ids they get, where their data goes, where the name list and index
// blocks move. True, with this GsdFile in the state it had after their last frame, if every
// entry is where the file has it and the frames end at `offset`.
bool GsdFile::Replay(const std::vector<std::string>& names, const std::vector<IndexEntry>& kept, std::int64_t offset) {
  dry_ = true;
  Begin();
  for (std::size_t first = 0; first < kept.size();) {
    std::size_t last = first;
    while (last < kept.size() && kept[last].frame == kept[first].frame) ++last;
    if (kept[first].frame != frame_) return false;
    // A frame's entries are sorted by name id; its chunks were written in the order of their data.
    std::vector<IndexEntry> written(kept.begin() + static_cast<std::ptrdiff_t>(first),
                                    kept.begin() + static_cast<std::ptrdiff_t>(last));
    std::sort(written.begin(), written.end(),
              [](const IndexEntry& a, const IndexEntry& b) { return a.location < b.location; });
    for (const IndexEntry& e : written) {
      if (e.id >= names.size()) return false;
      Write(names[e.id], static_cast<Type>(e.type), e.n, e.m, nullptr);
      if (std::memcmp(&pending_.back(), &e, sizeof e) != 0) return false;
    }
    EndFrame();
    first = last;
  }
  return end_ == offset;
}

GsdFile GsdFile::ContinueAt(const std::filesystem::path& file, std::int64_t offset, const std::string& schema,
                            int major, int minor) {
  if (!std::filesystem::exists(file) || offset < static_cast<std::int64_t>(sizeof(Header)))
    return Create(file, schema, major, minor);
  const int fd = ::open(file.c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error("cannot open " + file.string() + ": " + ErrnoText());
  FileHead h;
  try {
    h = ReadHead(fd, file, FileSize(fd, file));
  } catch (...) {
    ::close(fd);
    throw;
  }
  // The frames the checkpoint had: their data ends before `offset` (a checkpoint is taken
  // between frames, so a frame is kept whole or dropped whole).
  std::vector<IndexEntry> kept;
  for (const IndexEntry& e : h.entries)
    if (e.location + static_cast<std::int64_t>(e.Bytes()) <= offset) kept.push_back(e);
  GsdFile g;
  g.path_ = file;
  g.schema_ = schema;
  g.schema_version_ = MakeVersion(major, minor);
  bool replayed = false;
  try {
    replayed = g.Replay(h.names, kept, offset);
  } catch (const std::exception&) {
    // A chunk named twice in a frame, say: not this layout; continued as an older one below.
  }
  g.dry_ = false;
  g.fd_ = fd;
  if (::ftruncate(g.fd_, offset) != 0) throw std::runtime_error("cannot cut " + file.string() + ": " + ErrnoText());
  if (replayed) {
    // The name list and index block in use at the checkpoint lie before `offset`; entries and
    // names the interrupted run added to them after it are cleared.
    g.WriteNames(false);
    g.WriteIndex(g.index_capacity_, false);
    return g;
  }
  g.names_.clear();
  g.ids_.clear();
  g.names_used_ = 0;
  for (const std::string& name : h.names) {
    g.ids_.emplace(name, static_cast<std::uint16_t>(g.names_.size()));
    g.names_.push_back(name);
    g.names_used_ += name.size() + 1;
  }
  g.index_ = kept;
  g.pending_.clear();
  g.frame_ = g.index_.empty() ? 0 : g.index_.back().frame + 1;
  g.end_ = offset;
  // The old blocks may lie past the offset, or list frames after it: both are written anew.
  g.names_capacity_ = std::max<std::uint64_t>(kFirstNameBytes, 2 * g.names_used_ + kNameSlot);
  g.WriteNames(true);
  g.WriteIndex(std::max<std::uint64_t>(kFirstIndexEntries, 2 * g.index_.size()), true);
  return g;
}

void GsdFile::PutAt(std::int64_t at, const void* data, std::size_t bytes) {
  if (dry_) {
    end_ = std::max(end_, at + static_cast<std::int64_t>(bytes));
    return;
  }
  const auto* p = static_cast<const char*>(data);
  while (bytes > 0) {
    const ssize_t put = ::pwrite(fd_, p, bytes, at);
    if (put < 0 && errno == EINTR) continue;
    if (put <= 0) throw std::runtime_error("cannot write " + path_.string() + ": " + ErrnoText());
    p += put;
    bytes -= static_cast<std::size_t>(put);
    at += put;
  }
  end_ = std::max(end_, at);
}

void GsdFile::WriteHeader() {
  Header h;
  h.index_location = index_location_;
  h.index_allocated_entries = index_capacity_;
  h.namelist_location = names_location_;
  h.namelist_allocated_entries = names_capacity_ / kNameSlot;
  h.schema_version = schema_version_;
  std::snprintf(h.application, sizeof h.application, "Granary %s", GRANARY_VERSION);
  std::snprintf(h.schema, sizeof h.schema, "%s", schema_.c_str());
  PutAt(0, &h, sizeof h);
}

// The name list at the end of the file (relocate) or in place, then the header.
void GsdFile::WriteNames(bool relocate) {
  std::string block;
  for (const std::string& n : names_) block += n + '\0';
  block.resize(names_capacity_, '\0');
  if (relocate) names_location_ = static_cast<std::uint64_t>(end_);
  PutAt(static_cast<std::int64_t>(names_location_), block.data(), block.size());
  WriteHeader();
}

// The committed entries in an index block of `capacity`: a new one at the end of the file
// (relocate) or the one in use.
void GsdFile::WriteIndex(std::uint64_t capacity, bool relocate) {
  index_capacity_ = capacity;
  if (relocate) index_location_ = static_cast<std::uint64_t>(end_);
  if (dry_) {
    PutAt(static_cast<std::int64_t>(index_location_), nullptr, capacity * sizeof(IndexEntry));
    return;
  }
  std::vector<IndexEntry> block(capacity);
  std::copy(index_.begin(), index_.end(), block.begin());
  PutAt(static_cast<std::int64_t>(index_location_), block.data(), block.size() * sizeof(IndexEntry));
  WriteHeader();
}

std::uint16_t GsdFile::IdOf(std::string_view name) {
  if (const auto it = ids_.find(std::string(name)); it != ids_.end()) return it->second;
  if (names_.size() >= 0xffff) throw std::runtime_error(path_.string() + ": more than 65535 chunk names");
  const auto id = static_cast<std::uint16_t>(names_.size());
  names_.emplace_back(name);
  ids_.emplace(std::string(name), id);
  names_used_ += name.size() + 1;
  // Room is kept for the empty name that ends the list.
  if (names_used_ + 1 > names_capacity_) {
    names_capacity_ = (2 * names_used_ + kNameSlot) / kNameSlot * kNameSlot;
    WriteNames(true);
  } else {
    WriteNames(false);
  }
  return id;
}

void GsdFile::Write(std::string_view name, Type type, std::uint64_t n, std::uint32_t m, const void* data) {
  IndexEntry e;
  e.frame = frame_;
  e.n = n;
  e.m = m;
  e.id = IdOf(name);
  e.type = static_cast<std::uint8_t>(type);
  e.location = end_;
  for (const IndexEntry& p : pending_)
    if (p.id == e.id)
      throw std::logic_error(path_.string() + ": chunk " + std::string(name) + " written twice in a frame");
  PutAt(end_, data, e.Bytes());
  pending_.push_back(e);
}

void GsdFile::EndFrame() {
  // The spec keeps a 2.x index sorted by frame, then by name id (readers search it).
  std::sort(pending_.begin(), pending_.end(), [](const IndexEntry& a, const IndexEntry& b) { return a.id < b.id; });
  if (index_.size() + pending_.size() > index_capacity_) {
    index_.insert(index_.end(), pending_.begin(), pending_.end());
    std::uint64_t capacity = std::max<std::uint64_t>(index_capacity_, 1);
    while (capacity < index_.size()) capacity *= 2;
    WriteIndex(capacity, true);
  } else {
    PutAt(static_cast<std::int64_t>(index_location_ + index_.size() * sizeof(IndexEntry)), pending_.data(),
          pending_.size() * sizeof(IndexEntry));
    index_.insert(index_.end(), pending_.begin(), pending_.end());
  }
  pending_.clear();
  ++frame_;
}

void GsdFile::Close() {
  if (fd_ < 0) return;
  if (!pending_.empty()) EndFrame();
  const int fd = std::exchange(fd_, -1);
  if (::close(fd) != 0) throw std::runtime_error("cannot close " + path_.string() + ": " + ErrnoText());
}

// ---- GsdReader ---------------------------------------------------------------------------

GsdReader::GsdReader(const std::filesystem::path& file) : path_(file) {
  fd_ = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) throw ReadError(file.string() + ": cannot open: " + ErrnoText());
  const std::int64_t size = FileSize(fd_, file);
  FileHead h = ReadHead(fd_, file, size);
  schema_ = std::string(h.header.schema, strnlen(h.header.schema, sizeof h.header.schema));
  names_ = std::move(h.names);
  for (std::size_t i = 0; i < names_.size(); ++i) ids_.emplace(names_[i], static_cast<std::uint16_t>(i));
  for (std::size_t k = 0; k < h.entries.size(); ++k) {
    const IndexEntry& e = h.entries[k];
    if (SizeOf(static_cast<Type>(e.type)) == 0 || e.id >= names_.size() || e.location < 0)
      Fail("index entry " + std::to_string(k) + " is corrupt (type " + std::to_string(e.type) + ", name id " +
           std::to_string(e.id) + " of " + std::to_string(names_.size()) + ")");
    if (!index_.empty() && e.frame < index_.back().frame)
      Fail("index entry " + std::to_string(k) + " goes back from frame " + std::to_string(index_.back().frame) +
           " to " + std::to_string(e.frame));
    if (e.location + static_cast<std::int64_t>(e.Bytes()) > size) {
      // Data not all there (a writer at work, or a cut file): the frames before this one.
      while (!index_.empty() && index_.back().frame == e.frame) index_.pop_back();
      break;
    }
    index_.push_back(e);
  }
  // A frame is complete when the next one has begun; the last one when its entries were all
  // written: it was (EndFrame writes them at once) unless the writer was interrupted, and
  // the frame readers check for the chunks they need.
  frames_ = index_.empty() ? 0 : index_.back().frame + 1;
  frame_start_.assign(frames_ + 1, index_.size());
  for (std::size_t k = index_.size(); k-- > 0;) frame_start_[index_[k].frame] = k;
  for (std::uint64_t f = frames_; f-- > 0;) frame_start_[f] = std::min(frame_start_[f], frame_start_[f + 1]);
}

GsdReader::~GsdReader() {
  if (fd_ >= 0) ::close(fd_);
}

GsdReader::GsdReader(GsdReader&& other) noexcept
    : path_(std::move(other.path_)),
      fd_(std::exchange(other.fd_, -1)),
      schema_(std::move(other.schema_)),
      names_(std::move(other.names_)),
      ids_(std::move(other.ids_)),
      index_(std::move(other.index_)),
      frame_start_(std::move(other.frame_start_)),
      frames_(other.frames_) {}

GsdReader& GsdReader::operator=(GsdReader&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    path_ = std::move(other.path_);
    fd_ = std::exchange(other.fd_, -1);
    schema_ = std::move(other.schema_);
    names_ = std::move(other.names_);
    ids_ = std::move(other.ids_);
    index_ = std::move(other.index_);
    frame_start_ = std::move(other.frame_start_);
    frames_ = other.frames_;
  }
  return *this;
}

const IndexEntry* GsdReader::Find(std::uint64_t frame, std::string_view name) const {
  if (frame >= frames_) return nullptr;
  const auto it = ids_.find(std::string(name));
  if (it == ids_.end()) return nullptr;
  for (std::size_t k = frame_start_[frame]; k < frame_start_[frame + 1]; ++k)
    if (index_[k].id == it->second) return &index_[k];
  return nullptr;
}

void GsdReader::Fail(const std::string& what) const { throw ReadError(path_.string() + ": " + what); }

void GsdReader::CheckType(const IndexEntry& e, std::size_t size) const {
  if (SizeOf(static_cast<Type>(e.type)) != size)
    Fail("chunk " + names_[e.id] + " of frame " + std::to_string(e.frame) + " has elements of " +
         std::to_string(SizeOf(static_cast<Type>(e.type))) + " bytes, expected " + std::to_string(size));
}

void GsdReader::ReadBytes(const IndexEntry& e, void* out) const { PreadAll(fd_, out, e.Bytes(), e.location, path_); }

// ---- frames ------------------------------------------------------------------------------

namespace {

constexpr char kFrameSchema[] = "hoomd";
constexpr int kFrameSchemaMajor = 1, kFrameSchemaMinor = 4;
constexpr char kContactSchema[] = "granary-contacts";

double CentreOf(const double (&box)[3][2], int axis) { return 0.5 * (box[axis][0] + box[axis][1]); }

// The box's HOOMD form (Lx Ly Lz xy xz yz) and its exact double form.
void WriteBoxAndTime(GsdFile& f, std::int64_t timestep, double time, const double (&box)[3][2]) {
  const auto step = static_cast<std::uint64_t>(timestep);
  f.Write("configuration/step", Type::kUint64, 1, 1, &step);
  const float hoomd_box[6] = {static_cast<float>(box[0][1] - box[0][0]),
                              static_cast<float>(box[1][1] - box[1][0]),
                              static_cast<float>(box[2][1] - box[2][0]),
                              0,
                              0,
                              0};
  f.Write("configuration/box", Type::kFloat, 6, 1, hoomd_box);
  f.Write("log/granary/time", Type::kDouble, 1, 1, &time);
  f.Write("log/granary/box", Type::kDouble, 3, 2, &box[0][0]);
}

// Step, time and box of `frame` of a frames.gsd or contacts.gsd; false if the frame lacks
// its step (cut short). A GSD file from elsewhere without Granary's log chunks gets time =
// step and a box centred on 0.
bool ReadBoxAndTime(const GsdReader& r, std::uint64_t frame, std::int64_t& timestep, double& time,
                    double (&box)[3][2]) {
  const IndexEntry* step = r.Find(frame, "configuration/step");
  if (!step) step = frame == 0 ? nullptr : r.Find(0, "configuration/step");
  timestep = step ? static_cast<std::int64_t>(r.ReadScalar<std::uint64_t>(*step)) : 0;
  const IndexEntry* t = r.Find(frame, "log/granary/time");
  time = t ? r.ReadScalar<double>(*t) : static_cast<double>(timestep);
  if (const IndexEntry* b = r.Find(frame, "log/granary/box")) {
    std::vector<double> v;
    r.Read(*b, v);
    if (v.size() != 6)
      r.Fail("log/granary/box of frame " + std::to_string(frame) + " has " + std::to_string(v.size()) +
             " values, not 6");
    std::copy(v.begin(), v.end(), &box[0][0]);
  } else {
    const IndexEntry* hb = r.Find(frame, "configuration/box");
    if (!hb) hb = r.Find(0, "configuration/box");
    std::vector<float> v;
    if (hb) r.Read(*hb, v);
    for (int a = 0; a < 3; ++a) {
      const double l = v.size() >= 3 ? v[static_cast<std::size_t>(a)] : 1.0;
      box[a][0] = -l / 2;
      box[a][1] = l / 2;
    }
  }
  return true;
}

// Per body, in increasing body id: each disc's row.
std::size_t BodyRows(const std::vector<std::int64_t>& mol, std::vector<std::uint32_t>& row) {
  row.resize(mol.size());
  if (std::is_sorted(mol.begin(), mol.end())) {
    std::size_t rows = 0;
    for (std::size_t i = 0; i < mol.size(); ++i) {
      if (i > 0 && mol[i] != mol[i - 1]) ++rows;
      row[i] = static_cast<std::uint32_t>(rows);
    }
    return mol.empty() ? 0 : rows + 1;
  }
  std::vector<std::int64_t> ids(mol);
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  for (std::size_t i = 0; i < mol.size(); ++i)
    row[i] = static_cast<std::uint32_t>(std::lower_bound(ids.begin(), ids.end(), mol[i]) - ids.begin());
  return ids.size();
}

// The chunks of one frame; `constants` adds the per-disc constants (frame 0 and frames whose
// constants differ from its).
void WriteFrameChunks(GsdFile& f, const Frame& frame, bool constants) {
  const std::size_t n = frame.discs.size();
  WriteBoxAndTime(f, frame.timestep, frame.time, frame.box);
  const auto count = static_cast<std::uint32_t>(n);
  f.Write("particles/N", Type::kUint32, 1, 1, &count);
  if (n == 0) return;
  const double cx = CentreOf(frame.box, 0), cy = CentreOf(frame.box, 1);
  std::vector<float> position(3 * n);
  std::vector<std::int64_t> mol(n);
  for (std::size_t i = 0; i < n; ++i) {
    position[3 * i] = static_cast<float>(frame.discs[i].x - cx);
    position[3 * i + 1] = static_cast<float>(frame.discs[i].y - cy);
    mol[i] = frame.discs[i].mol;
  }
  f.Write("particles/position", Type::kFloat, n, 3, position.data());
  std::vector<std::uint32_t> row;
  const std::size_t bodies = BodyRows(mol, row);
  std::vector<double> m(bodies, 0.0), p(2 * bodies, 0.0);
  std::vector<float> omega(bodies, 0.0f);
  for (std::size_t i = 0; i < n; ++i) {
    const Disc& d = frame.discs[i];
    m[row[i]] += d.mass;
    p[2 * row[i]] += d.mass * d.vx;
    p[2 * row[i] + 1] += d.mass * d.vy;
    omega[row[i]] = static_cast<float>(d.omega);
  }
  std::vector<float> velocity(2 * bodies);
  for (std::size_t b = 0; b < bodies; ++b)
    for (int a = 0; a < 2; ++a) velocity[2 * b + a] = static_cast<float>(m[b] > 0 ? p[2 * b + a] / m[b] : 0.0);
  f.Write("log/bodies/velocity", Type::kFloat, bodies, 2, velocity.data());
  f.Write("log/bodies/omega", Type::kFloat, bodies, 1, omega.data());
  if (!constants) return;
  std::vector<std::uint32_t> typeid_(n);
  std::vector<float> mass(n), diameter(n);
  std::vector<std::int32_t> body(n);
  std::vector<std::int64_t> id(n);
  int types = 1;
  for (std::size_t i = 0; i < n; ++i) {
    const Disc& d = frame.discs[i];
    typeid_[i] = static_cast<std::uint32_t>(std::max(0, d.type - 1));
    mass[i] = static_cast<float>(d.mass);
    diameter[i] = static_cast<float>(2 * d.radius);
    body[i] = static_cast<std::int32_t>(d.mol);
    id[i] = d.id;
    types = std::max(types, d.type);
  }
  // Type names "1", "2", ...: the dump's type column (species index + 1).
  constexpr std::uint32_t kNameWidth = 8;
  std::vector<char> names(static_cast<std::size_t>(types) * kNameWidth, '\0');
  for (int t = 0; t < types; ++t) {
    const std::string name = std::to_string(t + 1);
    std::copy_n(name.begin(), std::min<std::size_t>(name.size(), kNameWidth - 1),
                &names[static_cast<std::size_t>(t) * kNameWidth]);
  }
  const std::uint8_t dimensions = 2;
  f.Write("configuration/dimensions", Type::kUint8, 1, 1, &dimensions);
  f.Write("particles/types", Type::kInt8, static_cast<std::uint64_t>(types), kNameWidth, names.data());
  f.Write("particles/typeid", Type::kUint32, n, 1, typeid_.data());
  f.Write("particles/mass", Type::kFloat, n, 1, mass.data());
  f.Write("particles/diameter", Type::kFloat, n, 1, diameter.data());
  f.Write("particles/body", Type::kInt32, n, 1, body.data());
  f.Write("log/particles/id", Type::kInt64, n, 1, id.data());
}

}  // namespace

GsdFrameWriter GsdFrameWriter::Create(const std::filesystem::path& file) {
  GsdFrameWriter w;
  w.file_ = GsdFile::Create(file, kFrameSchema, kFrameSchemaMajor, kFrameSchemaMinor);
  return w;
}

GsdFrameWriter GsdFrameWriter::ContinueAt(const std::filesystem::path& file, std::int64_t offset) {
  GsdFrameWriter w;
  if (std::filesystem::exists(file) && offset >= static_cast<std::int64_t>(sizeof(Header))) {
    const GsdReader r(file);
    if (const IndexEntry* e = r.Find(0, "particles/typeid");
        e && e->location + static_cast<std::int64_t>(e->Bytes()) <= offset) {
      r.Read(*e, w.typeid0_);
      r.Read(*r.Find(0, "particles/mass"), w.mass0_);
      r.Read(*r.Find(0, "particles/diameter"), w.diameter0_);
      r.Read(*r.Find(0, "particles/body"), w.body0_);
      r.Read(*r.Find(0, "log/particles/id"), w.id0_);
    }
  }
  w.file_ = GsdFile::ContinueAt(file, offset, kFrameSchema, kFrameSchemaMajor, kFrameSchemaMinor);
  return w;
}

void GsdFrameWriter::Write(const Frame& frame) {
  bool constants = file_.Frames() == 0 || frame.discs.size() != typeid0_.size();
  for (std::size_t i = 0; !constants && i < frame.discs.size(); ++i) {
    const Disc& d = frame.discs[i];
    constants = typeid0_[i] != static_cast<std::uint32_t>(std::max(0, d.type - 1)) ||
                mass0_[i] != static_cast<float>(d.mass) || diameter0_[i] != static_cast<float>(2 * d.radius) ||
                body0_[i] != static_cast<std::int32_t>(d.mol) || id0_[i] != d.id;
  }
  WriteFrameChunks(file_, frame, constants);
  if (file_.Frames() == 0) {
    const std::size_t n = frame.discs.size();
    typeid0_.resize(n);
    mass0_.resize(n);
    diameter0_.resize(n);
    body0_.resize(n);
    id0_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Disc& d = frame.discs[i];
      typeid0_[i] = static_cast<std::uint32_t>(std::max(0, d.type - 1));
      mass0_[i] = static_cast<float>(d.mass);
      diameter0_[i] = static_cast<float>(2 * d.radius);
      body0_[i] = static_cast<std::int32_t>(d.mol);
      id0_[i] = d.id;
    }
  }
  file_.EndFrame();
}

std::int64_t GsdFrameBytes(const Frame& frame) {
  // Counted from the chunk sizes WriteFrameChunks writes without the constants: 4 scalar-ish
  // chunks, position, and the two per-body arrays; each with its index entry.
  std::vector<std::int64_t> mol(frame.discs.size());
  for (std::size_t i = 0; i < mol.size(); ++i) mol[i] = frame.discs[i].mol;
  std::vector<std::uint32_t> row;
  const auto bodies = static_cast<std::int64_t>(BodyRows(mol, row));
  const auto n = static_cast<std::int64_t>(frame.discs.size());
  std::int64_t bytes = 8 + 6 * 4 + 8 + 6 * 8 + 4 + 5 * static_cast<std::int64_t>(sizeof(IndexEntry));
  if (n > 0) bytes += 12 * n + 8 * bodies + 4 * bodies + 3 * static_cast<std::int64_t>(sizeof(IndexEntry));
  return bytes;
}

std::int64_t GsdOverheadBytes(std::uint64_t entries) {
  // As GsdFile::Create and EndFrame allocate: the first block, then each outgrown one
  // replaced by one of twice its size.
  std::uint64_t capacity = kFirstIndexEntries, blocks = kFirstIndexEntries;
  while (entries > capacity) {
    capacity *= 2;
    blocks += capacity;
  }
  return static_cast<std::int64_t>(sizeof(Header) + kFirstNameBytes + (blocks - entries) * sizeof(IndexEntry));
}

GsdFrameReader::GsdFrameReader(const std::filesystem::path& file) : file_(file) {
  if (file_.Schema() != kFrameSchema) file_.Fail("a GSD file of schema '" + file_.Schema() + "', not 'hoomd'");
}

bool GsdFrameReader::NextHeader(Frame& frame) {
  frame.discs.clear();
  if (pending_) SkipDiscs();
  if (next_ >= file_.Frames()) return false;
  // The last frame of a file still being written may lack its positions: the end.
  const IndexEntry* n = file_.Find(next_, "particles/N");
  if (!n) return false;
  if (file_.ReadScalar<std::uint32_t>(*n) > 0 && !file_.Find(next_, "particles/position")) return false;
  ReadBoxAndTime(file_, next_, frame.timestep, frame.time, frame.box);
  centre_[0] = CentreOf(frame.box, 0);
  centre_[1] = CentreOf(frame.box, 1);
  pending_ = true;
  return true;
}

bool GsdFrameReader::SkipDiscs() {
  if (!pending_) return false;
  pending_ = false;
  ++next_;
  return true;
}

void GsdFrameReader::LoadConstants(std::uint64_t frame, std::uint64_t n) {
  std::uint64_t from = file_.Find(frame, "particles/typeid") ? frame : 0;
  if (from == constants_from_ && typeid_.size() == n) return;
  auto need = [&](const char* name) -> const IndexEntry& {
    const IndexEntry* e = file_.Find(from, name);
    if (!e) file_.Fail(std::string("frame ") + std::to_string(frame) + " has no " + name + " (nor has frame 0)");
    if (e->n != n)
      file_.Fail(std::string(name) + " of frame " + std::to_string(from) + " has " + std::to_string(e->n) +
                 " rows, frame " + std::to_string(frame) + " has " + std::to_string(n) + " discs");
    return *e;
  };
  file_.Read(need("particles/typeid"), typeid_);
  file_.Read(need("particles/mass"), mass_);
  file_.Read(need("particles/diameter"), diameter_);
  file_.Read(need("particles/body"), body_);
  file_.Read(need("log/particles/id"), id_);
  std::vector<std::int64_t> mol(body_.begin(), body_.end());
  n_bodies_ = BodyRows(mol, body_index_);
  constants_from_ = from;
}

bool GsdFrameReader::ReadDiscs(Frame& frame) {
  frame.discs.clear();
  if (!pending_) return false;
  const std::uint64_t f = next_;
  SkipDiscs();
  const auto n = file_.ReadScalar<std::uint32_t>(*file_.Find(f, "particles/N"));
  if (n == 0) return true;
  LoadConstants(f, n);
  auto need = [&](const char* name, std::uint64_t rows, std::uint32_t cols, std::vector<float>& out) {
    const IndexEntry* e = file_.Find(f, name);
    if (!e) file_.Fail(std::string("frame ") + std::to_string(f) + " has no " + name);
    if (e->n != rows || e->m != cols)
      file_.Fail(std::string(name) + " of frame " + std::to_string(f) + " is " + std::to_string(e->n) + " x " +
                 std::to_string(e->m) + ", expected " + std::to_string(rows) + " x " + std::to_string(cols));
    file_.Read(*e, out);
  };
  need("particles/position", n, 3, position_);
  need("log/bodies/velocity", n_bodies_, 2, velocity_);
  need("log/bodies/omega", n_bodies_, 1, omega_);
  frame.discs.resize(n);
  // Disc velocities of a rigid body: V + omega x (r - R), R its centre of mass from these
  // very positions, so that BodiesOf gives back V.
  std::vector<double> m(n_bodies_, 0.0), mx(n_bodies_, 0.0), my(n_bodies_, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    Disc& d = frame.discs[i];
    d.id = id_[i];
    d.mol = body_[i];
    d.type = static_cast<int>(typeid_[i]) + 1;
    d.x = static_cast<double>(position_[3 * i]) + centre_[0];
    d.y = static_cast<double>(position_[3 * i + 1]) + centre_[1];
    d.radius = 0.5 * static_cast<double>(diameter_[i]);
    d.mass = static_cast<double>(mass_[i]);
    const std::uint32_t b = body_index_[i];
    m[b] += d.mass;
    mx[b] += d.mass * d.x;
    my[b] += d.mass * d.y;
  }
  for (std::size_t i = 0; i < n; ++i) {
    Disc& d = frame.discs[i];
    const std::uint32_t b = body_index_[i];
    const double w = omega_[b];
    const double rx = m[b] > 0 ? d.x - mx[b] / m[b] : 0.0, ry = m[b] > 0 ? d.y - my[b] / m[b] : 0.0;
    d.omega = w;
    d.vx = static_cast<double>(velocity_[2 * b]) - w * ry;
    d.vy = static_cast<double>(velocity_[2 * b + 1]) + w * rx;
  }
  return true;
}

// ---- contacts ----------------------------------------------------------------------------

namespace {

void WriteContactChunks(GsdFile& f, const ContactFrame& frame) {
  WriteBoxAndTime(f, frame.timestep, frame.time, frame.box);
  const std::uint64_t n = frame.contacts.size();
  f.Write("contacts/N", Type::kUint64, 1, 1, &n);
  if (n == 0) return;
  const double cx = CentreOf(frame.box, 0), cy = CentreOf(frame.box, 1);
  std::vector<std::int32_t> body(2 * n);
  std::vector<float> centres(4 * n), point(2 * n), force(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const ContactRow& c = frame.contacts[i];
    body[2 * i] = static_cast<std::int32_t>(c.body_i);
    body[2 * i + 1] = static_cast<std::int32_t>(c.body_j);
    centres[4 * i] = static_cast<float>(c.xi - cx);
    centres[4 * i + 1] = static_cast<float>(c.yi - cy);
    centres[4 * i + 2] = static_cast<float>(c.xj - cx);
    centres[4 * i + 3] = static_cast<float>(c.yj - cy);
    point[2 * i] = static_cast<float>(c.cx - cx);
    point[2 * i + 1] = static_cast<float>(c.cy - cy);
    force[2 * i] = static_cast<float>(c.fx);
    force[2 * i + 1] = static_cast<float>(c.fy);
  }
  f.Write("contacts/body", Type::kInt32, n, 2, body.data());
  f.Write("contacts/centres", Type::kFloat, n, 4, centres.data());
  f.Write("contacts/point", Type::kFloat, n, 2, point.data());
  f.Write("contacts/force", Type::kFloat, n, 2, force.data());
}

}  // namespace

GsdContactWriter GsdContactWriter::Create(const std::filesystem::path& file) {
  GsdContactWriter w;
  w.file_ = GsdFile::Create(file, kContactSchema, 1, 0);
  return w;
}

GsdContactWriter GsdContactWriter::ContinueAt(const std::filesystem::path& file, std::int64_t offset) {
  GsdContactWriter w;
  w.file_ = GsdFile::ContinueAt(file, offset, kContactSchema, 1, 0);
  return w;
}

void GsdContactWriter::Write(const ContactFrame& frame) {
  WriteContactChunks(file_, frame);
  file_.EndFrame();
}

std::int64_t GsdContactBytes(const ContactFrame& frame) {
  const auto n = static_cast<std::int64_t>(frame.contacts.size());
  std::int64_t bytes = 8 + 6 * 4 + 8 + 6 * 8 + 8 + 5 * static_cast<std::int64_t>(sizeof(IndexEntry));
  if (n > 0) bytes += n * (8 + 16 + 8 + 8) + 4 * static_cast<std::int64_t>(sizeof(IndexEntry));
  return bytes;
}

GsdContactReader::GsdContactReader(const std::filesystem::path& file) : file_(file) {
  if (file_.Schema() != kContactSchema)
    file_.Fail("a GSD file of schema '" + file_.Schema() + "', not '" + kContactSchema + "'");
}

bool GsdContactReader::NextHeader(ContactFrame& frame) {
  frame.contacts.clear();
  if (pending_) SkipContacts();
  if (next_ >= file_.Frames()) return false;
  const IndexEntry* n = file_.Find(next_, "contacts/N");
  if (!n) return false;
  if (file_.ReadScalar<std::uint64_t>(*n) > 0 && !file_.Find(next_, "contacts/force")) return false;
  ReadBoxAndTime(file_, next_, frame.timestep, frame.time, frame.box);
  centre_[0] = CentreOf(frame.box, 0);
  centre_[1] = CentreOf(frame.box, 1);
  pending_ = true;
  return true;
}

bool GsdContactReader::SkipContacts() {
  if (!pending_) return false;
  pending_ = false;
  ++next_;
  return true;
}

bool GsdContactReader::ReadContacts(ContactFrame& frame) {
  frame.contacts.clear();
  if (!pending_) return false;
  const std::uint64_t f = next_;
  SkipContacts();
  const auto n = file_.ReadScalar<std::uint64_t>(*file_.Find(f, "contacts/N"));
  if (n == 0) return true;
  std::vector<std::int32_t> body;
  std::vector<float> centres, point, force;
  auto need = [&](const char* name, std::uint32_t cols, auto& out) {
    const IndexEntry* e = file_.Find(f, name);
    if (!e || e->n != n || e->m != cols)
      file_.Fail(std::string(name) + " of frame " + std::to_string(f) + " is missing or not " + std::to_string(n) +
                 " x " + std::to_string(cols));
    file_.Read(*e, out);
  };
  need("contacts/body", 2, body);
  need("contacts/centres", 4, centres);
  need("contacts/point", 2, point);
  need("contacts/force", 2, force);
  frame.contacts.resize(n);
  const double cx = centre_[0], cy = centre_[1];
  for (std::size_t i = 0; i < n; ++i) {
    ContactRow& c = frame.contacts[i];
    c.body_i = body[2 * i];
    c.body_j = body[2 * i + 1];
    c.xi = static_cast<double>(centres[4 * i]) + cx;
    c.yi = static_cast<double>(centres[4 * i + 1]) + cy;
    c.xj = static_cast<double>(centres[4 * i + 2]) + cx;
    c.yj = static_cast<double>(centres[4 * i + 3]) + cy;
    c.cx = static_cast<double>(point[2 * i]) + cx;
    c.cy = static_cast<double>(point[2 * i + 1]) + cy;
    c.fx = force[2 * i];
    c.fy = force[2 * i + 1];
  }
  return true;
}

}  // namespace granary::rundir::gsd

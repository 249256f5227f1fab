// GSD (HOOMD-blue's binary trajectory format, file layer 2.0: gsd.readthedocs.io "File layer")
// written and read by Granary itself: frames.gsd and contacts.gsd (output.format "gsd";
// docs/run-directory.md "Binary frames"). The file layer (GsdFile, GsdReader) knows chunks
// only; GsdFrameWriter/-Reader and GsdContactWriter/-Reader map rundir::Frame and
// ContactFrame onto chunks. FrameWriter and FrameReader (frames.h), ContactWriter and
// ContactReader (contacts.h) use them for files named *.gsd, so callers do not change.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace granary::rundir {

struct Frame;
struct ContactFrame;

namespace gsd {

inline constexpr std::uint64_t kMagic = 0x65DF65DF65DF65DFULL;

// Chunk element types (the spec's numbering).
enum class Type : std::uint8_t {
  kUint8 = 1,
  kUint16,
  kUint32,
  kUint64,
  kInt8,
  kInt16,
  kInt32,
  kInt64,
  kFloat,
  kDouble,
  kCharacter
};
std::size_t SizeOf(Type type);  // 0 for an unknown type

// One entry of the index: chunk `id` (its name's place in the name list) of `frame`, an
// n x m array of `type` at `location`.
struct IndexEntry {
  std::uint64_t frame = 0;
  std::uint64_t n = 0;
  std::int64_t location = 0;
  std::uint32_t m = 0;
  std::uint16_t id = 0;
  std::uint8_t type = 0;
  std::uint8_t flags = 0;
  std::uint64_t Bytes() const { return n * m * SizeOf(static_cast<Type>(type)); }
};
static_assert(sizeof(IndexEntry) == 32);

// True when `file` starts with GSD's magic number.
bool IsGsdFile(const std::filesystem::path& file);

// A GSD file written frame by frame: chunks of the current frame with Write, committed by
// EndFrame (data first, then its index entries, so a reader never sees an entry whose data
// is not there yet).
class GsdFile {
 public:
  GsdFile() = default;
  ~GsdFile();
  GsdFile(GsdFile&& other) noexcept;
  GsdFile& operator=(GsdFile&& other) noexcept;
  GsdFile(const GsdFile&) = delete;
  GsdFile& operator=(const GsdFile&) = delete;

  // Creates (truncates) `file` with the schema's name and version (major, minor).
  static GsdFile Create(const std::filesystem::path& file, const std::string& schema, int major, int minor);
  // The file of an interrupted run cut back to `offset` bytes (an Offset() its checkpoint
  // recorded): frames whose data ends past it are dropped, and the file is left byte for byte
  // as it was when the checkpoint was taken, so that the continued run writes the same bytes
  // as an uninterrupted one. Where the name list and the index block lay then follows from the
  // frames kept (where each chunk and block goes depends only on the chunks written before
  // it): Replay finds it by writing the kept frames again without writing. A file whose
  // layout is not that (continued by an older build, which moved both to the end) gets its
  // name list and index written anew at the end. A missing file, or one cut before any frame,
  // is created.
  static GsdFile ContinueAt(const std::filesystem::path& file, std::int64_t offset, const std::string& schema,
                            int major, int minor);

  void Write(std::string_view name, Type type, std::uint64_t n, std::uint32_t m, const void* data);
  void EndFrame();
  std::uint64_t Frames() const { return frame_; }
  bool IsOpen() const { return fd_ >= 0; }
  // Bytes of the file after the last EndFrame: what a checkpoint records.
  std::int64_t Offset() const { return end_; }
  // Throws std::runtime_error naming the file if a write failed.
  void Close();

 private:
  void Begin();
  bool Replay(const std::vector<std::string>& names, const std::vector<IndexEntry>& kept, std::int64_t offset);
  std::uint16_t IdOf(std::string_view name);
  void PutAt(std::int64_t at, const void* data, std::size_t bytes);
  void WriteHeader();
  void WriteNames(bool relocate);
  void WriteIndex(std::uint64_t capacity, bool relocate);

  std::filesystem::path path_;
  int fd_ = -1;
  std::string schema_;
  std::uint32_t schema_version_ = 0;
  std::vector<std::string> names_;
  std::unordered_map<std::string, std::uint16_t> ids_;
  std::uint64_t names_location_ = 0, names_capacity_ = 0, names_used_ = 0;  // capacity, used: bytes
  std::uint64_t index_location_ = 0, index_capacity_ = 0;                   // capacity: entries
  std::vector<IndexEntry> index_;                                           // committed entries
  std::vector<IndexEntry> pending_;                                         // the current frame's
  std::uint64_t frame_ = 0;
  std::int64_t end_ = 0;
  bool dry_ = false;  // Replay: the layout is followed, nothing is written
};

// A GSD file read through its index. The frames are those complete when it was opened (an
// entry whose data is not all there ends them: an engine still writing). Malformed files
// throw ReadError naming the file.
class GsdReader {
 public:
  explicit GsdReader(const std::filesystem::path& file);
  ~GsdReader();
  GsdReader(GsdReader&& other) noexcept;
  GsdReader& operator=(GsdReader&& other) noexcept;
  GsdReader(const GsdReader&) = delete;
  GsdReader& operator=(const GsdReader&) = delete;

  std::uint64_t Frames() const { return frames_; }
  const std::string& Schema() const { return schema_; }
  // The chunk `name` of `frame`, or nullptr.
  const IndexEntry* Find(std::uint64_t frame, std::string_view name) const;
  // The chunk's n x m values, converted to T (which must be its type's C++ type).
  template <class T>
  void Read(const IndexEntry& e, std::vector<T>& out) const {
    CheckType(e, sizeof(T));
    out.resize(e.n * e.m);
    ReadBytes(e, out.data());
  }
  template <class T>
  T ReadScalar(const IndexEntry& e) const {
    CheckType(e, sizeof(T));
    if (e.n * e.m < 1) Fail("chunk of frame " + std::to_string(e.frame) + " is empty");
    std::vector<T> v(e.n * e.m);
    ReadBytes(e, v.data());
    return v[0];
  }
  const std::filesystem::path& File() const { return path_; }
  [[noreturn]] void Fail(const std::string& what) const;

 private:
  void CheckType(const IndexEntry& e, std::size_t size) const;
  void ReadBytes(const IndexEntry& e, void* out) const;

  std::filesystem::path path_;
  int fd_ = -1;
  std::string schema_;
  std::vector<std::string> names_;
  std::unordered_map<std::string, std::uint16_t> ids_;
  std::vector<IndexEntry> index_;
  std::vector<std::size_t> frame_start_;  // index_ position of each frame's first entry, and the end
  std::uint64_t frames_ = 0;
};

// ---- the frames and contact frames of a run directory ------------------------------------

// frames.gsd: HOOMD's schema ("hoomd" 1.4), so OVITO and gsd.hoomd open it: per frame
// configuration/step and box, particles/N and position (float32, relative to the box centre);
// the per-disc constants (typeid, mass, diameter, body, log/particles/id) in frame 0 and again
// in any frame where they differ from frame 0's; per body (in increasing body id) its
// centre-of-mass velocity and angular velocity (log/bodies/velocity, log/bodies/omega),
// from which the disc velocities of a rigid body follow; the exact time and box in double
// (log/granary/time, log/granary/box).
class GsdFrameWriter {
 public:
  static GsdFrameWriter Create(const std::filesystem::path& file);
  static GsdFrameWriter ContinueAt(const std::filesystem::path& file, std::int64_t offset);
  void Write(const Frame& frame);
  bool IsOpen() const { return file_.IsOpen(); }
  std::int64_t Offset() const { return file_.Offset(); }
  void Close() { file_.Close(); }

 private:
  GsdFile file_;
  // Frame 0's per-disc constants, to tell which later frames must carry their own.
  std::vector<std::uint32_t> typeid0_;
  std::vector<float> mass0_, diameter0_;
  std::vector<std::int32_t> body0_;
  std::vector<std::int64_t> id0_;
};

// The bytes a frame after the first adds to frames.gsd (its chunks and their index entries:
// kGsdFrameEntries of them); what the estimator counts per frame. Frame 0 adds the per-disc
// constants, kGsdConstantBytesPerDisc per disc.
std::int64_t GsdFrameBytes(const Frame& frame);
inline constexpr int kGsdFrameEntries = 8;
inline constexpr int kGsdConstantBytesPerDisc = 4 + 4 + 4 + 4 + 8;  // typeid mass diameter body id
// The bytes of a GSD file besides its chunks and their index entries, once it holds
// `entries` of them: header, name list, and the index blocks outgrown (each growth writes a
// larger block at the end of the file and leaves the old one).
std::int64_t GsdOverheadBytes(std::uint64_t entries);

class GsdFrameReader {
 public:
  explicit GsdFrameReader(const std::filesystem::path& file);
  bool NextHeader(Frame& frame);
  bool ReadDiscs(Frame& frame);
  bool SkipDiscs();

 private:
  void LoadConstants(std::uint64_t frame, std::uint64_t n);

  GsdReader file_;
  std::uint64_t next_ = 0;  // the frame NextHeader reads
  bool pending_ = false;    // a header read, its discs not yet
  double centre_[2] = {0, 0};
  // The per-disc constants in use and the frame they came from.
  std::uint64_t constants_from_ = UINT64_MAX;
  std::vector<std::uint32_t> typeid_;
  std::vector<float> mass_, diameter_;
  std::vector<std::int32_t> body_;
  std::vector<std::int64_t> id_;
  std::vector<std::uint32_t> body_index_;  // each disc's row in the per-body arrays
  std::size_t n_bodies_ = 0;
  std::vector<float> position_, velocity_, omega_;
};

// contacts.gsd: schema "granary-contacts" 1.0; per frame configuration/step, log/granary/time
// and box (double), contacts/N, and for N > 0 contacts/body (int32 N x 2: body_i, body_j),
// contacts/centres (float32 N x 4: xi yi xj yj), contacts/point (N x 2) and contacts/force
// (N x 2), coordinates relative to the box centre as in frames.gsd.
class GsdContactWriter {
 public:
  static GsdContactWriter Create(const std::filesystem::path& file);
  static GsdContactWriter ContinueAt(const std::filesystem::path& file, std::int64_t offset);
  void Write(const ContactFrame& frame);
  bool IsOpen() const { return file_.IsOpen(); }
  std::int64_t Offset() const { return file_.Offset(); }
  void Close() { file_.Close(); }

 private:
  GsdFile file_;
};

// The same for contacts.gsd (kGsdContactEntries entries per frame with contacts).
std::int64_t GsdContactBytes(const ContactFrame& frame);
inline constexpr int kGsdContactEntries = 9;

class GsdContactReader {
 public:
  explicit GsdContactReader(const std::filesystem::path& file);
  bool NextHeader(ContactFrame& frame);
  bool ReadContacts(ContactFrame& frame);
  bool SkipContacts();

 private:
  GsdReader file_;
  std::uint64_t next_ = 0;
  bool pending_ = false;
  double centre_[2] = {0, 0};
};

}  // namespace gsd
}  // namespace granary::rundir

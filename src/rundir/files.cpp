#include "rundir/files.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cerrno>
#include <cstring>
#include <deque>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace granary {

namespace {

// fsync of an open path; directories are opened read-only.
void SyncPath(const std::filesystem::path& path, bool directory) {
  const int fd = ::open(path.c_str(), (directory ? O_RDONLY | O_DIRECTORY : O_WRONLY) | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error("cannot open " + path.string() + " to sync it: " + std::strerror(errno));
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0) throw std::runtime_error("fsync failed on " + path.string() + ": " + std::strerror(err));
}

std::filesystem::path DirectoryOf(const std::filesystem::path& file) {
  return file.parent_path().empty() ? std::filesystem::path(".") : file.parent_path();
}

}  // namespace

void ReplaceAtomically(const std::filesystem::path& tmp, const std::filesystem::path& file) {
  SyncPath(tmp, false);
  std::filesystem::rename(tmp, file);
  SyncPath(DirectoryOf(file), true);
}

int RemoveStaleTemporaries(const std::filesystem::path& dir, double min_age_s) {
  int removed = 0;
  std::error_code ec;
  const auto now = std::filesystem::file_time_type::clock::now();
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const std::size_t at = name.rfind(".tmp.");
    if (at == std::string::npos || at + 5 >= name.size()) continue;
    const std::string digits = name.substr(at + 5);
    if (digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9) continue;
    const pid_t pid = static_cast<pid_t>(std::stol(digits));
    if (pid <= 0 || pid == ::getpid() || ::kill(pid, 0) == 0 || errno != ESRCH) continue;  // alive (or not ours to ask)
    std::error_code stat_error;
    const auto mtime = std::filesystem::last_write_time(it->path(), stat_error);
    if (stat_error || std::chrono::duration<double>(now - mtime).count() < min_age_s) continue;
    if (std::filesystem::remove(it->path(), stat_error)) ++removed;
  }
  return removed;
}

void WriteAtomically(const std::filesystem::path& file, const std::string& text, Durability durability) {
  const std::filesystem::path tmp = file.string() + ".tmp." + std::to_string(::getpid());
  // POSIX calls, so that a failure says why (ENOSPC: "No space left on device").
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot write " + tmp.string() + ": " + std::strerror(errno));
  const auto fail = [&](int err) {
    ::close(fd);
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot write " + file.string() + ": " + std::strerror(err));
  };
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) fail(n < 0 ? errno : ENOSPC);
    done += static_cast<std::size_t>(n);
  }
  // The data reaches the disk before the rename makes it visible, and the rename itself is
  // made durable: on a shared file system another node may read the file next.
  if (durability == Durability::kDurable && ::fsync(fd) != 0) fail(errno);
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot write " + file.string() + ": " + std::strerror(err));
  }
  std::filesystem::rename(tmp, file);
  if (durability == Durability::kDurable) SyncPath(DirectoryOf(file), true);
}

OutputFile::OutputFile(const std::filesystem::path& path) : path_(path), file_(std::fopen(path.c_str(), "wb")) {
  if (!file_) throw std::runtime_error("cannot open " + path.string() + " for writing");
}

OutputFile::OutputFile(const std::filesystem::path& path, std::int64_t offset) : path_(path) {
  if (std::filesystem::exists(path)) {
    std::filesystem::resize_file(path, static_cast<std::uintmax_t>(offset));
    file_ = std::fopen(path.c_str(), "ab");
  } else {
    file_ = std::fopen(path.c_str(), "wb");
  }
  if (!file_) throw std::runtime_error("cannot open " + path.string() + " for writing");
}

OutputFile::~OutputFile() {
  if (file_) std::fclose(file_);
}

OutputFile::OutputFile(OutputFile&& other) noexcept
    : path_(std::move(other.path_)), file_(std::exchange(other.file_, nullptr)) {}

OutputFile& OutputFile::operator=(OutputFile&& other) noexcept {
  std::swap(file_, other.file_);
  std::swap(path_, other.path_);
  return *this;
}

std::int64_t OutputFile::Offset() {
  if (!file_) return 0;
  // A failed write must end the run, not leave a silently short file behind a checkpoint.
  if (std::fflush(file_) != 0 || std::ferror(file_))
    throw std::runtime_error("cannot write " + path_.string() + ": " + std::strerror(errno));
  return std::ftell(file_);
}

void OutputFile::Close() {
  if (!file_) return;
  const bool failed = std::fflush(file_) != 0 || std::ferror(file_) != 0;
  const int error = errno;
  const bool close_failed = std::fclose(file_) != 0;
  file_ = nullptr;
  if (failed || close_failed)
    throw std::runtime_error("cannot write " + path_.string() + ": " + std::strerror(failed ? error : errno));
}

std::string ReadWholeFile(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + file.string());
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string TailOfFile(const std::filesystem::path& file, int lines) {
  std::ifstream in(file);
  if (!in) return "";
  std::deque<std::string> last;
  std::string line;
  while (std::getline(in, line)) {
    last.push_back(line);
    if (static_cast<int>(last.size()) > lines) last.pop_front();
  }
  std::string out;
  for (const auto& l : last) out += l + "\n";
  return out;
}

FileLock::FileLock(const std::filesystem::path& path) : fd_(::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644)) {
  if (fd_ < 0) throw std::runtime_error("cannot open lock file " + path.string());
  if (::flock(fd_, LOCK_EX) != 0) {
    ::close(fd_);
    throw std::runtime_error("cannot lock " + path.string());
  }
}

FileLock::FileLock(const std::filesystem::path& path, const std::function<void()>& on_wait)
    : fd_(::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644)) {
  if (fd_ < 0) throw std::runtime_error("cannot open lock file " + path.string() + ": " + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) == 0) return;
  if (on_wait) on_wait();
  if (::flock(fd_, LOCK_EX) != 0) {
    ::close(fd_);
    throw std::runtime_error("cannot lock " + path.string());
  }
}

FileLock::~FileLock() {
  ::flock(fd_, LOCK_UN);
  ::close(fd_);
}

}  // namespace granary

namespace granary {

namespace {

constexpr char kLockFile[] = "engine.lock";
constexpr char kHelpersLockFile[] = "engine.lock.helpers";

// Whether an exclusive flock on `path` could be taken now (then it is released at once).
bool CanLockExclusively(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return true;  // no lock file: nobody holds it
  const bool free = ::flock(fd, LOCK_EX | LOCK_NB) == 0;
  ::close(fd);
  return free;
}

std::string HolderText(const std::filesystem::path& dir) {
  std::ifstream in(dir / kLockFile);
  std::string who;
  std::getline(in, who);
  return who.empty() ? "another engine" : who;
}

std::string ThisProcess() {
  char host[256] = {0};
  ::gethostname(host, sizeof host - 1);
  return "engine pid " + std::to_string(::getpid()) + " on " + host;
}

}  // namespace

RunDirectoryLock::RunDirectoryLock(const std::filesystem::path& dir) {
  const std::filesystem::path file = dir / kLockFile;
  // Not close-on-exec: what the engine starts (mpirun) holds the lock with it.
  fd_ = ::open(file.c_str(), O_RDWR | O_CREAT, 0644);
  if (fd_ < 0) throw std::runtime_error("cannot open " + file.string() + ": " + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd_);
    fd_ = -1;
    throw RunDirectoryBusy("run directory " + dir.string() + " is locked by " + HolderText(dir) + " (" + file.string() +
                           "); two engines never write one directory");
  }
  if (!CanLockExclusively(dir / kHelpersLockFile)) {
    ::close(fd_);
    fd_ = -1;
    throw RunDirectoryBusy("run directory " + dir.string() + " still has helper processes of an earlier engine (" +
                           (dir / kHelpersLockFile).string() + " is held, e.g. MPI ranks winding down)");
  }
  // This engine writes here now: what a killed one left half-written goes.
  RemoveStaleTemporaries(dir);
  const std::string who = ThisProcess() + "\n";
  if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, who.data(), who.size(), 0) != static_cast<ssize_t>(who.size())) {
    // The lock holds without the note; only the busy message is less precise.
  }
}

RunDirectoryLock::~RunDirectoryLock() {
  if (fd_ >= 0) ::close(fd_);  // closing the last descriptor releases the flock
}

std::string RunDirectoryHolder(const std::filesystem::path& dir) {
  if (!CanLockExclusively(dir / kLockFile)) return HolderText(dir);
  if (!CanLockExclusively(dir / kHelpersLockFile)) return "helper processes of an earlier engine (MPI ranks)";
  return "";
}

void HoldRunDirectoryAsHelper(const std::filesystem::path& dir) {
  const std::filesystem::path file = dir / kHelpersLockFile;
  const int fd = ::open(file.c_str(), O_RDWR | O_CREAT, 0644);  // kept across exec
  if (fd < 0) throw std::runtime_error("cannot open " + file.string() + ": " + std::strerror(errno));
  if (::flock(fd, LOCK_SH) != 0) throw std::runtime_error("cannot lock " + file.string() + ": " + std::strerror(errno));
}

std::string SignalName(int signal) {
  const char* name = ::strsignal(signal);
  return "signal " + std::to_string(signal) + (name ? std::string(" (") + name + ")" : std::string());
}

std::uint32_t Crc32(std::string_view data, std::uint32_t crc) {
  static const std::array<std::uint32_t, 256> kTable = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t n = 0; n < 256; ++n) {
      std::uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  crc = ~crc;
  for (const unsigned char ch : data) crc = kTable[(crc ^ ch) & 0xFFu] ^ (crc >> 8);
  return ~crc;
}

}  // namespace granary

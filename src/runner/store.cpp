// SQLite ownership and migrations; see store.h.
#include "runner/store.h"

#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "runner/migrations_sql.h"

namespace granary::runner {

namespace {

// What SQLite's words leave out of a storage fault: a full file system ("disk I/O error" is
// also what a write into a full WAL says) and where it is, or a read-only one.
std::string StorageNote(sqlite3* db, int code, const std::string& fallback_path) {
  const int primary = code & 0xff;
  if (primary != SQLITE_IOERR && primary != SQLITE_FULL && primary != SQLITE_CANTOPEN && primary != SQLITE_READONLY)
    return "";
  const char* file = db ? sqlite3_db_filename(db, "main") : nullptr;
  std::filesystem::path path = file && *file ? std::filesystem::path(file) : std::filesystem::path(fallback_path);
  std::filesystem::path dir = path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
  struct statvfs st {};
  if (::statvfs(dir.c_str(), &st) == 0) {
    const double free_bytes = static_cast<double>(st.f_bavail) * static_cast<double>(st.f_frsize);
    if ((primary == SQLITE_IOERR || primary == SQLITE_FULL) && free_bytes < (1 << 20))
      return "; the file system of " + dir.string() + " is full (" +
             std::to_string(static_cast<long long>(free_bytes / 1024)) + " KiB free)";
  }
  if (::access(dir.c_str(), W_OK) != 0 && (errno == EROFS || errno == EACCES))
    return "; " + dir.string() + " is read-only (" + std::strerror(errno) +
           "): SQLite writes its journal beside the database; campaign status, show, report and export work read-only";
  return "";
}

[[noreturn]] void Fail(sqlite3* db, int code, const std::string& what, const std::string& path = "") {
  throw StoreError(code, what + ": " + (db ? sqlite3_errmsg(db) : sqlite3_errstr(code)) + " (SQLite code " +
                             std::to_string(code) + ")" + StorageNote(db, code, path));
}

}  // namespace

const std::vector<std::string>& Migrations() {
  static const std::vector<std::string> kMigrations = EmbeddedMigrations();
  return kMigrations;
}

Statement::Statement(sqlite3* db, const char* sql) : db_(db) {
  sqlite3_stmt* raw = nullptr;
  const int rc = sqlite3_prepare_v2(db, sql, -1, &raw, nullptr);
  if (rc != SQLITE_OK) Fail(db, rc, std::string("preparing \"") + sql + "\"");
  stmt_.reset(raw);
}

Statement& Statement::Bind(int index, const std::string& value) {
  const int rc = sqlite3_bind_text(stmt_.get(), index, value.data(), static_cast<int>(value.size()), SQLITE_TRANSIENT);
  if (rc != SQLITE_OK) Fail(db_, rc, "binding parameter " + std::to_string(index));
  return *this;
}
Statement& Statement::Bind(int index, const char* value) { return Bind(index, std::string(value)); }
Statement& Statement::Bind(int index, double value) {
  const int rc = sqlite3_bind_double(stmt_.get(), index, value);
  if (rc != SQLITE_OK) Fail(db_, rc, "binding parameter " + std::to_string(index));
  return *this;
}
Statement& Statement::Bind(int index, std::int64_t value) {
  const int rc = sqlite3_bind_int64(stmt_.get(), index, value);
  if (rc != SQLITE_OK) Fail(db_, rc, "binding parameter " + std::to_string(index));
  return *this;
}
Statement& Statement::BindNull(int index) {
  const int rc = sqlite3_bind_null(stmt_.get(), index);
  if (rc != SQLITE_OK) Fail(db_, rc, "binding parameter " + std::to_string(index));
  return *this;
}
Statement& Statement::Bind(int index, const std::optional<std::string>& value) {
  return value ? Bind(index, *value) : BindNull(index);
}

bool Statement::Step() {
  const int rc = sqlite3_step(stmt_.get());
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  Fail(db_, rc, std::string("executing \"") + sqlite3_sql(stmt_.get()) + "\"");
}
void Statement::Run() {
  while (Step()) {
  }
}
void Statement::Reset() {
  sqlite3_reset(stmt_.get());
  sqlite3_clear_bindings(stmt_.get());
}
bool Statement::IsNull(int col) const { return sqlite3_column_type(stmt_.get(), col) == SQLITE_NULL; }
std::string Statement::Text(int col) const {
  const unsigned char* p = sqlite3_column_text(stmt_.get(), col);
  if (!p) return "";
  return std::string(reinterpret_cast<const char*>(p),
                     static_cast<std::size_t>(sqlite3_column_bytes(stmt_.get(), col)));
}
double Statement::Real(int col) const { return sqlite3_column_double(stmt_.get(), col); }
std::int64_t Statement::Integer(int col) const { return sqlite3_column_int64(stmt_.get(), col); }

Store::Store(const std::string& path, int upto_version) : path_(path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw StoreError(SQLITE_CANTOPEN, path + " is a directory, not a campaign database (give the file, e.g. " +
                                          (std::filesystem::path(path) / "granary.db").string() + ")");
  sqlite3* raw = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &raw, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
  db_.reset(raw);
  if (rc != SQLITE_OK) Fail(raw, rc, "opening database " + path, path);
  // Several runners may share one database: wait for locks instead of failing at once.
  sqlite3_busy_timeout(db_.get(), 30000);
  // The first read of the file: anything but an SQLite database fails here. Say so plainly.
  if (sqlite3_exec(db_.get(), "PRAGMA schema_version", nullptr, nullptr, nullptr) == SQLITE_NOTADB)
    throw StoreError(SQLITE_NOTADB, path +
                                        " is not a campaign database (not an SQLite file; campaign plan SPEC --db "
                                        "FILE makes one)");
  if (SchemaVersion() == 0) {
    // An SQLite file of something else: never add our tables to it.
    Statement t = Prepare("SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name");
    std::string tables;
    while (t.Step()) tables += (tables.empty() ? "" : ", ") + t.Text(0);
    if (!tables.empty())
      throw StoreError(SQLITE_NOTADB, path + " is an SQLite database but not a campaign database (it has the tables " +
                                          tables + "); give another --db");
  }
  Exec("PRAGMA journal_mode = WAL");
  Exec("PRAGMA synchronous = NORMAL");
  Exec("PRAGMA foreign_keys = ON");

  const int newest = static_cast<int>(Migrations().size());
  const int target = upto_version < 0 ? newest : std::min(upto_version, newest);
  Transaction tx(*this);
  int version = SchemaVersion();
  if (version > newest) {
    throw StoreError(SQLITE_ERROR, "database " + path + " has schema version " + std::to_string(version) +
                                       ", newer than this granary supports (" + std::to_string(newest) +
                                       "); use a newer campaign binary");
  }
  // Ordered chain: each step runs inside the one transaction, so a failed migration
  // leaves the database as it was.
  while (version < target) {
    Exec(Migrations()[static_cast<std::size_t>(version)]);
    ++version;
    Exec("PRAGMA user_version = " + std::to_string(version));
  }
  tx.Commit();
}

Store::Store(const std::string& path, ReadOnly) : path_(path), read_only_(true) {
  sqlite3* raw = nullptr;
  int rc = sqlite3_open_v2(path.c_str(), &raw, SQLITE_OPEN_READONLY, nullptr);
  db_.reset(raw);
  if (rc != SQLITE_OK) Fail(raw, rc, "opening database " + path, path);
  sqlite3_busy_timeout(db_.get(), 1000);
  // A database in WAL mode in a directory nobody may write (a read-only mount, a shared
  // archive): SQLite cannot make the shared-memory file it reads through, so the file is read
  // as it is, unlocked (immutable); whatever a -wal file beside it holds is not seen.
  if (sqlite3_exec(db_.get(), "PRAGMA schema_version", nullptr, nullptr, nullptr) == SQLITE_CANTOPEN) {
    db_.reset();
    raw = nullptr;
    const std::string uri = "file:" + std::filesystem::absolute(path).string() + "?immutable=1";
    rc = sqlite3_open_v2(uri.c_str(), &raw, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
    db_.reset(raw);
    if (rc != SQLITE_OK) Fail(raw, rc, "opening database " + path + " read-only", path);
  }
  if (SchemaVersion() > static_cast<int>(Migrations().size()))
    throw StoreError(SQLITE_ERROR, "database " + path + " is newer than this granary");
}

void Store::Exec(const std::string& sql) {
  char* err = nullptr;
  const int rc = sqlite3_exec(db_.get(), sql.c_str(), nullptr, nullptr, &err);
  if (rc != SQLITE_OK) {
    const std::string msg = err ? err : sqlite3_errstr(rc);
    sqlite3_free(err);
    throw StoreError(rc, "executing \"" + sql.substr(0, 60) + "\": " + msg + " (SQLite code " + std::to_string(rc) +
                             ")" + StorageNote(db_.get(), rc, path_));
  }
}

int Store::SchemaVersion() {
  Statement s = Prepare("PRAGMA user_version");
  s.Step();
  return static_cast<int>(s.Integer(0));
}

Transaction::Transaction(Store& store, bool immediate) : store_(store) {
  store_.Exec(immediate ? "BEGIN IMMEDIATE" : "BEGIN");
}

Transaction::~Transaction() {
  if (!done_) sqlite3_exec(store_.Handle(), "ROLLBACK", nullptr, nullptr, nullptr);  // never throws
}

void Transaction::Commit() {
  store_.Exec("COMMIT");
  done_ = true;
}

}  // namespace granary::runner

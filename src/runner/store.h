// Store: the one owner of a campaign's SQLite database. RAII handle
// and statements, a Transaction that rolls back unless committed, one exception type that
// carries the SQLite result code, and versioned migrations (db/NNN_*.sql, embedded at build
// time) applied on open. A database newer than this binary is refused.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace granary::runner {

class StoreError : public std::runtime_error {
 public:
  StoreError(int code, const std::string& message) : std::runtime_error(message), code_(code) {}
  int Code() const { return code_; }

 private:
  int code_;
};

// The migrations compiled in: Migrations()[i] takes the schema from version i to i + 1.
const std::vector<std::string>& Migrations();

class Statement {
 public:
  Statement(sqlite3* db, const char* sql);
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& Bind(int index, const std::string& value);
  Statement& Bind(int index, const char* value);
  Statement& Bind(int index, double value);
  Statement& Bind(int index, std::int64_t value);
  Statement& Bind(int index, int value) { return Bind(index, static_cast<std::int64_t>(value)); }
  Statement& BindNull(int index);
  Statement& Bind(int index, const std::optional<std::string>& value);

  bool Step();  // true while a row is available
  void Run();   // step to completion
  void Reset();

  bool IsNull(int col) const;
  std::string Text(int col) const;  // "" for NULL
  double Real(int col) const;
  std::int64_t Integer(int col) const;

 private:
  struct Finalizer {
    void operator()(sqlite3_stmt* s) const { sqlite3_finalize(s); }
  };
  sqlite3* db_;
  std::unique_ptr<sqlite3_stmt, Finalizer> stmt_;
};

class Store {
 public:
  // Opens (creating if missing) and migrates to the newest schema. `upto_version` stops the
  // migrations early (tests build an old database with it).
  explicit Store(const std::string& path, int upto_version = -1);
  // An existing database opened read-only, as it is: no migration, no journal change (shell
  // completion reads run ids while a runner writes). Throws StoreError if it cannot be read.
  struct ReadOnly {};
  Store(const std::string& path, ReadOnly);
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  void Exec(const std::string& sql);
  Statement Prepare(const char* sql) { return Statement(db_.get(), sql); }
  int SchemaVersion();
  sqlite3* Handle() { return db_.get(); }
  const std::string& Path() const { return path_; }
  bool IsReadOnly() const { return read_only_; }

 private:
  struct Closer {
    void operator()(sqlite3* db) const { sqlite3_close(db); }
  };
  std::string path_;
  bool read_only_ = false;
  std::unique_ptr<sqlite3, Closer> db_;
};

// BEGIN [IMMEDIATE] ... COMMIT; rolls back in the destructor unless Commit() was called.
class Transaction {
 public:
  explicit Transaction(Store& store, bool immediate = true);
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  ~Transaction();
  void Commit();

 private:
  Store& store_;
  bool done_ = false;
};

}  // namespace granary::runner

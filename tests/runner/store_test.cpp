// Tests of the Store: migrations on open, upgrading an old schema without losing rows,
// refusing a too-new database, and transactions that roll back unless committed.
#include "runner/store.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "test_util.h"

namespace granary::runner {
namespace {

TEST(StoreTest, NewDatabaseHasNewestSchema) {
  Store store(":memory:");
  EXPECT_EQ(store.SchemaVersion(), static_cast<int>(Migrations().size()));
  EXPECT_GE(Migrations().size(), 2u);
  Statement q = store.Prepare("SELECT COUNT(*) FROM runs");
  ASSERT_TRUE(q.Step());
  EXPECT_EQ(q.Integer(0), 0);
}

TEST(StoreTest, MigratesAnOldDatabaseKeepingRows) {
  const auto dir = testing::MakeTempDir();
  const std::string path = (dir / "old.db").string();
  {
    Store v1(path, 1);
    ASSERT_EQ(v1.SchemaVersion(), 1);
    v1.Exec(
        "INSERT INTO runs (run_id, seq, point_id, point, replica, params, state, engine, run_dir) "
        "VALUES ('r1', 0, 'p', '{}', 0, '{}', 'done', 'native', '/x')");
    EXPECT_THROW(v1.Exec("SELECT summary FROM runs"), StoreError);  // not yet in version 1
  }
  Store v2(path);
  EXPECT_EQ(v2.SchemaVersion(), static_cast<int>(Migrations().size()));
  Statement q = v2.Prepare("SELECT run_id, state, summary, job_array FROM runs");
  ASSERT_TRUE(q.Step());
  EXPECT_EQ(q.Text(0), "r1");
  EXPECT_EQ(q.Text(1), "done");
  EXPECT_TRUE(q.IsNull(2));
  EXPECT_TRUE(q.IsNull(3));  // never queued
  std::filesystem::remove_all(dir);
}

TEST(StoreTest, RefusesTooNewDatabase) {
  const auto dir = testing::MakeTempDir();
  const std::string path = (dir / "new.db").string();
  {
    Store s(path);
    s.Exec("PRAGMA user_version = 99");
  }
  try {
    Store s(path);
    FAIL() << "opened a too-new database";
  } catch (const StoreError& e) {
    EXPECT_EQ(std::string(e.what()), "database " + path + " has schema version 99, newer than this granary supports (" +
                                         std::to_string(Migrations().size()) +
                                         "); use a newer "
                                         "campaign binary");
  }
  std::filesystem::remove_all(dir);
}

TEST(StoreTest, TransactionRollsBackUnlessCommitted) {
  Store store(":memory:");
  store.Exec("CREATE TABLE t (x INTEGER NOT NULL)");
  {
    Transaction tx(store);
    store.Exec("INSERT INTO t VALUES (1)");
  }
  {
    Transaction tx(store);
    store.Exec("INSERT INTO t VALUES (2)");
    tx.Commit();
  }
  Statement q = store.Prepare("SELECT COUNT(*), SUM(x) FROM t");
  ASSERT_TRUE(q.Step());
  EXPECT_EQ(q.Integer(0), 1);
  EXPECT_EQ(q.Integer(1), 2);
}

TEST(StoreTest, ErrorsCarryTheSqliteCode) {
  Store store(":memory:");
  try {
    store.Exec("INSERT INTO runs (run_id) VALUES ('x')");
    FAIL();
  } catch (const StoreError& e) {
    EXPECT_EQ(e.Code(), SQLITE_CONSTRAINT);
  }
}

}  // namespace
}  // namespace granary::runner

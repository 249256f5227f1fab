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
  EXPECT_EQ(store.schema_version(), static_cast<int>(migrations().size()));
  EXPECT_GE(migrations().size(), 2u);
  Statement q = store.prepare("SELECT COUNT(*) FROM runs");
  ASSERT_TRUE(q.step());
  EXPECT_EQ(q.integer(0), 0);
}

TEST(StoreTest, MigratesAnOldDatabaseKeepingRows) {
  const auto dir = testing::MakeTempDir();
  const std::string path = (dir / "old.db").string();
  {
    Store v1(path, 1);
    ASSERT_EQ(v1.schema_version(), 1);
    v1.exec("INSERT INTO runs (run_id, seq, point_id, point, replica, params, state, engine, run_dir) "
            "VALUES ('r1', 0, 'p', '{}', 0, '{}', 'done', 'native', '/x')");
    EXPECT_THROW(v1.exec("SELECT summary FROM runs"), StoreError);  // not yet in version 1
  }
  Store v2(path);
  EXPECT_EQ(v2.schema_version(), static_cast<int>(migrations().size()));
  Statement q = v2.prepare("SELECT run_id, state, summary, job_array FROM runs");
  ASSERT_TRUE(q.step());
  EXPECT_EQ(q.text(0), "r1");
  EXPECT_EQ(q.text(1), "done");
  EXPECT_TRUE(q.is_null(2));
  EXPECT_TRUE(q.is_null(3));  // never queued
  std::filesystem::remove_all(dir);
}

TEST(StoreTest, RefusesTooNewDatabase) {
  const auto dir = testing::MakeTempDir();
  const std::string path = (dir / "new.db").string();
  {
    Store s(path);
    s.exec("PRAGMA user_version = 99");
  }
  try {
    Store s(path);
    FAIL() << "opened a too-new database";
  } catch (const StoreError& e) {
    EXPECT_EQ(std::string(e.what()), "database " + path +
                                         " has schema version 99, newer than this granary supports (" +
                                         std::to_string(migrations().size()) + "); use a newer "
                                         "campaign binary");
  }
  std::filesystem::remove_all(dir);
}

TEST(StoreTest, TransactionRollsBackUnlessCommitted) {
  Store store(":memory:");
  store.exec("CREATE TABLE t (x INTEGER NOT NULL)");
  {
    Transaction tx(store);
    store.exec("INSERT INTO t VALUES (1)");
  }
  {
    Transaction tx(store);
    store.exec("INSERT INTO t VALUES (2)");
    tx.commit();
  }
  Statement q = store.prepare("SELECT COUNT(*), SUM(x) FROM t");
  ASSERT_TRUE(q.step());
  EXPECT_EQ(q.integer(0), 1);
  EXPECT_EQ(q.integer(1), 2);
}

TEST(StoreTest, ErrorsCarryTheSqliteCode) {
  Store store(":memory:");
  try {
    store.exec("INSERT INTO runs (run_id) VALUES ('x')");
    FAIL();
  } catch (const StoreError& e) {
    EXPECT_EQ(e.code(), SQLITE_CONSTRAINT);
  }
}

}  // namespace
}  // namespace granary::runner

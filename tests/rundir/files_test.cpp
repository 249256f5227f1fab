// files.h: the temporary files of killed writers (NAME.tmp.PID) are removed when their
// process is gone and they are old enough; a live writer's and a fresh one are kept.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "rundir/files.h"
#include "test_util.h"

namespace granary {
namespace {

namespace fs = std::filesystem;
using analysis::testing::TempDir;
using analysis::testing::WriteFile;

pid_t DeadPid() {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(0);
  ::waitpid(pid, nullptr, 0);
  return pid;
}

TEST(StaleTemporaries, OnlyOldFilesOfDeadProcessesAreRemoved) {
  TempDir t;
  const std::string dead = std::to_string(DeadPid());
  const std::string alive = std::to_string(::getppid());
  const auto old = fs::file_time_type::clock::now() - std::chrono::hours(1);
  for (const std::string& name :
       std::vector<std::string>{"flow.json.tmp." + dead, "progress.json.tmp." + dead, "fresh.json.tmp." + dead,
                                "live.json.tmp." + alive, "notmine.tmp.x12", "flow.json"}) {
    WriteFile(t.Path() / name, "{");
    if (name.rfind("fresh", 0) != 0) fs::last_write_time(t.Path() / name, old);
  }
  EXPECT_EQ(RemoveStaleTemporaries(t.Path()), 2);
  EXPECT_FALSE(fs::exists(t.Path() / ("flow.json.tmp." + dead)));
  EXPECT_FALSE(fs::exists(t.Path() / ("progress.json.tmp." + dead)));
  for (const std::string& name :
       std::vector<std::string>{"fresh.json.tmp." + dead, "live.json.tmp." + alive, "notmine.tmp.x12", "flow.json"})
    EXPECT_TRUE(fs::exists(t.Path() / name)) << name;
  EXPECT_EQ(RemoveStaleTemporaries(t.Path() / "missing"), 0);
  // An engine taking the run directory's lock clears it too.
  WriteFile(t.Path() / ("events.csv.tmp." + dead), "time");
  fs::last_write_time(t.Path() / ("events.csv.tmp." + dead), old);
  { RunDirectoryLock lock(t.Path()); }
  EXPECT_FALSE(fs::exists(t.Path() / ("events.csv.tmp." + dead)));
}

}  // namespace
}  // namespace granary

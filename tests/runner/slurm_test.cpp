// Tests against a real one-node Slurm (slurm_cluster.h): the cluster itself, then campaigns
// submitted as job arrays by `campaign run --executor slurm`.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>

#include "slurm_cluster.h"
#include "test_util.h"

namespace granary::runner {
namespace {

namespace fs = std::filesystem;
using testing::ReadFile;
using testing::Sh;
using testing::SlurmCluster;
using testing::WaitFor;

TEST(SlurmClusterTest, RunsAnArrayAndReportsAFailedTask) {
  SlurmCluster cluster;
  const fs::path dir = testing::MakeTempDir();
  const fs::path script = dir / "task.sh";
  std::ofstream(script) << "#!/bin/bash\necho \"$SLURM_ARRAY_TASK_ID\" > " << dir.string()
                        << "/out.$SLURM_ARRAY_TASK_ID\nexit $((SLURM_ARRAY_TASK_ID == 2 ? 7 : 0))\n";
  const auto submitted = Sh("sbatch --parsable --array=0-2%2 -o /dev/null " + script.string());
  ASSERT_EQ(submitted.code, 0) << submitted.output << cluster.log_tails();
  const std::string job = submitted.output.substr(0, submitted.output.find_first_of(";\n"));
  const auto states = [&] { return Sh("squeue -h -r -t all -j " + job + " -o '%i %T' | sort").output; };
  EXPECT_TRUE(WaitFor([&] { return states() == job + "_0 COMPLETED\n" + job + "_1 COMPLETED\n" + job + "_2 FAILED\n"; }, 60))
      << states() << cluster.log_tails();
  for (int i = 0; i < 3; ++i) EXPECT_EQ(ReadFile(dir / ("out." + std::to_string(i))), std::to_string(i) + "\n");
  EXPECT_NE(Sh("scontrol show job " + job + "_2").output.find("ExitCode=7:0"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace granary::runner

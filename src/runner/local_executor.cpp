// The local executor: a pool of engine subprocesses through Boost.Process (executor.h).
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <boost/process.hpp>
#include <boost/process/extend.hpp>
#include <chrono>
#include <filesystem>
#include <map>
#include <optional>
#include <stdexcept>

#include "rundir/files.h"
#include "runner/executor.h"
#include "runner/executors.h"

namespace granary::runner {

namespace bp = boost::process;

namespace {

// Runs in the child between fork and exec: log redirection and parent-death signal.
struct ChildSetup : bp::extend::handler {
  int log_fd = -1;
  template <class Executor>
  void on_exec_setup(Executor&) const {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (log_fd >= 0) {
      dup2(log_fd, 1);
      dup2(log_fd, 2);
      close(log_fd);
    }
    // Own process group: a terminal's Ctrl-C reaches the runner only, which forwards it.
    setpgid(0, 0);
  }
};

using Clock = std::chrono::steady_clock;

// The engine's log, open for reading from its start: if its run directory is deleted while
// it runs, the log's name is gone but not its content, and the engine's last words (the
// error it died of) can still be told.
class KeptLog {
 public:
  KeptLog() = default;
  KeptLog(const std::string& file) : file_(file), fd_(open(file.c_str(), O_RDONLY | O_CLOEXEC)) {}  // NOLINT
  KeptLog(KeptLog&& o) noexcept : file_(std::move(o.file_)), fd_(std::exchange(o.fd_, -1)) {}
  KeptLog& operator=(KeptLog&& o) noexcept {
    std::swap(file_, o.file_);
    std::swap(fd_, o.fd_);
    return *this;
  }
  ~KeptLog() {
    if (fd_ >= 0) close(fd_);
  }
  // "" while the log is where it was; else its last lines, read through the kept descriptor.
  std::string TailIfDeleted(int lines) const {
    std::error_code ec;
    if (fd_ < 0 || std::filesystem::exists(file_, ec)) return "";
    struct stat st {};
    if (fstat(fd_, &st) != 0) return "";
    constexpr off_t kMaxBytes = 16384;
    const off_t from = st.st_size > kMaxBytes ? st.st_size - kMaxBytes : 0;
    std::string text(static_cast<std::size_t>(st.st_size - from), '\0');
    const ssize_t n = pread(fd_, text.data(), text.size(), from);
    text.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
    std::size_t at = text.size();
    for (int k = 0; k <= lines && at != std::string::npos && at > 0; ++k) at = text.rfind('\n', at - 1);
    return at == std::string::npos || at == 0 ? text : text.substr(at + 1);
  }

 private:
  std::string file_;
  int fd_ = -1;
};

class LocalExecutor : public Executor {
 public:
  LocalExecutor(int slots, double grace_seconds) : slots_(slots), grace_(grace_seconds) {}
  ~LocalExecutor() override {
    for (auto& [id, child] : children_) {
      std::error_code ec;
      if (child.process.running(ec)) KillGroup(child.process);
      child.process.wait(ec);
    }
  }

  bool CanStartMore() const override { return static_cast<int>(children_.size()) < slots_; }

  void Start(const Launch& launch) override {
    const int fd = open(launch.log_file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (fd < 0) throw std::runtime_error("run " + launch.run_id + ": cannot open log " + launch.log_file);
    ChildSetup setup;
    setup.log_fd = fd;
    std::vector<std::string> args(launch.argv.begin() + 1, launch.argv.end());
    std::error_code ec;
    // dup2 in the child clears O_CLOEXEC on fds 1 and 2; the original fd closes on exec.
    bp::child child(bp::exe = launch.argv[0], bp::args = args, bp::std_in < bp::null, setup, ec);
    close(fd);
    if (ec) {
      throw std::runtime_error("run " + launch.run_id + ": cannot start " + launch.argv[0] + ": " + ec.message());
    }
    children_.emplace(launch.run_id, Child{std::move(child), {}, KeptLog(launch.log_file), launch.run_dir});
  }

  std::vector<Finished> Poll() override {
    std::vector<Finished> out;
    const auto now = Clock::now();
    for (auto it = children_.begin(); it != children_.end();) {
      std::error_code ec;
      if (it->second.process.running(ec)) {
        if (it->second.kill_at && now >= *it->second.kill_at) {
          KillGroup(it->second.process);
          it->second.kill_at.reset();
        }
        ++it;
        continue;
      }
      Finished f;
      f.run_id = it->first;
      const int status = it->second.process.native_exit_code();
      if (WIFSIGNALED(status))
        f.signal = WTERMSIG(status);
      else
        f.exit_code = WEXITSTATUS(status);
      if (const std::string said = it->second.log.TailIfDeleted(20);
          !said.empty() || !std::filesystem::exists(it->second.run_dir, ec))
        f.how = std::string(f.signal != 0 ? "engine killed by " + SignalName(f.signal)
                                          : "engine exited with status " + std::to_string(f.exit_code)) +
                "; its run directory " + it->second.run_dir + " was deleted while it ran" +
                (said.empty() ? std::string(" (its log is gone with it)") : "; it last said:\n" + said);
      out.push_back(f);
      it = children_.erase(it);
    }
    return out;
  }

  void Stop(const std::string& run_id, StopReason reason) override {
    auto it = children_.find(run_id);
    if (it != children_.end()) Stop(it->second, reason);
  }
  void StopAll(StopReason reason) override {
    for (auto& [id, child] : children_) Stop(child, reason);
  }
  std::size_t Active() const override { return children_.size(); }

 private:
  struct Child {
    bp::child process;
    std::optional<Clock::time_point> kill_at;  // SIGKILL to the group then (a stop's grace period)
    KeptLog log;
    std::string run_dir;
  };
  // The engine's whole process group: a LIGGGHTS wrapper's mpirun and ranks too.
  static void KillGroup(bp::child& c) {
    kill(-c.id(), SIGKILL);
    kill(c.id(), SIGKILL);  // also before the child has made its group (setpgid after fork)
  }

  void Stop(Child& c, StopReason reason) {
    if (reason == StopReason::kLeaseLost) {
      KillGroup(c.process);
      c.kill_at.reset();
      return;
    }
    // The engine alone: it checkpoints, then ends what it started itself.
    kill(c.process.id(), SIGTERM);
    const auto deadline =
        Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(grace_));
    if (!c.kill_at || deadline < *c.kill_at) c.kill_at = deadline;
  }

  int slots_;
  double grace_;
  std::map<std::string, Child> children_;
};

}  // namespace

bool IsQueuedOrRunning(TaskFate fate) { return fate == TaskFate::kQueued || fate == TaskFate::kRunning; }

const char* ToString(StopReason reason) {
  switch (reason) {
    case StopReason::kInterrupt: return "interrupt";
    case StopReason::kTimeLimit: return "time limit";
    case StopReason::kLeaseLost: return "lease lost";
  }
  return "?";
}

std::unique_ptr<Executor> MakeLocalExecutor(int slots, double grace_seconds) {
  return std::make_unique<LocalExecutor>(slots, grace_seconds);
}

namespace {

class LocalSetup : public ExecutorSetup {
 public:
  std::unique_ptr<Executor> Make(const CampaignRunOptions& options) const override {
    return MakeLocalExecutor(options.jobs);
  }
};

}  // namespace

ExecutorRow LocalExecutorRow() {
  return {"local",
          "engines on this machine, --jobs at once",
          {{"jobs", true}, {"threads-per-run", true}},
          "The local pool:\n"
          "  --jobs N             concurrent runs (default: number of cores)\n"
          "  --threads-per-run T  passed to the engine as --threads (default 1)\n",
          [](const cli::Args&, const nlohmann::json*, const std::string&,
             const CampaignRunOptions&) -> std::unique_ptr<ExecutorSetup> { return std::make_unique<LocalSetup>(); }};
}

}  // namespace granary::runner

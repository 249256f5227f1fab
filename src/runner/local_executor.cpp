// The local executor: a pool of engine subprocesses through Boost.Process (executor.h).
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <boost/process.hpp>
#include <boost/process/extend.hpp>
#include <map>
#include <stdexcept>

#include "runner/executor.h"

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

class LocalExecutor : public Executor {
 public:
  explicit LocalExecutor(int slots) : slots_(slots) {}
  ~LocalExecutor() override {
    for (auto& [id, child] : children_) {
      if (child.running()) kill(child.id(), SIGKILL);
      std::error_code ec;
      child.wait(ec);
    }
  }

  bool can_start_more() const override { return static_cast<int>(children_.size()) < slots_; }

  void start(const Launch& launch) override {
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
    children_.emplace(launch.run_id, std::move(child));
  }

  std::vector<Finished> poll() override {
    std::vector<Finished> out;
    for (auto it = children_.begin(); it != children_.end();) {
      std::error_code ec;
      if (it->second.running(ec)) {
        ++it;
        continue;
      }
      Finished f;
      f.run_id = it->first;
      const int status = it->second.native_exit_code();
      if (WIFSIGNALED(status)) f.signal = WTERMSIG(status);
      else f.exit_code = WEXITSTATUS(status);
      out.push_back(f);
      it = children_.erase(it);
    }
    return out;
  }

  void abort(const std::string& run_id, int signal) override {
    auto it = children_.find(run_id);
    if (it != children_.end()) kill(it->second.id(), signal);
  }
  void abort_all(int signal) override {
    for (auto& [id, child] : children_) kill(child.id(), signal);
  }
  std::size_t active() const override { return children_.size(); }

 private:
  int slots_;
  std::map<std::string, bp::child> children_;
};

}  // namespace

std::unique_ptr<Executor> make_local_executor(int slots) { return std::make_unique<LocalExecutor>(slots); }

}  // namespace granary::runner

// The external-engine driver (driver.h).
#include "external/driver.h"

#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>

#include <boost/process.hpp>
#include <boost/process/extend.hpp>

#include "rundir/files.h"

namespace granary::external {

namespace fs = std::filesystem;
namespace bp = boost::process;
using Clock = std::chrono::steady_clock;

namespace {

volatile std::sig_atomic_t g_stop_signal = 0;

double Seconds(Clock::time_point since) { return std::chrono::duration<double>(Clock::now() - since).count(); }

// In the child, before exec: its own process group (ending it ends what it started), and
// SIGKILL when the backend dies.
struct DieWithParent : bp::extend::handler {
  template <class Executor>
  void on_exec_setup(Executor&) const {
    setpgid(0, 0);
    prctl(PR_SET_PDEATHSIG, SIGKILL);
  }
};

std::vector<std::pair<long long, fs::path>> Checkpoints(const fs::path& dir) {
  static const std::regex kName(R"(checkpoint\.(\d+)\.restart)");
  std::vector<std::pair<long long, fs::path>> found;
  for (const auto& e : fs::directory_iterator(dir)) {
    std::smatch m;
    const std::string f = e.path().filename().string();
    if (std::regex_match(f, m, kName)) found.emplace_back(std::stoll(m[1]), e.path());
  }
  std::sort(found.rbegin(), found.rend());
  return found;
}

}  // namespace

void RequestStop(int signal) { g_stop_signal = signal; }
int StopSignal() { return g_stop_signal; }

std::string ChildRun::How(const std::string& what) const {
  if (!stop_reason.empty()) return stop_reason;
  if (signal != 0) return what + " killed by " + SignalName(signal);
  return what + " exit status " + std::to_string(exit_code);
}

std::string Diagnostics(const ChildRun& r, const fs::path& log, const std::string& what) {
  std::string msg;
  for (const std::string& e : r.errors) msg += "\n" + e;
  msg += "\n--- " + what + " screen output, last lines ---\n";
  for (const std::string& l : r.screen) msg += l + "\n";
  if (r.screen.empty()) msg += "(none)\n";
  if (!log.empty()) {
    const std::string tail = TailOfFile(log, kLogTailLines);
    msg += "--- last lines of " + log.filename().string() + " ---\n" + (tail.empty() ? "(empty or missing)\n" : tail);
  }
  return msg;
}

ChildRun RunChild(const std::string& program, const std::vector<std::string>& args, const ChildOptions& o,
                  const std::function<void(const std::string&)>& on_line) {
  bp::pipe out;
  std::error_code ec;
  bp::child child(bp::exe = program, bp::args = args, bp::start_dir = o.dir.string(),
                  bp::std_in<bp::null, (bp::std_out & bp::std_err)> out, DieWithParent{}, ec);
  if (ec) throw std::runtime_error("cannot start " + program + ": " + ec.message());
  ChildRun r;
  const int fd = out.native_source();
  std::string pending;
  char buf[4096];
  auto last_output = Clock::now();
  bool stop_sent = false;
  const auto handle = [&](const std::string& line) {
    r.screen.push_back(line);
    if (r.screen.size() > static_cast<std::size_t>(kLogTailLines)) r.screen.pop_front();
    const bool ours = line.rfind("GRANARY_", 0) == 0;
    if (line.rfind("GRANARY_STOPPED", 0) == 0) r.stopped = true;
    if (!ours && line.find("ERROR") != std::string::npos && r.errors.size() < 5) r.errors.push_back(line);
    on_line(line);
  };
  while (true) {
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, 1000);
    if (ready > 0) {
      const ssize_t n = ::read(fd, buf, sizeof buf);
      if (n == 0) break;  // the child (and every rank) closed its output: it has ended
      if (n > 0) {
        last_output = Clock::now();
        pending.append(buf, static_cast<std::size_t>(n));
        for (std::size_t nl; (nl = pending.find('\n')) != std::string::npos; pending.erase(0, nl + 1))
          handle(pending.substr(0, nl));
      } else if (errno != EINTR) {
        break;
      }
    } else if (ready < 0 && errno != EINTR) {
      break;
    }
    if (g_stop_signal != 0 && !stop_sent) {
      stop_sent = true;
      // Said now: an engine that does not react (hung) is killed by the runner after its
      // grace period, and this is what the run's failure will show.
      std::fprintf(stderr, "%s: %s received; %s so far:%s", o.tag.c_str(), SignalName(g_stop_signal).c_str(),
                   o.what.c_str(), Diagnostics(r, o.log, o.what).c_str());
      if (!o.control.empty()) {
        WriteAtomically(o.control, "variable stop_requested equal 1\n", Durability::kVisible);
        std::fprintf(stderr, "%s: stop requested (%s): %s checkpoints at the end of its chunk\n", o.tag.c_str(),
                     SignalName(g_stop_signal).c_str(), o.what.c_str());
      } else {
        r.stop_reason = "stopped on request (" + SignalName(g_stop_signal) + ")";
        kill(-child.id(), SIGTERM);
      }
      std::fflush(stderr);
    }
    if (o.silence_limit > 0 && Seconds(last_output) > o.silence_limit && r.stop_reason.empty()) {
      r.stop_reason = o.what + " printed nothing for " + std::to_string(static_cast<long long>(o.silence_limit)) +
                      " s and was ended (hung? the limit is --silence-limit)";
      kill(-child.id(), SIGKILL);
    }
    // Ended, though something it started still holds its output open.
    if (ready == 0 && !child.running()) break;
  }
  if (!pending.empty()) handle(pending);
  child.wait(ec);
  const int status = child.native_exit_code();
  if (WIFSIGNALED(status))
    r.signal = WTERMSIG(status);
  else
    r.exit_code = WEXITSTATUS(status);
  return r;
}

Command LaunchCommand(const std::vector<std::string>& engine_command, int threads, const fs::path& dir,
                      const std::string& helper) {
  std::vector<std::string> engine = engine_command;
  if (!helper.empty()) engine.insert(engine.begin(), {helper, "exec-helper", dir.string()});
  Command c;
  if (threads <= 1) {
    c.program = engine[0];
    c.args.assign(engine.begin() + 1, engine.end());
    return c;
  }
  std::vector<std::string> launcher;
  std::istringstream words(std::getenv("GRANARY_MPI_LAUNCHER") ? std::getenv("GRANARY_MPI_LAUNCHER") : "");
  for (std::string w; words >> w;) launcher.push_back(w);
  if (launcher.empty()) launcher = {"mpirun"};
  c.program = bp::search_path(launcher[0]).string();
  if (c.program.empty())
    throw std::runtime_error(
        "--threads " + std::to_string(threads) + " needs " + launcher[0] +
        (launcher[0] == "mpirun" ? " (Debian package openmpi-bin)" : " (from GRANARY_MPI_LAUNCHER)"));
  c.args.assign(launcher.begin() + 1, launcher.end());
  if (fs::path(c.program).filename() == "srun") {
    c.args.push_back("--ntasks=" + std::to_string(threads));
  } else {
    if (geteuid() == 0 && fs::path(c.program).filename() == "mpirun") c.args.push_back("--allow-run-as-root");
    c.args.insert(c.args.end(), {"-np", std::to_string(threads)});
  }
  c.args.insert(c.args.end(), engine.begin(), engine.end());
  return c;
}

std::string HelperExe(const std::string& name) {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return !ec && self.filename() == name ? self.string() : std::string();
}

Checkpoint NewestCheckpoint(const fs::path& dir) {
  const auto found = Checkpoints(dir);
  return found.empty() ? Checkpoint{} : Checkpoint{found[0].second, found[0].first};
}

void PruneCheckpoints(const fs::path& dir, std::size_t keep) {
  const auto found = Checkpoints(dir);
  for (std::size_t i = keep; i < found.size(); ++i) fs::remove(found[i].second);
}

std::vector<std::string> Tokens(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> t;
  for (std::string w; in >> w;) t.push_back(w);
  return t;
}

bool NextDumpBlock(std::istream& in, long long& step, long long& rows) {
  std::string line;
  while (std::getline(in, line)) {
    if (line != "ITEM: TIMESTEP") continue;
    std::string step_s, n_s;
    std::getline(in, step_s);
    std::getline(in, line);  // ITEM: NUMBER OF ATOMS / ENTRIES
    std::getline(in, n_s);
    for (int i = 0; i < 5; ++i) std::getline(in, line);  // BOX BOUNDS + 3 lines, ITEM: ATOMS / ENTRIES
    step = std::stoll(step_s);
    rows = std::stoll(n_s);
    return true;
  }
  return false;
}

void TruncateDump(const fs::path& file, long long step) {
  if (!fs::exists(file)) return;
  std::ifstream in(file);
  std::string line, kept;
  bool keep = true;
  while (std::getline(in, line)) {
    if (line == "ITEM: TIMESTEP") {
      std::string s;
      std::getline(in, s);
      keep = std::stoll(s) <= step;
      if (keep) kept += line + "\n" + s + "\n";
      continue;
    }
    if (keep) kept += line + "\n";
  }
  in.close();
  WriteAtomically(file, kept);
}

double NearestImage(double y, double near, double height) {
  if (y - near > height / 2) return y - height;
  if (near - y > height / 2) return y + height;
  return y;
}

}  // namespace granary::external

// The backends' shared command line (cli.h).
#include "external/cli.h"

#include <signal.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <exception>
#include <iostream>
#include <stdexcept>

#include "external/driver.h"
#include "rundir/files.h"
#include "rundir/layout.h"
#include "rundir/run_directory.h"
#include "rundir/run_spec.h"
#include "rundir/stop.h"
#include "rundir/version.h"

namespace granary::external {

namespace {
extern "C" void OnStopSignal(int signal) { RequestStop(signal); }
}  // namespace

int ParsePositive(const std::string& flag, const std::string& value) {
  std::size_t used = 0;
  int v = 0;
  try {
    v = std::stoi(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != value.size() || v < 1)
    throw std::invalid_argument(flag + ": expected a positive integer (got \"" + value + "\")");
  return v;
}

bool WantsHelp(const std::vector<std::string>& args) {
  for (const auto& a : args)
    if (a == "--help" || a == "-h") return true;
  return false;
}

int RunVerb(const std::string& tag, const std::vector<std::string>& args, const std::string& help,
            const std::function<std::string(const RunArgs&)>& run) {
  if (WantsHelp(args)) {
    std::cout << help;
    return 0;
  }
  RunArgs o;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--threads" && i + 1 < args.size())
      o.threads = ParsePositive(a, args[++i]);
    else if (a == "--silence-limit" && i + 1 < args.size())
      o.silence_limit = ParsePositive(a, args[++i]);
    else if (!a.empty() && a[0] == '-')
      throw std::invalid_argument("run: unknown option \"" + a + "\"\n" + help);
    else if (o.dir.empty())
      o.dir = a;
    else
      throw std::invalid_argument("run: more than one directory (\"" + o.dir + "\", \"" + a + "\")");
  }
  if (o.dir.empty()) throw std::invalid_argument(std::string("run: missing DIR\n") + help);
  struct sigaction sa {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
  std::string done;
  try {
    done = run(o);
  } catch (const Stopped& e) {
    // Ended as the signal would have ended it, so the runner sees an interruption.
    std::cerr << tag << " run: " << e.what() << "\n";
    std::cerr.flush();
    signal(e.Signal(), SIG_DFL);
    raise(e.Signal());
    return 128 + e.Signal();
  }
  std::cout << done << "\n";
  return 0;
}

int ExecHelper(const std::string& tag, const std::vector<std::string>& args) {
  if (args.size() < 2) throw std::invalid_argument("exec-helper: expected DIR PROGRAM [ARGS...]");
  HoldRunDirectoryAsHelper(args[0]);
  const pid_t parent = getppid();
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != parent) return 1;  // the parent died before the line above
  std::vector<char*> argv;
  for (std::size_t i = 1; i < args.size(); ++i) argv.push_back(const_cast<char*>(args[i].c_str()));
  argv.push_back(nullptr);
  execv(argv[0], argv.data());
  std::cerr << tag << " exec-helper: cannot run " << args[1] << ": " << std::strerror(errno) << "\n";
  return 127;
}

int Main(const std::string& tag, const std::vector<std::string>& args, const std::string& usage, const Verbs& verbs) {
  if (args.empty() || args[0] == "help" || args[0] == "--help" || args[0] == "-h") {
    std::cout << usage;
    return args.empty() ? 2 : 0;
  }
  if (args[0] == "--version") {
    std::cout << tag << " " << GRANARY_VERSION << " (" << granary::GitCommit() << ")\n";
    return 0;
  }
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  try {
    if (args[0] == "exec-helper") return ExecHelper(tag, rest);
    const auto verb = verbs.find(args[0]);
    if (verb != verbs.end()) return verb->second(rest);
    std::cerr << tag << ": unknown verb \"" << args[0] << "\"\n" << usage;
    return 2;
  } catch (const RunDirectoryBusy& e) {
    std::cerr << tag << " " << args[0] << ": " << e.what() << "\n";
    return kExitRunDirectoryBusy;
  } catch (const SpecError& e) {
    std::cerr << tag << " " << args[0] << ": spec error: " << e.what() << "\n";
    return 2;
  } catch (const std::invalid_argument& e) {
    std::cerr << tag << " " << args[0] << ": error: " << e.what() << "\n";
    return 2;
  } catch (const rundir::ReadError& e) {  // run.json missing or not JSON
    std::cerr << tag << " " << args[0] << ": error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << tag << " " << args[0] << ": error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace granary::external

// See slurm_cluster.h.
#include "slurm_cluster.h"

#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

#include "rundir/files.h"
#include "test_util.h"

namespace granary::runner::testing {

namespace fs = std::filesystem;

namespace {

// A TCP port that was free a moment ago (the kernel's choice for port 0). Another process
// may take it before slurmctld binds it: Start() retries with new ports.
int FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) throw std::runtime_error("socket: " + std::string(std::strerror(errno)));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof addr;
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    close(fd);
    throw std::runtime_error("no free port: " + std::string(std::strerror(errno)));
  }
  const int port = ntohs(addr.sin_port);
  close(fd);
  return port;
}

// Starts a daemon in the foreground as a child that gets SIGKILL if this test process dies,
// so a crashed or killed test never leaves a cluster running.
pid_t StartDaemon(const std::vector<std::string>& argv, const fs::path& log) {
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("fork: " + std::string(std::strerror(errno)));
  if (pid == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd >= 0) {
      dup2(fd, 1);
      dup2(fd, 2);
      close(fd);
    }
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execv(args[0], args.data());
    _exit(127);
  }
  return pid;
}

bool Exited(pid_t pid) {
  int status = 0;
  return waitpid(pid, &status, WNOHANG) == pid;
}

std::string ShortHostname() {
  char host[256] = {0};
  gethostname(host, sizeof host - 1);
  std::string h = host;
  return h.substr(0, h.find('.'));
}

std::string UserName() {
  const auto r = Sh("id -un");
  std::string name = r.output;
  while (!name.empty() && (name.back() == '\n' || name.back() == ' ')) name.pop_back();
  return name;
}

}  // namespace

SlurmCluster::SlurmCluster(const Options& options) {
  // Processes the daemons orphan (slurmstepd, job scripts) become our children, so Stop()
  // can reap them instead of leaving them to init.
  prctl(PR_SET_CHILD_SUBREAPER, 1);
  std::string last_error;
  for (int attempt = 0; attempt < 3; ++attempt) {
    try {
      Start(options);
      return;
    } catch (const std::exception& e) {
      last_error = e.what();
      Stop();
    }
  }
  throw std::runtime_error("the test Slurm cluster did not start: " + last_error);
}

SlurmCluster::~SlurmCluster() { Stop(); }

void SlurmCluster::Start(const Options& options) {
  for (const char* exe : {"/usr/sbin/munged", "/usr/sbin/slurmctld", "/usr/sbin/slurmd", "/usr/bin/sbatch"}) {
    if (!fs::exists(exe)) {
      throw std::runtime_error(
          std::string(exe) +
          " is missing: install Debian's slurmctld, slurmd, slurm-client and munge (scripts/setup.sh)");
    }
  }
  std::string tmpl = (fs::temp_directory_path() / "granary-slurm-XXXXXX").string();
  if (!mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed");
  dir_ = tmpl;
  chmod(dir_.c_str(), 0755);  // job scripts read their manifests from under here
  for (const char* sub : {"munge", "state", "spool", "tmp"}) fs::create_directories(dir_ / sub);
  chmod((dir_ / "munge").c_str(), 0700);

  // munged: a private key and socket.
  {
    std::random_device rd;
    std::string key(1024, '\0');
    for (auto& c : key) c = static_cast<char>(rd() & 0xff);
    std::ofstream(dir_ / "munge" / "key", std::ios::binary) << key;
    chmod((dir_ / "munge" / "key").c_str(), 0400);
  }
  const fs::path sock = dir_ / "munge" / "munge.sock";
  daemons_.push_back(StartDaemon(
      {"/usr/sbin/munged", "--foreground", "--force", "--socket=" + sock.string(),
       "--key-file=" + (dir_ / "munge" / "key").string(), "--pid-file=" + (dir_ / "munge" / "munged.pid").string(),
       "--log-file=" + (dir_ / "munge" / "munged.log").string(), "--seed-file=" + (dir_ / "munge" / "seed").string()},
      dir_ / "munge" / "munged.out"));
  if (!WaitFor([&] { return fs::exists(sock) || Exited(daemons_.back()); }, 20) || !fs::exists(sock)) {
    throw std::runtime_error("munged did not create its socket\n" + LogTails());
  }

  const auto node = Sh("/usr/sbin/slurmd -C");
  const std::string node_line = node.output.substr(0, node.output.find('\n'));
  if (node.code != 0 || node_line.rfind("NodeName=", 0) != 0) {
    throw std::runtime_error("slurmd -C failed: " + node.output);
  }
  const std::string user = UserName();
  const int ctld_port = FreePort();
  int slurmd_port = FreePort();
  while (slurmd_port == ctld_port) slurmd_port = FreePort();
  std::ostringstream text;
  const std::string d = dir_.string();
  text << "ClusterName=granarytest\n"
       // Addresses given, so nothing depends on the host name resolving.
       << "SlurmctldHost=" << ShortHostname() << "(127.0.0.1)\n"
       << "SlurmUser=" << user << "\nSlurmdUser=" << user << "\n"
       << "AuthType=auth/munge\nCredType=cred/munge\nAuthInfo=socket=" << sock.string() << "\n"
       << "SlurmctldPort=" << ctld_port << "\nSlurmdPort=" << slurmd_port << "\n"
       << "StateSaveLocation=" << d << "/state\nSlurmdSpoolDir=" << d
       << "/spool\n"
       // PMIx (srun --mpi=pmix) keeps per-step directories under TmpFS, named by job and step
       // id, which a second test cluster on this machine reuses.
       << "TmpFS=" << d
       << "/tmp\n"
       // Open MPI and PMIx name their session files by job id: two test clusters both at job 1
       // left LIGGGHTS' ranks spinning in MPI_Init. Each cluster numbers its jobs apart.
       << "FirstJobId=" << 1000 * (1 + getpid() % 60000) << "\n"
       << "SlurmctldPidFile=" << d << "/slurmctld.pid\nSlurmdPidFile=" << d << "/slurmd.pid\n"
       << "SlurmctldLogFile=" << d << "/slurmctld.log\nSlurmdLogFile=" << d << "/slurmd.log\n"
       << "ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nJobAcctGatherType=jobacct_gather/none\n"
       << "AccountingStorageType=accounting_storage/none\nJobCompType=jobcomp/none\n"
       << "MpiDefault=none\nSwitchType=switch/none\n"
       << "SelectType=select/cons_tres\nSelectTypeParameters=CR_Core\n"
       << "SchedulerType=sched/builtin\nReturnToService=2\nMailProg=/bin/true\n"
       // A cancelled task gets SIGKILL 2 s after SIGTERM (default 30 s).
       << "KillWait=2\n"
       << "MaxArraySize=" << options.max_array_size << "\nMinJobAge=" << options.min_job_age << "\n"
       << node_line << " NodeAddr=127.0.0.1\n"
       << "PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n";
  std::ofstream(dir_ / "slurm.conf") << text.str();
  setenv("SLURM_CONF", Conf().c_str(), 1);

  daemons_.push_back(StartDaemon({"/usr/sbin/slurmctld", "-D", "-i", "-f", Conf()}, dir_ / "slurmctld.out"));
  daemons_.push_back(StartDaemon({"/usr/sbin/slurmd", "-D", "-f", Conf()}, dir_ / "slurmd.out"));
  const bool idle = WaitFor(
      [&] {
        for (pid_t pid : daemons_) {
          if (Exited(pid)) return true;  // reported below
        }
        const auto r = Sh("sinfo -h -o %T");
        return r.code == 0 && r.output.find("idle") != std::string::npos;
      },
      30);
  const auto r = Sh("sinfo -h -o %T");
  if (!idle || r.output.find("idle") == std::string::npos) {
    throw std::runtime_error("the node did not become idle (sinfo: " + r.output + ")\n" + LogTails());
  }
}

void SlurmCluster::Stop() {
  if (daemons_.size() == 3 && !Exited(daemons_[1])) {
    // Cancel everything and let the node drain, so no job step outlives the daemons.
    Sh("scancel --user=" + UserName());
    WaitFor([] { return Sh("squeue -h -o %i").output.empty(); }, 30);
  }
  for (auto it = daemons_.rbegin(); it != daemons_.rend(); ++it) {
    const pid_t pid = *it;
    if (Exited(pid)) continue;
    kill(pid, SIGTERM);
    if (!WaitFor([&] { return Exited(pid); }, 10)) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
    }
  }
  daemons_.clear();
  // What the daemons orphaned (slurmstepd, scripts of jobs still ending) was reparented to us.
  std::vector<pid_t> orphans;
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream stat(entry.path() / "stat");
    std::string line;
    std::getline(stat, line);
    const auto close_paren = line.rfind(')');
    if (close_paren == std::string::npos) continue;
    std::istringstream rest(line.substr(close_paren + 2));
    char state = 0;
    pid_t ppid = 0;
    rest >> state >> ppid;
    if (ppid == getpid()) orphans.push_back(std::stoi(name));
  }
  for (pid_t pid : orphans) {
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
  }
  if (!dir_.empty()) {
    std::error_code ec;
    fs::remove_all(dir_, ec);
    dir_.clear();
  }
}

std::string SlurmCluster::LogTails() const {
  std::string out;
  for (const char* log :
       {"munge/munged.log", "munge/munged.out", "slurmctld.log", "slurmctld.out", "slurmd.log", "slurmd.out"}) {
    const std::string tail = TailOfFile(dir_ / log, 15);
    if (!tail.empty()) out += std::string("--- ") + log + "\n" + tail;
  }
  return out;
}

}  // namespace granary::runner::testing

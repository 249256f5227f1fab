// See slurm.h.
#include "runner/slurm.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <regex>
#include <sstream>
#include <stdexcept>

#include "rundir/layout.h"
#include "rundir/run_spec.h"
#include "runner/campaign_spec.h"
#include "runner/executors.h"

namespace granary::runner {

using nlohmann::json;

namespace {

// A word for the shell: single-quoted, quotes inside escaped.
std::string Quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'')
      out += "'\\''";
    else
      out += c;
  }
  return out + "'";
}

// Seconds without an exponent and without trailing zeros ("3600", "0.5"): `timeout` reads it.
std::string PlainNumber(double x) {
  char buf[64];
  auto [end, ec] = std::to_chars(buf, buf + sizeof buf, x, std::chars_format::fixed);
  if (ec != std::errc()) return std::to_string(x);
  std::string s(buf, end);
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  return s;
}

void CheckField(const std::string& value, const char* what) {
  if (value.find_first_of("\t\n\r") != std::string::npos) {
    throw std::invalid_argument(std::string("manifest: ") + what + " holds a tab or a line break: \"" + value + "\"");
  }
}

}  // namespace

std::string ParseExecutorBlock(const json& block, const std::string& path, SlurmOptions& o) {
  CheckKeys(block, path,
            {"type", "partition", "time", "account", "cpus_per_run", "array_max", "sbatch_args", "poll_interval"});
  ExecutorOfBlock(block, path);
  const auto text = [&](const char* key, std::string& out) {
    if (!block.contains(key)) return;
    if (!block[key].is_string() || block[key].get<std::string>().empty()) {
      throw SpecError(path + "/" + key, "must be a non-empty string (got " + block[key].dump() + ")");
    }
    out = block[key];
  };
  text("partition", o.partition);
  text("account", o.account);
  text("time", o.time);
  if (!o.time.empty() && !IsSlurmTime(o.time)) {
    throw SpecError(path + "/time",
                    "must be a Slurm time such as \"30\", \"4:00:00\" or \"1-12:00:00\" (got \"" + o.time + "\")");
  }
  const auto integer = [&](const char* key, int min, int& out) {
    if (!block.contains(key)) return;
    const json& v = block[key];
    if (!v.is_number_integer() || v.get<std::int64_t>() < min || v.get<std::int64_t>() > 1000000) {
      throw SpecError(path + "/" + key, "must be an integer >= " + std::to_string(min) + " (got " + v.dump() + ")");
    }
    out = v.get<int>();
  };
  integer("cpus_per_run", 1, o.cpus_per_run);
  integer("array_max", 0, o.array_max);
  if (block.contains("sbatch_args")) {
    const json& a = block["sbatch_args"];
    if (!a.is_array()) throw SpecError(path + "/sbatch_args", "must be an array of strings (got " + a.dump() + ")");
    o.sbatch_args.clear();
    for (std::size_t i = 0; i < a.size(); ++i) {
      if (!a[i].is_string() || a[i].get<std::string>().rfind("-", 0) != 0 ||
          a[i].get<std::string>().find_first_of("\n\r") != std::string::npos) {
        throw SpecError(path + "/sbatch_args/" + std::to_string(i),
                        "must be one sbatch option such as \"--qos=long\" (got " + a[i].dump() + ")");
      }
      o.sbatch_args.push_back(a[i]);
    }
  }
  if (block.contains("poll_interval")) {
    const json& v = block["poll_interval"];
    if (!v.is_number() || !(v.get<double>() > 0)) {
      throw SpecError(path + "/poll_interval", "must be a number of seconds > 0 (got " + v.dump() + ")");
    }
    o.poll_interval = v.get<double>();
  }
  return block["type"];
}

bool IsSlurmTime(const std::string& text) {
  static const std::regex kTime(
      R"(^(\d+|\d+:\d{1,2}|\d+:\d{1,2}:\d{1,2}|\d+-\d+|\d+-\d+:\d{1,2}|\d+-\d+:\d{1,2}:\d{1,2})$)");
  return std::regex_match(text, kTime) || text == "UNLIMITED" || text == "INFINITE";
}

std::string SlurmTime(double seconds) {
  const long minutes = std::max(1L, static_cast<long>(std::ceil(seconds / 60.0)));
  char buf[48];
  std::snprintf(buf, sizeof buf, "%ld-%02ld:%02ld:00", minutes / 1440, (minutes % 1440) / 60, minutes % 60);
  return buf;
}

std::string ManifestText(const std::vector<ManifestEntry>& entries) {
  std::string out = "# index\trun_id\tengine\texecutable\trun_dir\n";
  for (const auto& e : entries) {
    CheckField(e.run_id, "a run id");
    CheckField(e.engine, "an engine");
    CheckField(e.executable, "an engine path");
    CheckField(e.run_dir, "a run directory");
    out += std::to_string(e.index) + "\t" + e.run_id + "\t" + e.engine + "\t" + e.executable + "\t" + e.run_dir + "\n";
  }
  return out;
}

std::vector<ManifestEntry> ParseManifest(const std::string& text) {
  std::vector<ManifestEntry> out;
  std::istringstream in(text);
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> f;
    std::size_t start = 0;
    while (true) {
      const auto tab = line.find('\t', start);
      f.push_back(line.substr(start, tab - start));
      if (tab == std::string::npos) break;
      start = tab + 1;
    }
    int index = -1;
    if (f.size() != 5 || std::from_chars(f[0].data(), f[0].data() + f[0].size(), index).ec != std::errc() ||
        index < 0) {
      throw std::invalid_argument("manifest line " + std::to_string(number) +
                                  ": expected index, run id, engine, executable, run directory");
    }
    out.push_back({index, f[1], f[2], f[3], f[4]});
  }
  return out;
}

std::string ArraySpec(const std::vector<int>& indices, int throttle) {
  std::string out;
  for (std::size_t i = 0; i < indices.size();) {
    std::size_t j = i;
    while (j + 1 < indices.size() && indices[j + 1] == indices[j] + 1) ++j;
    if (!out.empty()) out.push_back(',');
    out.append(std::to_string(indices[i]));
    if (j > i) {
      out.push_back('-');
      out.append(std::to_string(indices[j]));
    }
    i = j + 1;
  }
  if (throttle > 0) {
    out.push_back('%');
    out.append(std::to_string(throttle));
  }
  return out;
}

std::string BatchScript(const BatchJob& job) {
  const SlurmOptions& o = job.options;
  const bool mpi = job.engine == "liggghts" || job.engine == "lammps";
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "# Granary: each task of this array runs one run of the campaign; " << job.manifest << "\n"
    << "# maps the array index to the run. Written by campaign run --executor slurm (docs/slurm.md).\n"
    << "#SBATCH --job-name=" << job.job_name << "\n"
    << "#SBATCH --array=" << job.array << "\n";
  // LIGGGHTS and LAMMPS use MPI ranks (srun inside the task); the native engine uses threads.
  if (mpi)
    s << "#SBATCH --ntasks=" << o.cpus_per_run << "\n#SBATCH --cpus-per-task=1\n";
  else
    s << "#SBATCH --ntasks=1\n#SBATCH --cpus-per-task=" << o.cpus_per_run << "\n";
  s << "#SBATCH --output=" << job.log_dir << "/%A_%a.out\n";
  if (!o.partition.empty()) s << "#SBATCH --partition=" << o.partition << "\n";
  if (!o.account.empty()) s << "#SBATCH --account=" << o.account << "\n";
  // Slurm's own limit leaves the engine a minute to checkpoint after `timeout` stopped it.
  if (!o.time.empty())
    s << "#SBATCH --time=" << o.time << "\n";
  else if (job.time_limit > 0)
    s << "#SBATCH --time=" << SlurmTime(job.time_limit + 90) << "\n";
  if (!job.dependency.empty()) s << "#SBATCH --dependency=" << job.dependency << "\n";
  for (const auto& a : o.sbatch_args) s << "#SBATCH " << a << "\n";
  s << "set -u\n"
    << "manifest=" << Quote(job.manifest) << "\n"
    << "time_limit=" << PlainNumber(job.time_limit) << "  # seconds per run from this task's start; 0 = none\n"
    << "entry=$(awk -F '\\t' -v i=\"$SLURM_ARRAY_TASK_ID\" '$1 == i { print; exit }' \"$manifest\")\n"
    << "if [ -z \"$entry\" ]; then\n"
    << "  echo \"granary: array index $SLURM_ARRAY_TASK_ID is not in $manifest\" >&2\n"
    << "  exit 2\n"
    << "fi\n"
    << "IFS=$'\\t' read -r index run_id engine exe dir <<< \"$entry\"\n"
    << "task=\"${SLURM_ARRAY_JOB_ID}_${SLURM_ARRAY_TASK_ID}\"\n"
    << "started=$(date +%s.%N)\n"
    << "# DIR/" << rundir::kSlurmTaskFile
    << ": this task, its node and start, then its exit status; replaced atomically.\n"
    << "record() {\n"
    << "  local tmp=\"$dir/" << rundir::kSlurmTaskFile << ".tmp.$$\"\n"
    << "  printf '{\"job\": \"%s\", \"run_id\": \"%s\", \"node\": \"%s\", \"started_at\": %s%s}\\n' \\\n"
    << "    \"$task\" \"$run_id\" \"$(hostname -s)\" \"$started\" \"$1\" > \"$tmp\" &&\n"
    << "    sync \"$tmp\" && mv -f \"$tmp\" \"$dir/" << rundir::kSlurmTaskFile << "\" && sync \"$dir\"\n"
    << "}\n"
    << "record ''\n";
  if (mpi) {
    s << "threads=${SLURM_NTASKS:-1}\n"
      << "if [ \"$threads\" -gt 1 ]; then export GRANARY_MPI_LAUNCHER=\"${GRANARY_MPI_LAUNCHER:-srun --mpi=pmix}\"; fi\n";
  } else {
    s << "threads=${SLURM_CPUS_PER_TASK:-1}\n";
  }
  s << "cmd=(\"$exe\" run \"$dir\" --threads \"$threads\")\n"
    << "if [ \"$time_limit\" != 0 ]; then cmd=(timeout --signal=TERM --kill-after=30 \"$time_limit\" \"${cmd[@]}\"); fi\n"
    << "\"${cmd[@]}\" < /dev/null >> \"$dir/" << rundir::kEngineLogFile << "\" 2>&1\n"
    << "status=$?\n"
    << "record \", \\\"exit_code\\\": $status, \\\"ended_at\\\": $(date +%s.%N)\"\n"
    << "exit $status\n";
  return s.str();
}

std::vector<QueueEntry> ParseSqueue(const std::string& text) {
  std::vector<QueueEntry> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::vector<std::string> f;
    std::size_t start = 0;
    for (int i = 0; i < 5; ++i) {  // the reason (last) may hold anything
      const auto bar = line.find('|', start);
      if (bar == std::string::npos) break;
      f.push_back(line.substr(start, bar - start));
      start = bar + 1;
    }
    if (f.size() != 5) continue;  // not a line of ours (a warning)
    f.push_back(line.substr(start));
    QueueEntry e;
    e.job_id = f[0];
    int task = -1;
    if (std::from_chars(f[1].data(), f[1].data() + f[1].size(), task).ec == std::errc()) e.task = task;
    e.state = f[2];
    double t = 0;
    if (std::from_chars(f[3].data(), f[3].data() + f[3].size(), t).ec == std::errc()) e.started_at = t;
    e.name = f[4];
    e.reason = f[5];
    out.push_back(e);
  }
  return out;
}

int ParseMaxArraySize(const std::string& show_config) {
  static const std::regex kLine(R"(^MaxArraySize\s*=\s*(\d+)\s*$)");
  std::istringstream in(show_config);
  std::string line;
  std::smatch m;
  while (std::getline(in, line)) {
    if (std::regex_match(line, m, kLine)) return std::stoi(m[1]);
  }
  return 1001;
}

TaskFate FateOf(const std::string& state) {
  // Slurm prints the long names (squeue %T); a trailing "+" (e.g. "CANCELLED+") is dropped.
  std::string s = state;
  while (!s.empty() && s.back() == '+') s.pop_back();
  if (s == "PENDING" || s == "REQUEUED" || s == "REQUEUE_HOLD" || s == "REQUEUE_FED" || s == "RESV_DEL_HOLD" ||
      s == "CONFIGURING" || s == "RESIZING") {
    return TaskFate::kQueued;
  }
  if (s == "COMPLETED") return TaskFate::kCompleted;
  if (s == "FAILED" || s == "OUT_OF_MEMORY") return TaskFate::kFailed;
  if (s == "TIMEOUT") return TaskFate::kTimedOut;
  if (s == "CANCELLED" || s == "PREEMPTED" || s == "NODE_FAIL" || s == "BOOT_FAIL" || s == "DEADLINE" ||
      s == "REVOKED" || s == "SPECIAL_EXIT") {
    return TaskFate::kLost;
  }
  // RUNNING, COMPLETING, SUSPENDED, STOPPED, SIGNALING, STAGE_OUT, and anything newer: the job
  // still holds the run, so nothing is resubmitted for it.
  return TaskFate::kRunning;
}

std::optional<TaskRecord> ParseTaskRecord(const std::string& text) {
  const json j = json::parse(text, nullptr, false);
  if (!j.is_object() || !j.contains("job") || !j["job"].is_string()) return std::nullopt;
  TaskRecord r;
  r.job = j["job"];
  r.node = j.value("node", std::string());
  r.started_at = j.value("started_at", 0.0);
  if (j.contains("exit_code") && j["exit_code"].is_number_integer()) r.exit_code = j["exit_code"].get<int>();
  r.ended_at = j.value("ended_at", 0.0);
  return r;
}

bool EndedByTimeLimit(const TaskRecord& record, double time_limit) {
  if (time_limit <= 0 || !record.exit_code) return false;
  return *record.exit_code == 124 ||
         (*record.exit_code == 128 + 9 && record.ended_at - record.started_at >= time_limit);
}

}  // namespace granary::runner

// See python_analysis.h.
#include "analysis/python_analysis.h"

#include <algorithm>
#include <boost/process.hpp>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include "analysis/campaign_view.h"
#include "analysis/options.h"
#include "rundir/hash.h"

#ifndef GRANARY_PYTHON
#define GRANARY_PYTHON "/usr/bin/python3"
#endif
#ifndef GRANARY_PYTHON_PATH
#define GRANARY_PYTHON_PATH ""
#endif

namespace granary::analysis {
namespace {

namespace bp = boost::process;
using nlohmann::json;

// Seconds a script may run on one run unless its entry sets /report/python/<i>/timeout, and
// how much longer the pass waits before it stops an interpreter the worker's alarm did not.
constexpr double kDefaultTimeout = 600.0;
double GraceSeconds(double timeout) { return std::min(10.0, std::max(1.0, timeout)); }

// Interpreters running `python -m granary.worker`, started when a request finds none idle (at
// most one per hardware thread: the pass runs that many runs at once), kept for the next
// request, stopped with the pool. One request = one JSON line each way.
class PythonPool {
 public:
  PythonPool() : size_(static_cast<int>(std::max(1u, std::thread::hardware_concurrency()))) {}
  ~PythonPool() {
    for (auto& w : idle_) Stop(*w);
  }
  PythonPool(const PythonPool&) = delete;
  PythonPool& operator=(const PythonPool&) = delete;

  // The worker's answer, or {"ok": false, "error": why} when there is none (no interpreter,
  // it died, it answered something that is not JSON).
  //
  // `limit`: the interpreter is stopped when it has not answered by then (the worker's own
  // alarm stops a script at its timeout; this catches what the alarm cannot interrupt).
  json Call(const json& request, std::chrono::duration<double> limit) {
    std::unique_ptr<Worker> w = Take();
    if (!w) return Failed("cannot start " + PythonInterpreter() + " -m granary.worker: " + start_error_);
    std::string line;
    try {
      w->in << request.dump() << "\n" << std::flush;
    } catch (const std::exception&) {
    }
    std::mutex m;
    std::condition_variable cv;
    bool answered = false, stopped = false;
    std::thread watchdog([&] {
      std::unique_lock<std::mutex> lock(m);
      if (!cv.wait_for(lock, limit, [&] { return answered; })) {
        stopped = true;
        std::error_code ec;
        w->child.terminate(ec);
      }
    });
    const bool got = static_cast<bool>(std::getline(w->out, line));
    {
      std::lock_guard<std::mutex> lock(m);
      answered = true;
    }
    cv.notify_one();
    watchdog.join();
    if (!got || stopped) {
      std::string why = Died(*w);
      if (stopped)
        why = "the Python interpreter running the script did not answer within " + FormatSeconds(limit.count()) +
              " s and was stopped (the script's timeout, /report/python/.../timeout, plus a grace period)";
      Release(nullptr);
      return Failed(why);
    }
    json answer = json::parse(line, nullptr, false);
    if (answer.is_discarded() || !answer.is_object() || !answer.contains("ok")) {
      // The protocol is broken: this interpreter is not trusted with another request.
      Stop(*w);
      Release(nullptr);
      json failed = Failed("the Python worker answered something that is not an answer: '" + line.substr(0, 200) + "'");
      failed.erase("retry");
      return failed;
    }
    Release(std::move(w));
    return answer;
  }

 private:
  struct Worker {
    bp::opstream in;
    bp::ipstream out;
    bp::child child;
  };

  // No answer (no interpreter, it died or was stopped): a failure that may not happen again.
  static json Failed(const std::string& why) { return {{"ok", false}, {"error", why}, {"retry", true}}; }
  static std::string FormatSeconds(double s) {
    std::ostringstream o;
    o << s;
    return o.str();
  }

  std::unique_ptr<Worker> Take() {
    std::unique_lock<std::mutex> lock(m_);
    cv_.wait(lock, [&] { return !idle_.empty() || live_ < size_; });
    if (!idle_.empty()) {
      std::unique_ptr<Worker> w = std::move(idle_.back());
      idle_.pop_back();
      return w;
    }
    ++live_;
    lock.unlock();
    auto w = std::make_unique<Worker>();
    try {
      bp::environment env = boost::this_process::environment();
      const std::string own = GRANARY_PYTHON_PATH;
      if (!own.empty()) {
        const std::string old = env.count("PYTHONPATH") ? env["PYTHONPATH"].to_string() : std::string();
        env["PYTHONPATH"] = old.empty() ? own : own + ":" + old;
      }
      w->child = bp::child(PythonInterpreter(), "-m", "granary.worker", bp::std_in<w->in, bp::std_out> w->out,
                           bp::std_err > bp::null, env);
      // Its first line says it has imported granary: a script's timeout counts from there.
      std::string ready;
      const bool got = static_cast<bool>(std::getline(w->out, ready));
      const json hello = got ? json::parse(ready, nullptr, false) : json();
      if (!hello.is_object() || !hello.value("ready", false)) {
        std::error_code ec;
        w->child.wait(ec);
        throw std::runtime_error("it did not start (exit status " + std::to_string(ec ? -1 : w->child.exit_code()) +
                                 "; is python/granary on its path, with NumPy and pandas?)");
      }
      return w;
    } catch (const std::exception& e) {
      lock.lock();
      start_error_ = e.what();
      --live_;
      cv_.notify_one();
      return nullptr;
    }
  }

  void Release(std::unique_ptr<Worker> w) {
    std::lock_guard<std::mutex> lock(m_);
    if (w)
      idle_.push_back(std::move(w));
    else
      --live_;
    cv_.notify_one();
  }

  static std::string Died(Worker& w) {
    std::error_code ec;
    w.in.pipe().close();
    w.child.wait(ec);  // it has ended: its output is closed
    const int code = ec ? -1 : w.child.exit_code();
    return "the Python interpreter running the script died without an answer (exit status " + std::to_string(code) +
           "; a crash, os._exit or the system's memory limit)";
  }

  // Asked, not by closing its input: a worker started later inherited this one's pipe, so the
  // end of input would not reach it while that one lives.
  static void Stop(Worker& w) {
    std::error_code ec;
    try {
      w.in << "{\"quit\": true}\n" << std::flush;
    } catch (const std::exception&) {
    }
    w.in.pipe().close();
    w.child.wait(ec);
  }

  std::mutex m_;
  std::condition_variable cv_;
  std::vector<std::unique_ptr<Worker>> idle_;
  int live_ = 0;
  int size_;
  std::string start_error_;
};

std::string ReadScript(const std::string& file, const std::string& path) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw OptionError(path, file, "a readable Python file (no such file or not readable)");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

bool IsMetricName(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(),
                                   [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_'; });
}

class PythonAccumulator : public RunAccumulator {
 public:
  PythonAccumulator(std::shared_ptr<PythonPool> pool, json request)
      : pool_(std::move(pool)), request_(std::move(request)) {}

  // The script reads what it wants itself; the pass reads no frame for it.
  json Finish() override {
    const double timeout = request_.value("timeout", kDefaultTimeout);
    const json answer = pool_->Call(request_, std::chrono::duration<double>(timeout + GraceSeconds(timeout)));
    const std::string key = request_.value("key", "");
    if (answer.value("ok", false)) {
      json metrics = json::array();
      std::string bad;
      if (answer.contains("metrics") && answer.at("metrics").is_object()) {
        for (const auto& [name, v] : answer.at("metrics").items()) {
          if (!IsMetricName(name) || !v.is_array() || v.size() != 3 || !v[0].is_number() || !v[2].is_string() ||
              !(v[1].is_number() || v[1].is_null()) || !std::isfinite(v[0].get<double>())) {
            bad = "metric '" + name + "': " + v.dump();
            break;
          }
          metrics.push_back({{"name", name}, {"value", v[0]}, {"se", v[1]}, {"unit", v[2]}});
        }
      } else {
        bad = "no metrics";
      }
      if (bad.empty()) return {{"metrics", metrics}};
      return Failure(key, "the worker's answer is not {name: [value, se, unit]} (" + bad + ")");
    }
    const std::string error = answer.value("error", std::string("failed"));
    const std::string output = answer.value("output", std::string());
    json failed = Failure(key, error, output.empty() ? "" : "\n(the script printed: " + output + ")");
    // A timeout or an interpreter that died may not recur: the next report runs the script again.
    if (answer.value("retry", false)) failed[kRecompute] = true;
    return failed;
  }

 private:
  static json Failure(const std::string& key, const std::string& error, const std::string& printed = "") {
    // The note is one line: a traceback's last (the exception), else the message's first (a
    // timeout's "where it was stopped" follows it). The result keeps the whole tail.
    std::string line = error;
    while (!line.empty() && line.back() == '\n') line.pop_back();
    const bool traceback = line.rfind("Traceback", 0) == 0 || line.rfind(' ', 0) == 0;
    if (traceback) {
      if (const auto nl = line.rfind('\n'); nl != std::string::npos) line = line.substr(nl + 1);
    } else if (const auto nl = line.find('\n'); nl != std::string::npos) {
      line = line.substr(0, nl);
    }
    return {{"failed", error + printed}, {"notes", json::array({"python analysis '" + key + "' failed: " + line})}};
  }

  std::shared_ptr<PythonPool> pool_;
  json request_;
};

class PythonAnalysis : public Analysis {
 public:
  PythonAnalysis(std::string key, std::string script, std::string source, json options, double timeout,
                 std::shared_ptr<PythonPool> pool)
      : key_(std::move(key)),
        script_(std::move(script)),
        source_(std::move(source)),
        hash_(HashHex(source_)),
        options_(std::move(options)),
        timeout_(timeout),
        pool_(std::move(pool)) {}

  std::string Key() const override { return key_; }
  // The protocol between the pass and the worker; the script itself is in RunOptions().
  int Version() const override { return 1; }
  // A changed script (its text, not its name) or changed options re-analyse the runs.
  json RunOptions() const override { return {{"script_hash", hash_}, {"options", options_}}; }

  std::unique_ptr<RunAccumulator> Start(const RunView& run) const override {
    const json request = {{"key", key_},         {"script", script_},
                          {"source", source_},   {"options", options_},
                          {"timeout", timeout_}, {"run", run.data ? run.data->dir.string() : std::string()}};
    return std::make_unique<PythonAccumulator>(pool_, request);
  }

  std::vector<Metric> RunMetrics(const json& result) const override {
    std::vector<Metric> out;
    if (!result.is_object() || !result.contains("metrics")) return out;
    for (const auto& m : result.at("metrics"))
      out.push_back({m.value("name", ""), m.value("unit", ""), NumberAt(m, "value"), NumberAt(m, "se"),
                     m.value("name", ""), true});
    return out;
  }

  std::optional<Section> BuildSection(const SectionInput& in) const override {
    const CampaignView& v = in.view;
    Section s{"python-" + key_, "Python analysis " + key_, {}};
    s.blocks.push_back(Text{"Computed by `" + script_ + "` (`analyse(run, options)`, options `" + options_.dump() +
                            "`) on each run; per point the mean over its runs with its standard error."});
    std::vector<std::string> names;
    for (const auto& metrics : in.points)
      for (const PointMetric& m : metrics)
        if (std::find(names.begin(), names.end(), m.name) == names.end()) names.push_back(m.name);
    if (!names.empty()) {
      Table t{"python_" + key_, "Python analysis " + key_ + " per point", {"point"}, {}, {"point"}};
      for (const auto& n : names) {
        const PointMetric* unit_of = nullptr;
        for (const auto& metrics : in.points)
          if (!unit_of) unit_of = FindMetric(metrics, n);
        t.header.push_back(
            n + (unit_of && !unit_of->unit.empty() && unit_of->unit != "1" ? " [" + unit_of->unit + "]" : ""));
        t.keys.push_back(n);
      }
      for (std::size_t p = 0; p < v.points.size(); ++p) {
        std::vector<Cell> row = {PointName(v, v.points[p])};
        for (const auto& n : names) {
          const PointMetric* m = FindMetric(in.points[p], n);
          row.push_back(m ? Cell::Estimate(m->Estimate()) : Cell(""));
        }
        t.rows.push_back(row);
      }
      s.blocks.push_back(t);
      if (HasX(v))
        for (const auto& n : names)
          s.blocks.push_back(Figure{"python_" + key_ + "_" + n, n + " against " + v.x_label, v.x_label, n,
                                    PointSeries(v, in.points, n, n), false, false, "Error bars: se over replicas"});
    }
    // Every failed run with the last lines of its traceback.
    std::string failures;
    int failed = 0;
    for (std::size_t r = 0; r < in.results.runs.size() && r < v.used.size(); ++r) {
      const std::string why = PythonFailure(in.results.runs[r]);
      if (why.empty()) continue;
      ++failed;
      std::string lines;
      std::istringstream text(why);
      for (std::string line; std::getline(text, line);)
        if (line.find_first_not_of(' ') != std::string::npos) lines += (lines.empty() ? "" : " / ") + line;
      failures += "\n\nRun `" + v.used[r].record->run_id + "`: " + lines;
    }
    if (failed > 0)
      s.blocks.push_back(Text{"**Failed on " + std::to_string(failed) + " of " + std::to_string(v.used.size()) +
                              " runs** (the traceback's last lines; the other runs' metrics are above):" + failures});
    return s;
  }

 private:
  std::string key_, script_, source_, hash_;
  json options_;
  double timeout_;
  std::shared_ptr<PythonPool> pool_;
};

}  // namespace

std::string PythonInterpreter() {
  if (const char* p = std::getenv("GRANARY_PYTHON"); p && *p) return p;
  return GRANARY_PYTHON;
}

std::string PythonFailure(const json& result) {
  if (!result.is_object() || !result.contains("failed") || !result.at("failed").is_string()) return "";
  return result.at("failed").get<std::string>();
}

std::vector<std::unique_ptr<Analysis>> MakePythonAnalyses(const json& options, const std::string& path) {
  std::vector<std::unique_ptr<Analysis>> out;
  if (options.is_null()) return out;
  if (!options.is_array()) throw OptionError(path, options, "an array of {\"key\", \"script\", \"options\"}");
  auto pool = std::make_shared<PythonPool>();
  std::vector<std::string> keys;
  for (std::size_t k = 0; k < options.size(); ++k) {
    const std::string p = path + "/" + std::to_string(k);
    const json& e = OptionObject(options[k], p, {"key", "script", "options", "timeout"});
    if (!e.contains("key") || !e.at("key").is_string() || !IsMetricName(e.at("key").get<std::string>()))
      throw OptionError(p + "/key", e.value("key", json()), "a name of a-z, 0-9 and _ (the analysis' key)");
    const std::string key = e.at("key").get<std::string>();
    if (std::find(keys.begin(), keys.end(), key) != keys.end())
      throw OptionError(p + "/key", key, "a key no other Python analysis has");
    keys.push_back(key);
    if (!e.contains("script") || !e.at("script").is_string())
      throw OptionError(p + "/script", e.value("script", json()), "the path of a Python file");
    const std::string script = e.at("script").get<std::string>();
    json script_options = e.value("options", json::object());
    if (!script_options.is_object())
      throw OptionError(p + "/options", script_options, "an object (the script's options)");
    const json timeout = e.value("timeout", json(kDefaultTimeout));
    if (!timeout.is_number() || !(timeout.get<double>() > 0.0) || !std::isfinite(timeout.get<double>()))
      throw OptionError(p + "/timeout", timeout, "a number of seconds > 0 (how long the script may run on one run)");
    out.push_back(std::make_unique<PythonAnalysis>(key, script, ReadScript(script, p + "/script"),
                                                   std::move(script_options), timeout.get<double>(), pool));
  }
  return out;
}

}  // namespace granary::analysis

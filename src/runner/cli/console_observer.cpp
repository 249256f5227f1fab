// See console_observer.h.
#include "runner/cli/console_observer.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <chrono>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "runner/cli/common.h"
#include "runner/executor.h"

namespace granary::runner::cli {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Columns of the terminal on stdout (80 when it cannot be asked).
int TerminalColumns() {
  struct winsize w {};
  if (ioctl(STDOUT_FILENO, TIOCGWINSZ, &w) == 0 && w.ws_col > 0) return w.ws_col;
  return 80;
}

// `line` cut to `columns` - 1 characters (UTF-8 aware), so that a drawn line never wraps: the
// display clears itself by moving up one row per line, which a wrapped line would defeat.
std::string FitColumns(const std::string& line, int columns) {
  const int max = std::max(8, columns - 1);
  int shown = 0;
  for (std::size_t i = 0; i < line.size(); ++i) {
    if ((static_cast<unsigned char>(line[i]) & 0xC0) == 0x80) continue;  // UTF-8 continuation byte
    if (++shown > max) return line.substr(0, i);
  }
  return line;
}

class ConsoleObserver : public RunObserver {
 public:
  ConsoleObserver(std::ostream& out, bool tty, std::map<std::string, std::string> short_names)
      : out_(out), tty_(tty), short_names_(std::move(short_names)) {}
  void OnBegin(int total, int done, int failed) override {
    start_ = std::chrono::steady_clock::now();
    done_at_start_ = done;
    out_ << "campaign run: " << total << " runs, " << done << " done, " << failed << " failed before this run\n";
    out_.flush();
  }
  void OnEvent(const std::string& run_id, const std::string& state, const std::string& message) override {
    Clear();
    if (state != ToString(RunState::kRunning)) {
      std::erase_if(active_, [&](const ActiveRun& a) { return a.run_id == run_id; });
      if (state == ToString(RunState::kDone)) ++done_;
    }
    std::string first = message.substr(0, message.find('\n'));
    std::string where;
    if (const auto it = points_.find(run_id); it != points_.end()) where = it->second + ": ";
    out_ << std::left << std::setw(12) << state << " " << (run_id.empty() ? "" : run_id + "  ") << where << first
         << "\n";
    if (state == ToString(RunState::kFailed) || state == ToString(RunState::kInterrupted)) {
      const auto nl = message.find('\n');
      if (nl != std::string::npos) {
        std::istringstream tail(message.substr(nl + 1));
        std::string line;
        std::vector<std::string> lines;
        while (std::getline(tail, line)) lines.push_back(line);
        for (std::size_t i = lines.size() > 5 ? lines.size() - 5 : 0; i < lines.size(); ++i)
          out_ << "    | " << lines[i] << "\n";
      }
    }
    out_.flush();
    Draw();
  }
  void OnTick(const std::vector<ActiveRun>& active, int done, int failed, int total) override {
    active_ = active;
    for (const ActiveRun& a : active_)
      points_[a.run_id] =
          CompactPoint(json::parse(a.point, nullptr, false), short_names_) + " r" + std::to_string(a.replica);
    done_ = done;
    failed_ = failed;
    total_ = total;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    if (tty_) {
      Clear();
      Draw();
    } else if (elapsed - last_plain_ >= 10.0) {
      last_plain_ = elapsed;
      const int queued = Queued(active);
      out_ << "progress " << done << "/" << total << " done, " << failed << " failed, " << active.size() - queued
           << " running" << (queued > 0 ? ", " + std::to_string(queued) + " queued" : "") << ", elapsed "
           << Duration(elapsed) << ", ETA " << Eta(elapsed) << "\n";
      out_.flush();
    }
  }
  void OnEnd(int done, int failed, int total) override {
    Clear();
    done_ = done;
    failed_ = failed;
    total_ = total;
    out_ << "campaign run: " << done_ << "/" << total_ << " done, " << failed_ << " failed\n";
    out_.flush();
  }

 private:
  std::string Eta(double elapsed) const {
    const int finished_here = done_ - done_at_start_;
    if (finished_here <= 0) return "?";
    return Duration(elapsed / finished_here * std::max(0, total_ - done_ - failed_));
  }
  // Erases what Draw drew: the cursor goes up one row per drawn line (none wraps) and the
  // screen is cleared from there down, so the next text starts on a clean line.
  void Clear() {
    if (!tty_ || lines_ == 0) return;
    out_ << "\r\033[" << lines_ << "A\033[J";
    lines_ = 0;
  }
  void Line(const std::string& text) {
    out_ << FitColumns(text, columns_) << "\n";
    ++lines_;
  }
  static bool IsQueued(const ActiveRun& a) {
    return !a.queue_state.empty() && DefaultBatchQueue().FateOf(a.queue_state) != TaskFate::kRunning;
  }
  static int Queued(const std::vector<ActiveRun>& active) {
    return static_cast<int>(std::count_if(active.begin(), active.end(), IsQueued));
  }
  void Draw() {
    if (!tty_ || total_ == 0) return;
    columns_ = TerminalColumns();
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    std::ostringstream head;
    head << Bar(static_cast<double>(done_) / total_, 30) << " " << done_ << "/" << total_ << " done, " << failed_
         << " failed, elapsed " << Duration(elapsed) << ", ETA " << Eta(elapsed);
    Line(head.str());
    // Runs waiting in a batch queue get one line for all of them.
    if (const int queued = Queued(active_); queued > 0)
      Line("  " + std::to_string(queued) + " queued (" + DefaultBatchQueue().Name() + ")");
    for (const auto& a : active_) {
      if (IsQueued(a)) continue;
      const auto it = points_.find(a.run_id);
      Line("  " + a.run_id.substr(0, 10) + " " + (it == points_.end() ? std::string() : it->second) + "  " +
           ProgressText(a.progress, true));
    }
    out_.flush();
  }
  std::ostream& out_;
  bool tty_;
  std::map<std::string, std::string> short_names_;
  int columns_ = 80;
  std::chrono::steady_clock::time_point start_;
  int done_at_start_ = 0, done_ = 0, failed_ = 0, total_ = 0, lines_ = 0;
  double last_plain_ = 0;
  std::vector<ActiveRun> active_;
  std::map<std::string, std::string> points_;  // run id -> "W=9 r0", from the ticks
};

}  // namespace

std::unique_ptr<RunObserver> MakeConsoleObserver(std::ostream& out, bool tty,
                                                 std::map<std::string, std::string> short_names) {
  return std::make_unique<ConsoleObserver>(out, tty, std::move(short_names));
}

}  // namespace granary::runner::cli

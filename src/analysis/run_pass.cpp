// See run_pass.h.
#include "analysis/run_pass.h"

#include <algorithm>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>

#include "analysis/clogging.h"
#include "rundir/analysis_cache.h"
#include "rundir/files.h"
#include "rundir/hash.h"

namespace granary::analysis {
namespace {

// Which frames one accumulator gets: those inside its windows, every frame_stride-th of them,
// at most max_frames. Frames come in time order, so past its last window it is done.
class FrameSelector {
 public:
  FrameSelector(FrameRequest request, const PassOptions& pass)
      : request_(std::move(request)), stride_(std::max(1, pass.frame_stride)), max_(pass.max_frames) {
    done_ = request_.windows.empty();
    for (const TimeWindow& w : request_.windows) last_end_ = std::max(last_end_, w.end);
  }
  bool Done() const { return done_; }
  bool Contacts() const { return request_.contacts; }
  bool Wants(double t) {
    if (done_) return false;
    if (t > last_end_) {
      done_ = true;
      return false;
    }
    const bool inside = std::any_of(request_.windows.begin(), request_.windows.end(),
                                    [t](const TimeWindow& w) { return w.Contains(t); });
    if (!inside || seen_++ % stride_ != 0) return false;
    if (max_ > 0 && ++used_ >= max_) done_ = true;
    return true;
  }

 private:
  FrameRequest request_;
  int stride_;
  int max_;
  int seen_ = 0, used_ = 0;
  double last_end_ = -std::numeric_limits<double>::infinity();
  bool done_ = false;
};

// One selected frame with everything the accumulators get.
struct FrameItem {
  rundir::Frame frame;
  std::vector<rundir::Body> bodies;
  rundir::ContactFrame contacts;
  bool has_contacts = false;
  std::vector<char> wanted;  // per accumulator
};

// Reads the frames of a run in order and prepares the ones some selector wants.
class FrameSource {
 public:
  FrameSource(const rundir::RunData& data, double density, std::vector<FrameSelector>& selectors)
      : frames_(data.FramesFile(), density), selectors_(selectors) {
    bool contacts = false;
    for (const FrameSelector& s : selectors_) contacts = contacts || (s.Contacts() && !s.Done());
    if (contacts && data.has_contacts) contact_reader_.emplace(data.ContactsFile());
  }

  // Fills `item` with the next wanted frame; false when no selector wants any more.
  bool Next(FrameItem& item) {
    for (;;) {
      if (std::all_of(selectors_.begin(), selectors_.end(), [](const FrameSelector& s) { return s.Done(); }))
        return false;
      if (!frames_.NextHeader(item.frame)) return false;
      item.wanted.assign(selectors_.size(), 0);
      bool any = false, contacts = false;
      for (std::size_t k = 0; k < selectors_.size(); ++k) {
        if (!selectors_[k].Wants(item.frame.time)) continue;
        item.wanted[k] = 1;
        any = true;
        contacts = contacts || selectors_[k].Contacts();
      }
      if (!any) {
        if (!frames_.SkipDiscs()) return false;
        continue;
      }
      if (!frames_.ReadDiscs(item.frame)) return false;  // cut short at the end: an engine still writing
      ++parsed_;
      item.bodies = rundir::BodiesOf(item.frame.discs);
      item.has_contacts = contacts && ContactsAt(item.frame.timestep, item.contacts);
      return true;
    }
  }
  int Parsed() const { return parsed_; }

 private:
  // The contact frame written at `timestep`, if there is one (contact frames come in the
  // same order; those before it are skipped). A header read ahead waits in `pending_`.
  bool ContactsAt(std::int64_t timestep, rundir::ContactFrame& out) {
    if (!contact_reader_) return false;
    for (;;) {
      if (!contact_pending_) {
        if (!contact_reader_->NextHeader(pending_)) {
          contact_reader_.reset();
          return false;
        }
        contact_pending_ = true;
      }
      if (pending_.timestep > timestep) return false;  // none at this step; kept for a later frame
      contact_pending_ = false;
      if (pending_.timestep == timestep) {
        const bool read = contact_reader_->ReadContacts(pending_);
        std::swap(out, pending_);
        return read;
      }
      if (!contact_reader_->SkipContacts()) {
        contact_reader_.reset();
        return false;
      }
    }
  }

  rundir::FrameReader frames_;
  std::vector<FrameSelector>& selectors_;
  std::optional<rundir::ContactReader> contact_reader_;
  rundir::ContactFrame pending_;
  bool contact_pending_ = false;
  int parsed_ = 0;
};

void Deliver(const FrameItem& item, const std::vector<RunAccumulator*>& accumulators) {
  const FrameView view{item.frame, item.bodies, item.has_contacts ? &item.contacts : nullptr};
  for (std::size_t k = 0; k < accumulators.size(); ++k)
    if (item.wanted[k]) accumulators[k]->AddFrame(view);
}

// Reading and parsing on a second thread, a few frames ahead of the analyses: the reader
// fills free items, the analyses empty full ones, in order.
int StreamWithReadAhead(FrameSource& source, const std::vector<RunAccumulator*>& accumulators) {
  constexpr std::size_t kItems = 3;
  std::vector<FrameItem> items(kItems);
  std::deque<FrameItem*> free_items, full_items;
  for (FrameItem& it : items) free_items.push_back(&it);
  std::mutex mutex;
  std::condition_variable changed;
  bool finished = false, stop = false;
  std::exception_ptr reader_error;
  std::thread reader([&] {
    try {
      for (;;) {
        FrameItem* item = nullptr;
        {
          std::unique_lock<std::mutex> lock(mutex);
          changed.wait(lock, [&] { return stop || !free_items.empty(); });
          if (stop) break;
          item = free_items.front();
          free_items.pop_front();
        }
        const bool more = source.Next(*item);
        std::lock_guard<std::mutex> lock(mutex);
        if (!more) {
          free_items.push_back(item);
          break;
        }
        full_items.push_back(item);
        changed.notify_all();
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(mutex);
      reader_error = std::current_exception();
    }
    std::lock_guard<std::mutex> lock(mutex);
    finished = true;
    changed.notify_all();
  });
  auto stop_reader = [&] {
    {
      std::lock_guard<std::mutex> lock(mutex);
      stop = true;
      changed.notify_all();
    }
    reader.join();
  };
  try {
    for (;;) {
      FrameItem* item = nullptr;
      {
        std::unique_lock<std::mutex> lock(mutex);
        changed.wait(lock, [&] { return finished || !full_items.empty(); });
        if (full_items.empty()) break;
        item = full_items.front();
        full_items.pop_front();
      }
      Deliver(*item, accumulators);
      std::lock_guard<std::mutex> lock(mutex);
      free_items.push_back(item);
      changed.notify_all();
    }
  } catch (...) {
    stop_reader();
    throw;
  }
  stop_reader();
  if (reader_error) std::rethrow_exception(reader_error);
  return source.Parsed();
}

int Stream(FrameSource& source, const std::vector<RunAccumulator*>& accumulators) {
  FrameItem item;
  while (source.Next(item)) Deliver(item, accumulators);
  return source.Parsed();
}

nlohmann::json PassJson(const PassOptions& p, const PassUse& use) {
  nlohmann::json j = nlohmann::json::object();
  if (use.window)
    j["window"] = {{"start_time", p.window.start_time},
                   {"start_fraction", p.window.start_fraction},
                   {"shallow_fraction", p.window.shallow_fraction},
                   {"stop_at_first_clog", p.window.stop_at_first_clog},
                   {"min_events", p.window.min_events},
                   {"min_exits_before_clog", p.window.min_exits_before_clog}};
  if (use.clog_gap) j["clog_gap"] = p.clog_gap;
  if (use.frames) j["frames"] = {{"stride", p.frame_stride}, {"max", p.max_frames}};
  return j;
}

}  // namespace

nlohmann::json CacheKey(const Analysis& a, const PassOptions& pass) {
  return {{"analysis", a.Key()},
          {"version", a.Version()},
          {"options", a.RunOptions()},
          {"pass", PassJson(pass, a.PassOptionsUsed())}};
}

RunView MakeRunView(const rundir::RunData& data, const PassOptions& pass) {
  RunView v;
  v.data = &data;
  v.options = &pass;
  const nlohmann::json& spec = data.spec;
  const nlohmann::json none = nlohmann::json::object();
  const nlohmann::json discharge = spec.is_object() ? spec.value("discharge", none) : none;
  v.run_id =
      data.summary.run_id.empty() && spec.is_object() ? spec.value("run_id", std::string()) : data.summary.run_id;
  v.engine = !data.summary.engine.empty() ? data.summary.engine
                                          : (spec.is_object() ? spec.value("engine", std::string("native")) : "native");
  v.end_reason = data.summary.end_reason;
  v.remove_mode = discharge.value("mode", std::string("remove")) == "remove";
  v.stop_on_clog = discharge.value("stop_on_clog", true);
  v.on_clog = discharge.value("on_clog", std::string(v.stop_on_clog ? "stop" : "wait"));
  v.bodies = data.summary.bodies;
  if (v.bodies == 0 && spec.is_object() && spec.contains("bodies")) v.bodies = spec.at("bodies").value("count", 0);
  v.exited = data.has_summary ? data.summary.exited : static_cast<int>(data.events.size());
  v.undischarged = data.has_summary ? data.summary.remaining : v.bodies - v.exited;
  v.t_end = data.summary.t_end;
  if (!data.events.empty()) v.t_end = std::max(v.t_end, data.events.back().time);
  v.clog_gap = pass.clog_gap >= 0.0 ? pass.clog_gap : discharge.value("clog_window", 5.0);
  if (spec.is_object() && spec.contains("bodies")) v.density = spec.at("bodies").value("density", 1.0);
  v.outlets = OutletsOf(spec);
  v.flow = MeasureFlowRate({data.events, v.remove_mode, v.bodies, v.clog_gap, -1, v.t_end, v.on_clog == "stop"},
                           pass.window);
  const ClogSeries series =
      ComputeClogSeries(data.events, -1, v.t_end, v.clog_gap, RunEndOf(v.end_reason), v.stop_on_clog);
  for (const Stretch& c : series.clogged) v.clogged.push_back({c.start, c.end});
  v.steady.start = pass.window.start_time;
  if (v.flow.ok) {
    v.steady = {v.flow.t_start, v.flow.t_end};
  } else if (v.flow.startup_clog) {
    v.steady.end = v.steady.start - 1.0;  // a start-up clog: no frames of steady flow at all
  } else if (!series.flowing.empty() && series.flowing.front().complete && series.flowing.front().exits > 0) {
    v.steady.end = series.flowing.front().end;  // no steady window: still only frames before the first clog
  }
  return v;
}

RunPassResult AnalyseRun(const std::filesystem::path& dir, const std::vector<const Analysis*>& analyses,
                         const PassOptions& pass, const RunPassOptions& options) {
  RunPassResult out;
  out.results.assign(analyses.size(), nullptr);
  // What a killed writer left: analyses/*.json.tmp.PID (a killed pass), progress.json.tmp.PID
  // (a killed engine).
  if (options.write_cache) {
    RemoveStaleTemporaries(dir);
    RemoveStaleTemporaries(dir / rundir::kAnalysesDir);
  }
  // A cached result belongs to this summary.json: a run run again is analysed again.
  std::string summary_hash;
  if (std::filesystem::exists(dir / rundir::kSummaryFile))
    summary_hash = HashHex(ReadWholeFile(dir / rundir::kSummaryFile));
  std::vector<nlohmann::json> keys;
  std::vector<std::size_t> missing;
  for (std::size_t k = 0; k < analyses.size(); ++k) {
    keys.push_back(CacheKey(*analyses[k], pass));
    if (options.read_cache && !summary_hash.empty()) {
      const auto cached = rundir::ReadCachedResult(dir, analyses[k]->Key());
      const bool recompute = cached && cached->result.is_object() && cached->result.value(kRecompute, false);
      if (cached && cached->key == keys[k] && cached->summary_hash == summary_hash && !recompute) {
        out.results[k] = cached->result;
        ++out.from_cache;
        continue;
      }
    }
    missing.push_back(k);
  }
  if (missing.empty()) return out;

  const rundir::RunData data = rundir::ReadRun(dir);
  const RunView view = MakeRunView(data, pass);
  std::vector<std::unique_ptr<RunAccumulator>> accumulators;
  std::vector<RunAccumulator*> raw;
  std::vector<FrameSelector> selectors;
  for (std::size_t k : missing) {
    accumulators.push_back(analyses[k]->Start(view));
    raw.push_back(accumulators.back().get());
    selectors.emplace_back(raw.back()->Frames(), pass);
  }
  const bool wants_frames =
      std::any_of(selectors.begin(), selectors.end(), [](const FrameSelector& s) { return !s.Done(); });
  // Frames removed by campaign clean --frames: an analysis not cached before cannot be computed.
  if (wants_frames && !data.frames_dropped.empty()) throw rundir::ReadError(data.frames_dropped);
  const bool frames = data.has_frames && wants_frames;
  if (frames) {
    FrameSource source(data, view.density, selectors);
    out.frames_parsed = options.threads >= 2 ? StreamWithReadAhead(source, raw) : Stream(source, raw);
  }
  for (std::size_t i = 0; i < missing.size(); ++i) {
    const std::size_t k = missing[i];
    out.results[k] = raw[i]->Finish();
    if (!options.write_cache || summary_hash.empty()) continue;
    try {
      rundir::WriteCachedResult(dir, {analyses[k]->Key(), keys[k], summary_hash, out.results[k]});
    } catch (const std::exception&) {
      // A run directory we may not write (shared, read-only): the result is used, not kept.
    }
  }
  return out;
}

}  // namespace granary::analysis

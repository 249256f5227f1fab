// See cg_run.h.
#include "analysis/cg_run.h"

#include <omp.h>

#include <algorithm>
#include <exception>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "rundir/contacts.h"
#include "rundir/frames.h"

namespace granary::analysis {

const rundir::ContactFrame* ContactFrameMatcher::At(std::int64_t timestep) {
  while (!done_) {
    if (!pending_) {
      if (!reader_.NextHeader(frame_)) {
        done_ = true;
        break;
      }
      pending_ = true;
    }
    if (frame_.timestep < timestep) {  // its rows are skipped, not parsed
      pending_ = false;
      continue;
    }
    if (frame_.timestep == timestep) {
      pending_ = false;
      if (reader_.ReadContacts(frame_)) return &frame_;
      done_ = true;  // cut short at the end of the file
      break;
    }
    break;
  }
  return nullptr;
}

Rect CgRunWindow(const rundir::RunData& data) {
  double width = 100.0;
  if (data.spec.is_object() && data.spec.contains("silo") && data.spec.at("silo").is_object())
    width = data.spec.at("silo").value("width", 100.0);
  double top = data.has_summary ? data.summary.bed.height : 0.0;
  if (!(top > 0.0) && data.has_frames) {
    rundir::FrameReader reader(data.FramesFile());
    rundir::Frame frame;
    if (reader.Next(frame))
      for (const rundir::Disc& d : frame.discs) top = std::max(top, d.y + d.radius);
  }
  if (!(top > 0.0)) top = 148.5;
  return CgDefaultWindow(width, top);
}

CgRunResult CgFieldsOfRun(const rundir::RunData& data, const CgRunOptions& options) {
  CgRunResult result;
  CgOptions cg = options.cg;
  if (!(cg.window.x1 > cg.window.x0)) cg.window = CgRunWindow(data);
  result.window = cg.window;
  const int parts = options.route ? std::max(1, options.parts) : 1;
  std::vector<CgAccumulator> acc;
  for (int p = 0; p < parts; ++p) acc.emplace_back(cg, options.series);
  if (!data.has_frames) {
    for (auto& a : acc) result.parts.push_back(a.Sums());
    return result;
  }
  double density = 1.0;
  if (data.spec.is_object() && data.spec.contains("bodies") && data.spec.at("bodies").is_object())
    density = data.spec.at("bodies").value("density", 1.0);
  rundir::FrameReader frames(data.FramesFile(), density);
  std::optional<ContactFrameMatcher> contacts;
  if (options.contacts && data.has_contacts) contacts.emplace(data.ContactsFile());
  result.has_contacts = contacts.has_value();
  rundir::Frame frame;
  int in_range = 0, used = 0;
  const bool two_readers = contacts && (cg.threads > 0 ? cg.threads : omp_get_max_threads()) >= 2;
  // Frames nobody wants are skipped on their header (their rows are not parsed).
  while (frames.NextHeader(frame)) {
    ++result.frames_read;
    if (frame.time > options.t_end) break;  // frames are in time order
    if (frame.time < options.t_start) continue;
    if (in_range++ % std::max(1, options.frame_stride) != 0) continue;
    const int part = options.route ? options.route(frame.time) : 0;
    if (part < 0) continue;
    if (part >= parts) throw std::invalid_argument("cg_fields_of_run: route gave part " + std::to_string(part));
    // The discs and the contact frame of the same step, on two threads when there are two
    // (the two files are independent; reading is otherwise the serial part).
    bool discs_read = false;
    const rundir::ContactFrame* c = nullptr;
    std::exception_ptr errors[2];
#pragma omp parallel sections num_threads(2) if (two_readers)
    {
#pragma omp section
      try {
        discs_read = frames.ReadDiscs(frame);
      } catch (...) {
        errors[0] = std::current_exception();
      }
#pragma omp section
      try {
        if (contacts) c = contacts->At(frame.timestep);
      } catch (...) {
        errors[1] = std::current_exception();
      }
    }
    for (const std::exception_ptr& e : errors)
      if (e) std::rethrow_exception(e);
    if (!discs_read) break;  // cut short at the end of the file (an engine still writing)
    acc[static_cast<std::size_t>(part)].AddFrame(frame.time, frame.discs, c);
    if (c == nullptr) ++result.frames_without_contacts;
    if (used++ == 0) result.first_time = frame.time;
    result.last_time = frame.time;
    if (options.max_frames > 0 && used >= options.max_frames) break;
  }
  for (auto& a : acc) result.parts.push_back(a.Sums());
  // Each part has the series of its frames; together they are the series of every frame used.
  result.series = acc.front().Series();
  for (std::size_t p = 1; p < acc.size(); ++p)
    for (std::size_t k = 0; k < result.series.size(); ++k) {
      const CgSeries& s = acc[p].Series()[k];
      CgSeries& out = result.series[k];
      out.time.insert(out.time.end(), s.time.begin(), s.time.end());
      out.value.insert(out.value.end(), s.value.begin(), s.value.end());
    }
  for (CgSeries& s : result.series) {
    std::vector<std::size_t> order(s.time.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return s.time[a] < s.time[b]; });
    std::vector<double> t, v;
    for (std::size_t i : order) {
      t.push_back(s.time[i]);
      v.push_back(s.value[i]);
    }
    s.time = std::move(t);
    s.value = std::move(v);
  }
  return result;
}

}  // namespace granary::analysis

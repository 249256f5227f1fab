// granary-read-run: what the C++ run-directory readers (src/rundir) return, as JSON, so that the
// Python package's readers (python/granary) are checked against them number for number
// (python/tests/test_readers.py), and how long they take (the benchmark of docs/benchmarks.md).
// Usage:
//   granary-read-run frames FILE      every frame: timestep, time, box, discs, bodies
//   granary-read-run contacts FILE    every contact frame
//   granary-read-run clogs DIR        every clog: its frame and its contact frame
//   granary-read-run events FILE      the exit events
//   granary-read-run bench DIR [--repeat R]   seconds per frame (wall and CPU) to read frames.dump
//                                     with its contacts.dump and rebuild the bodies (best of R passes)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>

#include "rundir/clogs.h"
#include "rundir/contacts.h"
#include "rundir/events.h"
#include "rundir/frames.h"
#include "rundir/run_directory.h"

namespace {

namespace fs = std::filesystem;
namespace rd = granary::rundir;
using nlohmann::json;

json Box(const double (&box)[3][2]) {
  return json::array({{box[0][0], box[0][1]}, {box[1][0], box[1][1]}, {box[2][0], box[2][1]}});
}

json FrameJson(const rd::Frame& f) {
  json discs = json::array(), bodies = json::array();
  for (const rd::Disc& d : f.discs)
    discs.push_back({d.id, d.mol, d.type, d.x, d.y, d.radius, d.mass, d.vx, d.vy, d.omega});
  for (const rd::Body& b : rd::BodiesOf(f.discs))
    bodies.push_back({b.id, b.type, b.n_discs, b.mass, b.x, b.y, b.vx, b.vy, b.omega, b.inertia, b.theta, b.area});
  return {{"timestep", f.timestep}, {"time", f.time}, {"box", Box(f.box)}, {"discs", discs}, {"bodies", bodies}};
}

json ContactJson(const rd::ContactFrame& f) {
  json rows = json::array();
  for (const rd::ContactRow& c : f.contacts)
    rows.push_back({c.body_i, c.body_j, c.xi, c.yi, c.xj, c.yj, c.cx, c.cy, c.fx, c.fy});
  return {{"timestep", f.timestep}, {"time", f.time}, {"box", Box(f.box)}, {"contacts", rows}};
}

int Bench(const fs::path& dir, int repeat) {
  const rd::RunData run = rd::ReadRun(dir);
  double best = 1e300, best_cpu = 1e300;
  long frames = 0, discs = 0, contacts = 0;
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    rd::FrameReader fr(run.FramesFile());
    rd::ContactReader cr(run.ContactsFile());
    rd::Frame f;
    rd::ContactFrame c;
    frames = discs = contacts = 0;
    double checksum = 0;
    while (fr.Next(f) && cr.Next(c)) {
      const auto bodies = rd::BodiesOf(f.discs);
      checksum += bodies.empty() ? 0.0 : bodies.back().x;
      ++frames;
      discs += static_cast<long>(f.discs.size());
      contacts += static_cast<long>(c.contacts.size());
    }
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    best = std::min(best, s);
    best_cpu = std::min(best_cpu, static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
    if (!std::isfinite(checksum)) std::cerr << "non-finite body position\n";
  }
  if (frames == 0) {
    std::cerr << dir.string() << ": no frames with contacts\n";
    return 1;
  }
  std::cout << json{{"frames", frames},
                    {"discs_per_frame", discs / frames},
                    {"contacts_per_frame", contacts / frames},
                    {"seconds_per_frame", best / static_cast<double>(frames)},
                    {"cpu_seconds_per_frame", best_cpu / static_cast<double>(frames)},
                    {"repeat", repeat}}
                   .dump()
            << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: granary-read-run frames|contacts|events FILE | clogs DIR | bench DIR [--repeat R]\n";
    return 2;
  }
  const std::string what = argv[1];
  const fs::path path = argv[2];
  try {
    json out = json::array();
    if (what == "frames") {
      rd::FrameReader reader(path);
      rd::Frame f;
      while (reader.Next(f)) out.push_back(FrameJson(f));
    } else if (what == "contacts") {
      rd::ContactReader reader(path);
      rd::ContactFrame c;
      while (reader.Next(c)) out.push_back(ContactJson(c));
    } else if (what == "clogs") {
      for (const rd::ClogState& clog : rd::ReadClogs(path))
        out.push_back({{"frame", FrameJson(clog.frame)}, {"contacts", ContactJson(clog.contacts)}});
    } else if (what == "events") {
      for (const rd::ExitEvent& e : rd::ReadEvents(path)) out.push_back({e.time, e.body, e.shape, e.mass, e.outlet});
    } else if (what == "bench") {
      const int repeat = argc >= 5 && std::string(argv[3]) == "--repeat" ? std::stoi(argv[4]) : 3;
      return Bench(path, std::max(repeat, 1));
    } else {
      std::cerr << "granary-read-run: unknown '" << what << "' (frames, contacts, clogs, events, bench)\n";
      return 2;
    }
    std::cout << out.dump() << "\n";
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
  return 0;
}

// Bed preparation: batch insertion, settling with the outlets plugged, the bed file and its
// cache lock.
#include "engine/bed.h"

#include "rundir/files.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <stdexcept>

#include "engine/random.h"
#include "engine/world.h"

namespace granary::engine {
namespace {

constexpr double kInsertPackingFraction = 0.3;  // area fraction of a batch's insertion region
constexpr double kSettleCheckInterval = 0.02;   // simulated time between kinetic-energy checks
constexpr long kProgressEvery = 2000;           // steps between progress reports

bool Overlaps(const silo::ShapeTemplate& a, double ax, double ay, double ath, const silo::ShapeTemplate& b, double bx,
              double by, double bth) {
  const double ddx = ax - bx, ddy = ay - by;
  const double reach = a.bound_radius + b.bound_radius;
  if (ddx * ddx + ddy * ddy >= reach * reach) return false;
  const double ca = std::cos(ath), sa = std::sin(ath), cb = std::cos(bth), sb = std::sin(bth);
  for (std::size_t i = 0; i < a.r.size(); ++i) {
    const double xi = ax + ca * a.ox[i] - sa * a.oy[i], yi = ay + sa * a.ox[i] + ca * a.oy[i];
    for (std::size_t j = 0; j < b.r.size(); ++j) {
      const double xj = bx + cb * b.ox[j] - sb * b.oy[j], yj = by + sb * b.ox[j] + cb * b.oy[j];
      const double rr = a.r[i] + b.r[j];
      if ((xi - xj) * (xi - xj) + (yi - yj) * (yi - yj) < rr * rr) return true;
    }
  }
  return false;
}

// Every body's species index, in a random order from `rng`: the order bodies are placed in, so
// that every batch (and the loose placement) is a mixture.
std::vector<int> ShuffledSpecies(const RunSpec& spec, Rng& rng) {
  std::vector<int> order;
  const std::vector<int> counts = silo::SpeciesCounts(spec.bodies);
  for (std::size_t k = 0; k < counts.size(); ++k)
    order.insert(order.end(), static_cast<std::size_t>(counts[k]), static_cast<int>(k));
  for (std::size_t i = order.size(); i > 1; --i) {
    const std::size_t j = static_cast<std::size_t>(rng.Next() % i);
    std::swap(order[i - 1], order[j]);
  }
  return order;
}

}  // namespace

std::vector<silo::ShapeTemplate> MakeTemplates(const RunSpec& spec) {
  std::vector<silo::ShapeTemplate> t;
  for (std::size_t k = 0; k < spec.bodies.species.size(); ++k)
    t.push_back(silo::MakeTemplate(spec.bodies.species[k], spec.bodies.density, static_cast<int>(k)));
  return t;
}

BedState PrepareBed(const RunSpec& spec, const BedProgress& progress, double skin) {
  std::vector<silo::ShapeTemplate> templates = MakeTemplates(spec);
  // The bed never sees outlets or obstacles (bed_key): a closed silo whose walls are one
  // segment per side, so element index = Side.
  Silo closed;
  closed.width = spec.silo.width;
  // The bed is prepared at its own, longer time step (BedTimeStep(), docs/run-spec.md):
  // a settled bed does not depend on it, and most of the preparation is free fall.
  WorldParams params = ParamsFromSpec(spec);
  params.dt = spec.BedTimeStep();
  params.skin = skin;
  World world(params, templates, silo::BuildGeometry(closed, kTallWall));
  Rng rng(spec.seed);

  // Bodies in random order so that every batch is a mixture.
  const std::vector<int> order = ShuffledSpecies(spec, rng);
  double mean_mass = 0.0;
  for (int s : order) mean_mass += templates[static_cast<std::size_t>(s)].mass;
  mean_mass /= static_cast<double>(order.size());
  const double energy_unit = mean_mass * spec.gravity * 1.0;  // m g d with d = 1
  const double hw = spec.silo.width / 2;
  const double dt = params.dt;
  const long settle_check_every = std::max(1L, std::lround(kSettleCheckInterval / dt));
  double t = 0.0;
  std::size_t inserted = 0;
  const std::size_t total = order.size();

  while (inserted < total) {
    const std::size_t batch_end = std::min(total, inserted + static_cast<std::size_t>(spec.bed.batch_size));
    double area = 0.0;
    for (std::size_t k = inserted; k < batch_end; ++k) area += templates[static_cast<std::size_t>(order[k])].area;
    double height = area / (spec.silo.width * kInsertPackingFraction);
    const double y_base = world.MaxDiscTop() + 0.5;
    std::vector<int> placed;
    for (std::size_t k = inserted; k < batch_end; ++k) {
      const silo::ShapeTemplate& tp = templates[static_cast<std::size_t>(order[k])];
      const double rb = tp.bound_radius;
      bool ok = false;
      double x = 0, y = 0, th = 0;
      for (int attempt = 0; !ok; ++attempt) {
        if (attempt > 0 && attempt % 200 == 0) height *= 1.1;  // region too crowded: grow it
        x = rng.Uniform(-hw + rb, hw - rb);
        y = rng.Uniform(y_base + rb, y_base + rb + height);
        th = rng.Uniform(0.0, 2.0 * std::numbers::pi);
        ok = true;
        for (int b : placed) {
          if (Overlaps(tp, x, y, th, templates[static_cast<std::size_t>(world.body_template_[b])], world.body_x_[b],
                       world.body_y_[b], world.body_angle_[b])) {
            ok = false;
            break;
          }
        }
      }
      placed.push_back(world.AddBody(order[k], x, y, th));
    }
    inserted = batch_end;
    world.ComputeForces();
    // Let the batch fall through its region before the next one is placed above it.
    const double fall = std::sqrt(2.0 * height / spec.gravity) + 1.0;
    const long steps = inserted < total ? std::lround(fall / dt) : 0;
    bool fell = false;
    for (long s = 0; s < steps; ++s) {
      world.Step();
      t += dt;
      if (progress && s % kProgressEvery == 0)
        progress(0.5 * static_cast<double>(inserted) / static_cast<double>(total), t);
      if (spec.bed.next_batch == NextBatch::kLanded && (s + 1) % settle_check_every == 0) {
        // Serially over the batch in placement order: the same sum at any thread count.
        double ke = 0.0;
        for (int b : placed)
          ke += world.body_mass_[b] * (world.body_vx_[b] * world.body_vx_[b] + world.body_vy_[b] * world.body_vy_[b]);
        ke *= 0.5 / (static_cast<double>(placed.size()) * energy_unit);
        if (ke > kBedLandedKePerBody)
          fell = true;
        else if (fell)
          break;
      }
    }
  }
  // Settle until the kinetic energy per body is negligible (or give up at max_settle_time).
  const double t_settle0 = t;
  double ke = 1.0;
  for (long s = 1;; ++s) {
    world.Step();
    t += dt;
    if (s % settle_check_every == 0) {
      ke = world.KineticEnergy() / static_cast<double>(world.ActiveCount()) / energy_unit;
      if (ke < spec.bed.settle_ke_per_body || t - t_settle0 >= spec.bed.max_settle_time) break;
    }
    if (progress && s % kProgressEvery == 0) {
      const double f = std::clamp(std::log(ke) / std::log(spec.bed.settle_ke_per_body), 0.0, 1.0);
      progress(0.5 + 0.5 * std::max(f, (t - t_settle0) / spec.bed.max_settle_time), t);
    }
  }
  // Body ids in spatial order (bands of height 2 d, serpentine in x), so that touching
  // discs are near in memory during the discharge (about 15 % faster force loops).
  const int nb = world.BodyCount();
  std::vector<int> order_new(static_cast<std::size_t>(nb));
  for (int b = 0; b < nb; ++b) order_new[b] = b;
  auto key = [&](int b) {
    const double band = std::floor(world.body_y_[b] / 2.0);
    const bool even = static_cast<long>(band) % 2 == 0;
    return std::pair{band, even ? world.body_x_[b] : -world.body_x_[b]};
  };
  std::stable_sort(order_new.begin(), order_new.end(), [&](int a, int b) { return key(a) < key(b); });
  BedState bed;
  std::vector<int> new_disc(static_cast<std::size_t>(world.DiscCount()));
  int next_disc = 0;
  for (int b : order_new) {
    bed.species.push_back(world.body_template_[b]);
    bed.x.push_back(world.body_x_[b]);
    bed.y.push_back(world.body_y_[b]);
    bed.theta.push_back(world.body_angle_[b]);
    bed.vx.push_back(world.body_vx_[b]);
    bed.vy.push_back(world.body_vy_[b]);
    bed.omega.push_back(world.body_spin_[b]);
    for (int k = 0; k < world.body_disc_count_[b]; ++k) new_disc[world.body_first_disc_[b] + k] = next_disc++;
  }
  world.RebuildNow();
  world.ExportHistory(bed.pair_history, bed.wall_history);
  for (HistoryEntry& h : bed.pair_history) {
    h.i = new_disc[h.i];
    h.j = new_disc[h.j];
    if (h.i > h.j) {  // xi integrates v_i - v_j: swapping the discs flips its sign
      std::swap(h.i, h.j);
      h.sx = -h.sx;
      h.sy = -h.sy;
    }
  }
  for (HistoryEntry& h : bed.wall_history) h.i = new_disc[h.i];
  for (auto* v : {&bed.pair_history, &bed.wall_history})
    std::sort(v->begin(), v->end(),
              [](const HistoryEntry& a, const HistoryEntry& b) { return a.i != b.i ? a.i < b.i : a.j < b.j; });
  bed.height = world.MaxDiscTop();
  bed.settle_time = t;
  return bed;
}

BedState LoosePlacement(const RunSpec& spec) {
  const std::vector<silo::ShapeTemplate> templates = MakeTemplates(spec);
  Rng rng(spec.seed);
  const std::vector<int> order = ShuffledSpecies(spec, rng);
  // One region for all bodies, as loose as a batch's, from just above the base; a grid of
  // cells of the largest bounding diameter finds the neighbours to test.
  double area = 0.0, cell = 0.0;
  for (int k : order) {
    area += templates[static_cast<std::size_t>(k)].area;
    cell = std::max(cell, 2 * templates[static_cast<std::size_t>(k)].bound_radius);
  }
  double height = area / (spec.silo.width * kInsertPackingFraction);
  const double hw = spec.silo.width / 2, y_base = 0.5;
  std::map<std::pair<long, long>, std::vector<int>> grid;
  BedState bed;
  for (int k : order) {
    const silo::ShapeTemplate& tp = templates[static_cast<std::size_t>(k)];
    const double rb = tp.bound_radius;
    double x = 0, y = 0, th = 0;
    for (int attempt = 0;; ++attempt) {
      if (attempt > 0 && attempt % 200 == 0) height *= 1.1;  // region too crowded: grow it
      x = rng.Uniform(-hw + rb, hw - rb);
      y = rng.Uniform(y_base + rb, y_base + rb + height);
      th = rng.Uniform(0.0, 2.0 * std::numbers::pi);
      const long cx = std::lround(std::floor(x / cell)), cy = std::lround(std::floor(y / cell));
      bool ok = true;
      for (long i = cx - 1; i <= cx + 1 && ok; ++i)
        for (long j = cy - 1; j <= cy + 1 && ok; ++j) {
          const auto it = grid.find({i, j});
          if (it == grid.end()) continue;
          for (int b : it->second)
            if (Overlaps(tp, x, y, th, templates[static_cast<std::size_t>(bed.species[b])], bed.x[b], bed.y[b],
                         bed.theta[b])) {
              ok = false;
              break;
            }
        }
      if (!ok) continue;
      grid[{cx, cy}].push_back(static_cast<int>(bed.species.size()));
      break;
    }
    bed.species.push_back(k);
    bed.x.push_back(x);
    bed.y.push_back(y);
    bed.theta.push_back(th);
    bed.vx.push_back(0.0);
    bed.vy.push_back(0.0);
    bed.omega.push_back(0.0);
    bed.height = std::max(bed.height, y + rb);
  }
  return bed;
}

namespace {

constexpr int kBedVersion = 3;  // 2: with contact history; 3: with a checksum

// "crc32:" and the CRC-32 of the document's dump without its "checksum" key.
std::string BedChecksum(nlohmann::json j) {
  j.erase("checksum");
  char hex[16];
  std::snprintf(hex, sizeof hex, "%08x", Crc32(j.dump()));
  return std::string("crc32:") + hex;
}

}  // namespace

nlohmann::json BedToJson(const BedState& bed, const RunSpec& spec) {
  nlohmann::json j;
  j["format"] = "granary-bed";
  j["version"] = kBedVersion;
  j["key"] = spec.BedKey();
  j["height"] = bed.height;
  j["settle_time"] = bed.settle_time;
  nlohmann::json rows = nlohmann::json::array();
  for (std::size_t b = 0; b < bed.x.size(); ++b)
    rows.push_back({bed.species[b], bed.x[b], bed.y[b], bed.theta[b], bed.vx[b], bed.vy[b], bed.omega[b]});
  j["bodies"] = std::move(rows);
  for (const auto* h : {&bed.pair_history, &bed.wall_history}) {
    nlohmann::json hist = nlohmann::json::array();
    for (const HistoryEntry& e : *h) hist.push_back({e.i, e.j, e.sx, e.sy});
    j[h == &bed.pair_history ? "pair_history" : "wall_history"] = std::move(hist);
  }
  j["checksum"] = BedChecksum(j);
  return j;
}

BedState BedFromJson(const nlohmann::json& j, const RunSpec& spec, const std::string& file) {
  if (!j.is_object() || j.value("format", "") != "granary-bed")
    throw BedFileError("bed file " + file + ": not a granary bed (format " +
                       (j.is_object() ? j.value("format", "?") : std::string("?")) + ")");
  if (j.value("version", 0) != kBedVersion)
    throw BedFileError("bed file " + file + " has format version " + std::to_string(j.value("version", 0)) +
                       "; this engine reads version " + std::to_string(kBedVersion) + " (with a checksum)");
  if (const std::string actual = BedChecksum(j); j.value("checksum", "") != actual)
    throw BedFileError("bed file " + file + " is corrupt: its checksum is " + j.value("checksum", "missing") +
                       ", its content gives " + actual);
  if (j.at("key") != spec.BedKey())
    throw std::runtime_error("bed file " + file +
                             " was prepared for another bed key (bodies, width, seed, ...): " + j.at("key").dump());
  BedState bed;
  bed.height = j.at("height").get<double>();
  bed.settle_time = j.at("settle_time").get<double>();
  for (const auto& row : j.at("bodies")) {
    bed.species.push_back(row.at(0).get<int>());
    bed.x.push_back(row.at(1).get<double>());
    bed.y.push_back(row.at(2).get<double>());
    bed.theta.push_back(row.at(3).get<double>());
    bed.vx.push_back(row.at(4).get<double>());
    bed.vy.push_back(row.at(5).get<double>());
    bed.omega.push_back(row.at(6).get<double>());
  }
  for (auto* h : {&bed.pair_history, &bed.wall_history}) {
    const char* key = h == &bed.pair_history ? "pair_history" : "wall_history";
    if (!j.contains(key)) continue;  // version 1 beds carry no history
    for (const auto& row : j.at(key))
      h->push_back({row.at(0).get<std::int32_t>(), row.at(1).get<std::int32_t>(), row.at(2).get<double>(),
                    row.at(3).get<double>()});
  }
  if (static_cast<int>(bed.x.size()) != spec.bodies.count)
    throw std::runtime_error("bed file " + file + " holds " + std::to_string(bed.x.size()) +
                             " bodies, the spec wants " + std::to_string(spec.bodies.count));
  return bed;
}

namespace {

BedState ReadBedFile(const std::string& file, const RunSpec& spec) {
  std::ifstream in(file);
  if (!in) throw BedFileError("cannot read bed file " + file);
  nlohmann::json j;
  try {
    in >> j;
  } catch (const std::exception& e) {
    throw BedFileError("bed file " + file + " is not valid JSON (torn or corrupt): " + e.what());
  }
  return BedFromJson(j, spec, file);
}

}  // namespace

ObtainedBed ObtainBed(const RunSpec& spec, const std::string& run_dir, const BedProgress& progress) {
  ObtainedBed out;
  out.file = spec.bed.cache_file.empty() ? (std::filesystem::path(run_dir) / "bed.json").string() : spec.bed.cache_file;
  const auto start = std::chrono::steady_clock::now();
  const std::filesystem::path parent = std::filesystem::path(out.file).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  FileLock lock(out.file + ".lock");
  bool have = false;
  if (std::filesystem::exists(out.file)) {
    try {
      out.bed = ReadBedFile(out.file, spec);
      have = true;
    } catch (const BedFileError& e) {
      // A bad cached bed is never used: it is put aside and prepared again.
      std::fprintf(stderr, "granary-engine: refusing the prepared bed: %s; preparing it again\n", e.what());
      std::filesystem::rename(out.file, out.file + ".corrupt");
      out.refused = e.what();
    }
  }
  if (!have) {
    out.bed = PrepareBed(spec, progress);
    WriteAtomically(out.file, BedToJson(out.bed, spec).dump() + "\n");
    out.prepared_here = true;
  }
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

BedShape MeasureBed(const BedState& bed, const RunSpec& spec) {
  const std::vector<silo::ShapeTemplate> templates = MakeTemplates(spec);
  const double hw = spec.silo.width / 2;
  std::vector<double> dx, dy, dr;  // the discs
  for (std::size_t b = 0; b < bed.x.size(); ++b) {
    const silo::ShapeTemplate& t = templates[static_cast<std::size_t>(bed.species[b])];
    const double c = std::cos(bed.theta[b]), s = std::sin(bed.theta[b]);
    for (std::size_t k = 0; k < t.r.size(); ++k) {
      dx.push_back(bed.x[b] + c * t.ox[k] - s * t.oy[k]);
      dy.push_back(bed.y[b] + s * t.ox[k] + c * t.oy[k]);
      dr.push_back(t.r[k]);
    }
  }
  BedShape shape;
  const int columns = std::max(1, static_cast<int>(std::floor(spec.silo.width - 4.0)));
  std::vector<double> column_top(static_cast<std::size_t>(columns), 0.0);
  for (std::size_t i = 0; i < dx.size(); ++i) {
    shape.top = std::max(shape.top, dy[i] + dr[i]);
    const int col = static_cast<int>(std::floor(dx[i] - (-hw + 2.0)));
    if (col >= 0 && col < columns) column_top[col] = std::max(column_top[col], dy[i] + dr[i]);
  }
  for (double top : column_top) shape.surface += top / columns;
  // Area of a disc between the lines y0 < y1: the disc minus its circular segments beyond them.
  auto segment = [](double r, double h) {  // the part of a disc of radius r beyond a chord h from its centre
    if (h >= r) return 0.0;
    if (h <= -r) return std::numbers::pi * r * r;
    return r * r * std::acos(h / r) - h * std::sqrt(r * r - h * h);
  };
  const double y0 = 5.0, y1 = shape.surface - 5.0;
  double area = 0.0;
  for (std::size_t i = 0; i < dx.size(); ++i)
    area += std::numbers::pi * dr[i] * dr[i] - segment(dr[i], dy[i] - y0) - segment(dr[i], y1 - dy[i]);
  shape.phi = y1 > y0 ? area / (spec.silo.width * (y1 - y0)) : 0.0;
  return shape;
}

}  // namespace granary::engine

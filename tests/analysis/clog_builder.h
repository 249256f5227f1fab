// A clogged configuration made by hand for the clogged-state analyses' tests: bodies of
// touching discs and the contacts they make.
#pragma once

#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/arches.h"
#include "silo/geometry.h"
#include "rundir/clogs.h"

namespace granary::analysis::testing {

// A clog made by hand: bodies of touching discs and the contacts they make (every pair of discs
// of different bodies closer than their radii + 0.01 touches, and every disc on a wall or an
// obstacle, with a unit force pushing them apart), in a silo of width 12.
class Clog {
 public:
  explicit Clog(nlohmann::json silo) : spec_({{"silo", std::move(silo)}}) { spec_["silo"]["width"] = 12; }
  // A body of the given discs (x, y, radius), species `type`.
  std::int64_t Body(std::vector<std::array<double, 3>> discs, int type = 1) {
    const std::int64_t id = next_body_++;
    for (const auto& d : discs)
      state_.frame.discs.push_back({static_cast<std::int64_t>(state_.frame.discs.size() + 1), id, type, d[0], d[1],
                                    d[2], std::numbers::pi * d[2] * d[2], 0, 0, 0});
    return id;
  }
  std::int64_t Disc(double x, double y, double r = 0.5) { return Body({{x, y, r}}); }
  std::int64_t Dumbbell(double x1, double y1, double x2, double y2) { return Body({{x1, y1, 0.5}, {x2, y2, 0.5}}); }
  // A row of touching unit discs from x = from to x = to at height y (material above an arch).
  void Row(double from, double to, double y) {
    for (double x = from; x <= to + 1e-9; x += 1.0) Disc(x, y);
  }

  const rundir::ClogState& Made() {
    state_.contacts.contacts.clear();
    const auto& d = state_.frame.discs;
    const silo::SiloGeometry g = SiloOf(spec_, 20);
    for (std::size_t i = 0; i < d.size(); ++i) {
      for (std::size_t j = i + 1; j < d.size(); ++j) {
        if (d[i].mol == d[j].mol) continue;
        const double dx = d[j].x - d[i].x, dy = d[j].y - d[i].y, r = std::hypot(dx, dy);
        if (r > d[i].radius + d[j].radius + 0.01) continue;
        state_.contacts.contacts.push_back({d[i].mol, d[j].mol, d[i].x, d[i].y, d[j].x, d[j].y,
                                            d[i].x + d[i].radius * dx / r, d[i].y + d[i].radius * dy / r, -dx / r,
                                            -dy / r});
      }
      for (const silo::WallElement& e : g.elements) {
        if (e.group == silo::WallGroup::kPlug) continue;
        double cx = e.ax, cy = e.ay, reach = d[i].radius + (e.kind == silo::ElementKind::kCircle ? e.radius : 0);
        if (e.kind == silo::ElementKind::kSegment) {
          const silo::Closest q = silo::ClosestPoint(e, d[i].x, d[i].y);
          if (!q.valid) continue;
          cx = q.qx, cy = q.qy;
        }
        const double dx = d[i].x - cx, dy = d[i].y - cy, r = std::hypot(dx, dy);
        if (r > reach + 0.01) continue;
        const double px = cx + (e.kind == silo::ElementKind::kCircle ? e.radius * dx / r : 0);
        const double py = cy + (e.kind == silo::ElementKind::kCircle ? e.radius * dy / r : 0);
        state_.contacts.contacts.push_back({d[i].mol, -1, d[i].x, d[i].y, px, py, px, py, dx / r, dy / r});
      }
    }
    return state_;
  }
  const nlohmann::json& Spec() const { return spec_; }

 private:
  nlohmann::json spec_;
  rundir::ClogState state_;
  std::int64_t next_body_ = 0;
};

}  // namespace granary::analysis::testing

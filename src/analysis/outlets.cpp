// See outlets.h.
#include "analysis/outlets.h"

#include <cmath>
#include <numbers>

namespace granary::analysis {

std::vector<OutletGeometry> OutletsOf(const nlohmann::json& spec) {
  std::vector<OutletGeometry> out;
  const nlohmann::json silo =
      spec.is_object() ? spec.value("silo", nlohmann::json::object()) : nlohmann::json::object();
  const double half_width = 0.5 * silo.value("width", 100.0);
  if (silo.contains("base_outlets") && silo.at("base_outlets").is_array()) {
    for (const auto& o : silo.at("base_outlets")) {
      OutletGeometry g;
      g.center = o.value("center", 0.0);
      g.width = o.value("width", 10.0);
      out.push_back(g);
    }
  } else {
    out.push_back(OutletGeometry());
  }
  if (silo.contains("side_outlets") && silo.at("side_outlets").is_array()) {
    for (const auto& o : silo.at("side_outlets")) {
      OutletGeometry g;
      g.base = false;
      g.width = o.value("width", 25.0);
      g.center = o.value("bottom", 3.5) + 0.5 * g.width;
      const std::string wall = o.value("wall", std::string("right"));
      g.right_wall = wall != "left";
      g.wall_x = g.right_wall ? half_width : -half_width;
      g.label = "side " + std::to_string(out.size()) + " (" + wall + ")";
      out.push_back(g);
    }
  }
  for (std::size_t i = 0; i < out.size(); ++i)
    if (out[i].label.empty()) out[i].label = "base " + std::to_string(i);
  return out;
}

std::optional<double> BaseOutletGap(const nlohmann::json& spec) {
  std::vector<OutletGeometry> base;
  for (const OutletGeometry& o : OutletsOf(spec))
    if (o.base) base.push_back(o);
  if (base.size() < 2) return std::nullopt;
  return std::abs(base[1].center - base[0].center) - 0.5 * (base[0].width + base[1].width);
}

void ToOutletFrame(const OutletGeometry& o, std::vector<rundir::Disc>& discs, std::vector<rundir::Body>& bodies) {
  // (x, y) -> (u, n): base: u = x - c, n = y. Right wall: u = y - c, n = X_w - x (a rotation).
  // Left wall: u = y - c, n = x - X_w (a reflection; omega changes sign, its squares do not).
  auto map = [&](double& x, double& y, double& vx, double& vy, double& omega) {
    if (o.base) {
      x -= o.center;
      return;
    }
    const double u = y - o.center, vu = vy;
    if (o.right_wall) {
      y = o.wall_x - x;
      vy = -vx;
    } else {
      y = x - o.wall_x;
      vy = vx;
      omega = -omega;
    }
    x = u;
    vx = vu;
  };
  for (rundir::Disc& d : discs) map(d.x, d.y, d.vx, d.vy, d.omega);
  for (rundir::Body& b : bodies) {
    map(b.x, b.y, b.vx, b.vy, b.omega);
    if (!o.base)
      b.theta = std::remainder(o.right_wall ? b.theta - 0.5 * std::numbers::pi : 0.5 * std::numbers::pi - b.theta,
                               2.0 * std::numbers::pi);
  }
}

std::string OutletSuffix(std::size_t k) { return "_outlet" + std::to_string(k); }

}  // namespace granary::analysis

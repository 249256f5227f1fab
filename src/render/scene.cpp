#include "render/scene.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>

namespace granary::render {

Colour ColourFromName(const std::string& name) {
  if (name == "species") return Colour::kSpecies;
  if (name == "speed") return Colour::kSpeed;
  if (name == "rotation") return Colour::kRotation;
  if (name == "force") return Colour::kForce;
  if (name == "disc") return Colour::kDisc;
  throw std::invalid_argument("colour '" + name + "' is not one of species, speed, rotation, force, disc");
}

namespace {

Rgb Mix(const Rgb& a, const Rgb& b, double t) {
  return {a.r + (b.r - a.r) * t, a.g + (b.g - a.g) * t, a.b + (b.b - a.b) * t};
}
// Piecewise-linear colour map over evenly spaced stops, t clamped to [0, 1].
template <std::size_t N>
Rgb Map(const Rgb (&stops)[N], double t) {
  t = std::clamp(std::isfinite(t) ? t : 0.0, 0.0, 1.0) * (N - 1);
  const std::size_t k = std::min<std::size_t>(static_cast<std::size_t>(t), N - 2);
  return Mix(stops[k], stops[k + 1], t - static_cast<double>(k));
}
constexpr Rgb kViridis[] = {
    {0.267, 0.005, 0.329}, {0.229, 0.322, 0.546}, {0.128, 0.567, 0.551}, {0.369, 0.789, 0.383}, {0.993, 0.906, 0.144}};
constexpr Rgb kDiverging[] = {{0.23, 0.30, 0.75}, {0.87, 0.87, 0.87}, {0.71, 0.02, 0.15}};
constexpr Rgb kHeat[] = {{1.0, 0.96, 0.75}, {0.99, 0.62, 0.26}, {0.80, 0.11, 0.11}, {0.35, 0.0, 0.10}};
constexpr Rgb kSpecies[] = {{0.30, 0.45, 0.69}, {0.87, 0.52, 0.32}, {0.33, 0.66, 0.41},
                            {0.77, 0.31, 0.32}, {0.51, 0.45, 0.70}, {0.58, 0.47, 0.38}};
constexpr Rgb kForceLine = {0.55, 0.0, 0.05};

// The q-quantile of `v` (v is reordered).
double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const auto k = static_cast<std::ptrdiff_t>(std::llround(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<std::size_t>(k)];
}

std::string Fixed(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// The dimension lines of a kDiscs mark: the body whose centre of mass is nearest the mark's
// point; for each disc size (smallest first) the disc of that size farthest from the centre
// (an end of the body), its diameter drawn across the body's axis through it and labelled
// outwards along the axis, so that a snowman's two lines stand apart, each beside its disc.
std::vector<Mark> DiscDimensions(const Mark& m, const std::vector<rundir::Body>& bodies,
                                 const std::vector<rundir::Disc>& discs) {
  const rundir::Body* body = nullptr;
  for (const auto& b : bodies)
    if (!body || std::hypot(b.x - m.x0, b.y - m.y0) < std::hypot(body->x - m.x0, body->y - m.y0)) body = &b;
  if (!body)
    throw std::invalid_argument("the discs' diameters: the frame has no body near (" + Fixed(m.x0) + ", " +
                                Fixed(m.y0) + ") to measure");
  std::vector<const rundir::Disc*> own;
  for (const auto& d : discs)
    if (d.mol == body->id) own.push_back(&d);
  // One disc per size, sizes apart by more than rounding; of equal sizes the farthest out.
  const auto out = [&](const rundir::Disc* d) { return std::hypot(d->x - body->x, d->y - body->y); };
  std::sort(own.begin(), own.end(), [&](const rundir::Disc* a, const rundir::Disc* b) {
    return a->radius != b->radius ? a->radius < b->radius : out(a) > out(b);
  });
  std::vector<const rundir::Disc*> sizes;
  for (const rundir::Disc* d : own)
    if (sizes.empty() || d->radius - sizes.back()->radius > 1e-6 * d->radius) sizes.push_back(d);
  std::vector<std::string> labels = m.labels;
  if (labels.empty()) {
    if (sizes.size() == 1) labels = {"D"};
    if (sizes.size() == 2) labels = {"D_s", "D_b"};
    for (std::size_t k = 0; sizes.size() > 2 && k < sizes.size(); ++k) labels.push_back("D_" + std::to_string(k + 1));
  }
  if (labels.size() != sizes.size())
    throw std::invalid_argument("the discs' diameters: the body nearest (" + Fixed(m.x0) + ", " + Fixed(m.y0) +
                                ") has " + std::to_string(sizes.size()) + " disc size(s), but " +
                                std::to_string(labels.size()) + " label(s) were given (one per size, smallest first)");
  std::vector<Mark> lines;
  for (std::size_t k = 0; k < sizes.size(); ++k) {
    const rundir::Disc& d = *sizes[k];
    // The axis from the body's centre out through this disc; a lone disc (or one at the
    // centre) is measured level and labelled above.
    const double len = out(&d);
    const double ux = len > 1e-9 ? (d.x - body->x) / len : 0.0, uy = len > 1e-9 ? (d.y - body->y) / len : 0.0;
    const double nx = len > 1e-9 ? -uy : 1.0, ny = len > 1e-9 ? ux : 0.0;
    Mark line{Mark::Kind::kDimension, d.x - d.radius * nx, d.y - d.radius * ny,
              d.x + d.radius * nx,    d.y + d.radius * ny, labels[k] + " = " + Fixed(2 * d.radius) + " d"};
    line.away_x = ux;
    line.away_y = uy;
    lines.push_back(line);
  }
  return lines;
}

}  // namespace

Window SiloWindow(const silo::SiloOutline& silo, double exit_distance, double top) {
  Window w{-1, 1, -exit_distance - 1, std::max(top, 1.0) + 1};
  for (const auto* list : {&silo.walls, &silo.outlets})
    for (const auto& s : *list) {
      w.x_lo = std::min({w.x_lo, s.ax - 1, s.bx - 1});
      w.x_hi = std::max({w.x_hi, s.ax + 1, s.bx + 1});
    }
  // Side outlets: room for what falls out beside the silo.
  for (const auto& o : silo.outlets) {
    if (o.ox < 0) w.x_lo = std::min(w.x_lo, o.ax - exit_distance - 1);
    if (o.ox > 0) w.x_hi = std::max(w.x_hi, o.ax + exit_distance + 1);
  }
  return w;
}

Scene MakeScene(const rundir::Frame& frame, const silo::SiloOutline& silo, const SceneOptions& o) {
  Scene scene;
  scene.window = o.window;
  scene.silo = silo;
  scene.caption = o.caption;
  const std::vector<rundir::Body> bodies = rundir::BodiesOf(frame.discs);
  for (const Mark& m : o.marks) {
    if (m.kind != Mark::Kind::kDiscs) {
      scene.marks.push_back(m);
      continue;
    }
    for (Mark& line : DiscDimensions(m, bodies, frame.discs)) scene.marks.push_back(std::move(line));
  }
  std::map<std::int64_t, const rundir::Body*> body_of;
  for (const auto& b : bodies) body_of[b.id] = &b;

  // Per-body value for the continuous colourings.
  std::map<std::int64_t, double> value;
  double lo = 0, hi = 1;
  std::string what;
  if (o.colour == Colour::kSpeed) {
    std::vector<double> all;
    for (const auto& b : bodies) all.push_back(value[b.id] = std::hypot(b.vx, b.vy));
    hi = std::max(Quantile(all, 0.99), 1e-12);
    what = "speed";
  } else if (o.colour == Colour::kRotation) {
    std::vector<double> all;
    for (const auto& b : bodies) all.push_back(std::fabs(value[b.id] = b.omega));
    hi = std::max(Quantile(all, 0.99), 1e-12);
    lo = -hi;
    what = "angular velocity";
  } else if (o.colour == Colour::kForce) {
    if (!o.contacts)
      throw std::invalid_argument("colour by force needs the run's contact frames (output.contact_forces)");
    for (const auto& c : o.contacts->contacts) {
      const double f = std::hypot(c.fx, c.fy);
      value[c.body_i] += f;
      if (c.body_j >= 0) value[c.body_j] += f;
    }
    std::vector<double> all;
    for (const auto& [id, v] : value) all.push_back(v);
    hi = std::max(Quantile(all, 0.99), 1e-12);
    what = "contact force on body";
  }
  // kDisc: each disc's place in its body, the largest first (ties by disc id), and one colour
  // per (species, place).
  std::map<std::int64_t, std::vector<const rundir::Disc*>> discs_of;
  std::map<std::pair<int, std::size_t>, std::size_t> role_colour;
  std::map<const rundir::Disc*, std::size_t> role_of;
  if (o.colour == Colour::kDisc) {
    for (const auto& d : frame.discs) discs_of[d.mol].push_back(&d);
    for (auto& [mol, list] : discs_of) {
      std::sort(list.begin(), list.end(), [](const rundir::Disc* a, const rundir::Disc* b) {
        return a->radius != b->radius ? a->radius > b->radius : a->id < b->id;
      });
      for (std::size_t k = 0; k < list.size(); ++k) {
        role_of[list[k]] = k;
        role_colour.emplace(std::make_pair(list[k]->type, k), 0);
      }
    }
    std::size_t next = 0;
    for (auto& [role, colour] : role_colour) colour = next++;
  }
  for (const auto& d : frame.discs) {
    DiscShape s{d.x, d.y, d.radius, {}, o.highlight.count(d.mol) > 0};
    if (o.colour == Colour::kDisc) {
      s.fill = kSpecies[role_colour.at({d.type, role_of.at(&d)}) % std::size(kSpecies)];
    } else if (o.colour == Colour::kSpecies) {
      s.fill = kSpecies[static_cast<std::size_t>(std::max(d.type - 1, 0)) % std::size(kSpecies)];
    } else {
      const auto it = value.find(d.mol);
      const double v = it == value.end() ? 0.0 : it->second;
      s.fill = o.colour == Colour::kSpeed      ? Map(kViridis, v / hi)
               : o.colour == Colour::kRotation ? Map(kDiverging, (v - lo) / (hi - lo))
                                               : Map(kHeat, v / hi);
    }
    scene.discs.push_back(s);
  }
  if (o.colour == Colour::kDisc) {
    // One key per (species, place): its diameter when the body's discs differ in size.
    std::map<std::pair<int, std::size_t>, const rundir::Disc*> example;
    std::map<int, std::set<double>> radii;
    for (const auto& [mol, list] : discs_of)
      for (std::size_t k = 0; k < list.size(); ++k) {
        example.emplace(std::make_pair(list[k]->type, k), list[k]);
        radii[list[k]->type].insert(list[k]->radius);
      }
    for (const auto& [role, colour] : role_colour) {
      const std::size_t t = static_cast<std::size_t>(std::max(role.first - 1, 0));
      const std::string species = t < o.species.size() ? o.species[t] : "type " + std::to_string(role.first);
      const rundir::Disc& d = *example.at(role);
      const std::string place = radii[role.first].size() > 1 ? "disc of D = " + Fixed(2 * d.radius) + " d"
                                                             : "disc " + std::to_string(role.second + 1);
      scene.legend.push_back({kSpecies[colour % std::size(kSpecies)], species + ": " + place});
    }
  } else if (o.colour == Colour::kSpecies) {
    std::set<int> types;
    for (const auto& d : frame.discs) types.insert(d.type);
    for (int t : types) {
      const std::size_t k = static_cast<std::size_t>(std::max(t - 1, 0));
      scene.legend.push_back(
          {kSpecies[k % std::size(kSpecies)], k < o.species.size() ? o.species[k] : "type " + std::to_string(t)});
    }
  } else {
    const auto& stops_lo = o.colour == Colour::kSpeed      ? kViridis[0]
                           : o.colour == Colour::kRotation ? kDiverging[0]
                                                           : kHeat[0];
    const auto& stops_hi = o.colour == Colour::kSpeed      ? kViridis[4]
                           : o.colour == Colour::kRotation ? kDiverging[2]
                                                           : kHeat[3];
    scene.legend.push_back({stops_lo, what + " " + Fixed(lo)});
    scene.legend.push_back({stops_hi, what + " " + Fixed(hi) + (o.colour == Colour::kRotation ? "" : " and above")});
  }
  if (o.forces) {
    if (!o.contacts)
      throw std::invalid_argument("the force network needs the run's contact frames (output.contact_forces)");
    std::vector<double> f;
    for (const auto& c : o.contacts->contacts) f.push_back(std::hypot(c.fx, c.fy));
    double mean = 0;
    for (double v : f) mean += v;
    mean = f.empty() ? 1 : mean / static_cast<double>(f.size());
    // Line width proportional to the force: the mean force 0.15 d wide (as in photoelastic
    // pictures of force chains), from 0.02 d to 0.6 d.
    for (std::size_t k = 0; k < f.size(); ++k) {
      const auto& c = o.contacts->contacts[k];
      const double w = std::clamp(0.15 * f[k] / std::max(mean, 1e-300), 0.02, 0.6);
      scene.forces.push_back({c.xi, c.yi, c.body_j >= 0 ? c.xj : c.cx, c.body_j >= 0 ? c.yj : c.cy, w, kForceLine});
    }
    scene.legend.push_back({kForceLine, "contact forces (width ~ |f|, mean " + Fixed(mean) + ")"});
  }
  return scene;
}

}  // namespace granary::render

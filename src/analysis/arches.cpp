// See arches.h.
#include "analysis/arches.h"
#include "analysis/json_numbers.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>

#include "analysis/orientation.h"
#include "silo/stall.h"
#include "rundir/run_spec.h"

namespace granary::analysis {

namespace {

constexpr double kPi = std::numbers::pi;
// A disc within 1 % of its radius of a wall or an obstacle touches it (resting overlaps are of
// the order of 1e-3 d on both engines).
constexpr double kTouching = 0.01;

// The bodies of a frame and, per body, its discs.
struct Bodies {
  std::vector<rundir::Body> list;               // BodiesOf order (by id)
  std::map<std::int64_t, std::size_t> index;    // id -> position in `list`
  std::vector<std::vector<std::size_t>> discs;  // per body: indices into frame.discs, by disc id
  explicit Bodies(const std::vector<rundir::Disc>& d) : list(rundir::BodiesOf(d)) {
    for (std::size_t k = 0; k < list.size(); ++k) index.emplace(list[k].id, k);
    discs.resize(list.size());
    for (std::size_t i = 0; i < d.size(); ++i) discs[index.at(d[i].mol)].push_back(i);
    for (auto& v : discs)
      std::sort(v.begin(), v.end(), [&](std::size_t a, std::size_t b) { return d[a].id < d[b].id; });
  }
  const rundir::Body* Find(std::int64_t id) const {
    const auto it = index.find(id);
    return it == index.end() ? nullptr : &list[it->second];
  }
};

// The disc of body `body` whose centre is nearest (x, y) (contact rows carry the touching
// discs' centres); npos if the body is not in the frame.
std::size_t DiscAt(const Bodies& b, const std::vector<rundir::Disc>& d, std::int64_t body, double x, double y) {
  const auto it = b.index.find(body);
  if (it == b.index.end()) return std::numeric_limits<std::size_t>::max();
  std::size_t best = std::numeric_limits<std::size_t>::max();
  double best_d = std::numeric_limits<double>::max();
  for (std::size_t i : b.discs[it->second]) {
    const double dd = std::hypot(d[i].x - x, d[i].y - y);
    if (dd < best_d) best_d = dd, best = i;
  }
  return best;
}

enum class SizeClass { kSmall, kLarge, kOther };
SizeClass ClassOf(const Bodies& b, const std::vector<rundir::Disc>& d, std::int64_t body, std::size_t disc) {
  const auto& own = b.discs[b.index.at(body)];
  if (own.size() != 2) return SizeClass::kOther;
  const rundir::Disc& first = d[own[0]];
  const rundir::Disc& second = d[own[1]];
  if (first.radius == second.radius) return disc == own[0] ? SizeClass::kSmall : SizeClass::kLarge;
  const bool this_is_first = disc == own[0];
  const double mine = this_is_first ? first.radius : second.radius,
               other = this_is_first ? second.radius : first.radius;
  return mine < other ? SizeClass::kSmall : SizeClass::kLarge;
}

// The arc from a through m to b on the circle through the three points; the chord |b - a| when
// they are (nearly) on a line or m is an end.
double ArcThrough(double ax, double ay, double mx, double my, double bx, double by) {
  const double chord = std::hypot(bx - ax, by - ay);
  const double d = 2 * (ax * (my - by) + mx * (by - ay) + bx * (ay - my));
  if (std::fabs(d) < 1e-12 * std::max(1.0, chord * chord) || (mx == ax && my == ay) || (mx == bx && my == by))
    return chord;
  const double a2 = ax * ax + ay * ay, m2 = mx * mx + my * my, b2 = bx * bx + by * by;
  const double cx = (a2 * (my - by) + m2 * (by - ay) + b2 * (ay - my)) / d;
  const double cy = (a2 * (bx - mx) + m2 * (ax - bx) + b2 * (mx - ax)) / d;
  const double r = std::hypot(ax - cx, ay - cy);
  auto ccw = [](double from, double to) {
    double s = std::fmod(to - from, 2 * kPi);
    return s < 0 ? s + 2 * kPi : s;
  };
  const double ta = std::atan2(ay - cy, ax - cx), tm = std::atan2(my - cy, mx - cx), tb = std::atan2(by - cy, bx - cx);
  const double sweep = ccw(ta, tb);
  return r * (ccw(ta, tm) <= sweep ? sweep : 2 * kPi - sweep);
}

// An object along a cavity's edge, bodies merged from their discs.
struct Item {
  enum class Kind { kBody, kLeft, kRight, kObstacle } kind;
  std::int64_t id;  // body id or obstacle index; 0 for walls
  bool operator==(const Item& o) const { return kind == o.kind && id == o.id; }
};

// `items` with repeats merged and every dead-end excursion A B ... B A cut back to A; the bodies
// cut off a body go to `dead` (what lies on a wall beside the arch is not a defect of it).
std::vector<Item> CutDeadEnds(const std::vector<Item>& items, std::vector<std::int64_t>& dead) {
  std::vector<Item> stack;
  for (const Item& item : items) {
    if (!stack.empty() && stack.back() == item) continue;
    if (stack.size() >= 2 && stack[stack.size() - 2] == item) {
      if (stack.back().kind == Item::Kind::kBody && item.kind == Item::Kind::kBody) dead.push_back(stack.back().id);
      stack.pop_back();
      continue;
    }
    stack.push_back(item);
  }
  return stack;
}

// The stretch from the last support on the left before the first on the right to that one, both
// included; false if there is no such stretch with something between.
bool Stretch(const std::vector<Item>& items, std::vector<Item>& stretch) {
  std::size_t right = items.size();
  for (std::size_t k = 0; k < items.size() && right == items.size(); ++k)
    if (items[k].kind == Item::Kind::kRight) right = k;
  std::size_t left = items.size();
  for (std::size_t k = 0; k < right; ++k)
    if (items[k].kind == Item::Kind::kLeft) left = k;
  if (right == items.size() || left == items.size() || right - left < 2) return false;
  stretch.assign(items.begin() + static_cast<std::ptrdiff_t>(left),
                 items.begin() + static_cast<std::ptrdiff_t>(right) + 1);
  return true;
}

}  // namespace

silo::SiloGeometry SiloOf(const nlohmann::json& spec, double top) {
  try {
    const RunSpec rs = RunSpec::FromJson(spec);
    return silo::BuildGeometry(rs.silo, rs.silo.height > 0 ? rs.silo.height : top);
  } catch (const std::exception& e) {
    throw std::invalid_argument(std::string("the run's spec does not describe a silo: ") + e.what());
  }
}

std::vector<double> BodyPressures(const rundir::Frame& frame, const rundir::ContactFrame& contacts) {
  const Bodies b(frame.discs);
  std::vector<double> virial(b.list.size(), 0.0);
  for (const rundir::ContactRow& c : contacts.contacts) {
    if (c.body_j < 0) continue;  // pairwise interactions only (eq. 6.1)
    const auto i = b.index.find(c.body_i), j = b.index.find(c.body_j);
    if (i == b.index.end() || j == b.index.end()) continue;
    // (r_i - r_j) . F_i; body j's share, (r_j - r_i) . F_j with F_j = -F_i, is the same.
    const double w = (c.xi - c.xj) * c.fx + (c.yi - c.yj) * c.fy;
    virial[i->second] += w;
    virial[j->second] += w;
  }
  std::vector<double> p(b.list.size(), kNaN);
  for (std::size_t k = 0; k < p.size(); ++k)
    if (b.list[k].area > 0) p[k] = virial[k] / (4 * b.list[k].area);
  return p;
}

ContactTypes CountContactTypes(const rundir::Frame& frame, const rundir::ContactFrame& contacts) {
  const Bodies b(frame.discs);
  ContactTypes t;
  for (const rundir::ContactRow& c : contacts.contacts) {
    if (c.body_j < 0 || c.body_i == c.body_j) continue;
    const std::size_t di = DiscAt(b, frame.discs, c.body_i, c.xi, c.yi),
                      dj = DiscAt(b, frame.discs, c.body_j, c.xj, c.yj);
    if (di == std::numeric_limits<std::size_t>::max() || dj == std::numeric_limits<std::size_t>::max()) continue;
    const SizeClass a = ClassOf(b, frame.discs, c.body_i, di), z = ClassOf(b, frame.discs, c.body_j, dj);
    if (a == SizeClass::kOther || z == SizeClass::kOther)
      ++t.other;
    else if (a == SizeClass::kSmall && z == SizeClass::kSmall)
      ++t.small_small;
    else if (a == SizeClass::kLarge && z == SizeClass::kLarge)
      ++t.large_large;
    else
      ++t.large_small;
  }
  return t;
}

ClogArches AnalyseClog(const rundir::ClogState& clog, const silo::SiloGeometry& silo) {
  const std::vector<rundir::Disc>& discs = clog.frame.discs;
  ClogArches out;
  out.timestep = clog.frame.timestep;
  out.time = clog.frame.time;
  out.contact_types = CountContactTypes(clog.frame, clog.contacts);
  const Bodies b(discs);
  out.bodies = static_cast<int>(b.list.size());
  if (discs.empty()) return out;
  const std::vector<BodyAxis> axes = BodyAxes(discs);
  const std::vector<double> pressure = BodyPressures(clog.frame, clog.contacts);

  // The contact network: which bodies touch (the contact rows), and where each touches a wall or
  // an obstacle (from the geometry: LIGGGHTS reports wall contacts only with mesh walls).
  std::map<std::int64_t, std::vector<std::int64_t>> neighbours;
  for (const rundir::ContactRow& c : clog.contacts.contacts) {
    if (c.body_j >= 0 && c.body_j != c.body_i) {
      neighbours[c.body_i].push_back(c.body_j);
      neighbours[c.body_j].push_back(c.body_i);
    }
  }
  std::map<std::int64_t, std::vector<std::pair<double, double>>> on_walls;  // contact points
  for (const rundir::Disc& d : discs) {
    for (const silo::WallElement& e : silo.elements) {
      if (e.group == silo::WallGroup::kPlug) continue;
      double qx = e.ax, qy = e.ay;
      if (e.kind == silo::ElementKind::kSegment) {
        const silo::Closest q = silo::ClosestPoint(e, d.x, d.y);
        if (!q.valid) continue;
        qx = q.qx, qy = q.qy;
      }
      const double r = std::hypot(d.x - qx, d.y - qy), surface = e.kind == silo::ElementKind::kCircle ? e.radius : 0.0;
      if (r - surface > d.radius * (1 + kTouching) || r == 0) continue;
      on_walls[d.mol].emplace_back(qx + surface * (d.x - qx) / r, qy + surface * (d.y - qy) / r);
    }
  }
  for (auto& [id, n] : neighbours) {
    std::sort(n.begin(), n.end());
    n.erase(std::unique(n.begin(), n.end()), n.end());
  }
  std::vector<int> circle_of(silo.elements.size(), -1);  // element -> obstacle index
  std::vector<const silo::WallElement*> circles;
  for (std::size_t e = 0; e < silo.elements.size(); ++e)
    if (silo.elements[e].kind == silo::ElementKind::kCircle) {
      circle_of[e] = static_cast<int>(circles.size());
      circles.push_back(&silo.elements[e]);
    }

  std::vector<silo::DiscAt> at;
  std::vector<std::int64_t> body_of;
  for (const rundir::Disc& d : discs) {
    at.push_back({d.x, d.y, d.radius});
    body_of.push_back(d.mol);
  }
  const double probe = silo::PassageProbe(at, body_of);
  for (int o = 0; o < static_cast<int>(silo.outlets.size()); ++o) {
    const silo::OutletCavity cavity = silo::CavityUnder(silo, at, probe, o);
    if (!cavity.sealed) continue;
    out.sealed_outlets.push_back(o);
    const silo::OutletFrame& f = silo.outlets[static_cast<std::size_t>(o)];
    // The supports a body touches, as seen from this outlet: an obstacle, or walls on its
    // s < 0 (left) or s > 0 (right) side.
    auto supports_of = [&](std::int64_t id) {
      std::vector<Item> s;
      const auto it = on_walls.find(id);
      if (it == on_walls.end()) return s;
      for (const auto& [cx, cy] : it->second) {
        Item item{(cx - f.cx) * f.ax + (cy - f.cy) * f.ay < 0 ? Item::Kind::kLeft : Item::Kind::kRight, 0};
        for (std::size_t k = 0; k < circles.size(); ++k)
          if (std::fabs(std::hypot(cx - circles[k]->ax, cy - circles[k]->ay) - circles[k]->radius) < 0.05)
            item = {Item::Kind::kObstacle, static_cast<std::int64_t>(k)};
        s.push_back(item);
      }
      return s;
    };
    auto touch = [&](const Item& u, const Item& v) {
      if (u.kind != Item::Kind::kBody && v.kind != Item::Kind::kBody) return false;
      if (u.kind == Item::Kind::kBody && v.kind == Item::Kind::kBody) {
        const auto it = neighbours.find(u.id);
        return it != neighbours.end() && std::binary_search(it->second.begin(), it->second.end(), v.id);
      }
      const Item& body = u.kind == Item::Kind::kBody ? u : v;
      const Item& support = u.kind == Item::Kind::kBody ? v : u;
      const std::vector<Item> s = supports_of(body.id);
      return std::find(s.begin(), s.end(), support) != s.end();
    };
    // The fewest touching bodies leading from body `from` to `to` (a body or a support), nearest
    // the outlet first among equals; empty if there are none within kBridge bodies.
    auto bridge = [&](std::int64_t from, const Item& to) {
      constexpr int kBridge = 8;
      std::map<std::int64_t, std::int64_t> parent{{from, from}};
      std::vector<std::int64_t> level{from};
      for (int depth = 0; depth < kBridge && !level.empty(); ++depth) {
        std::vector<std::int64_t> next;
        for (std::int64_t id : level) {
          if (depth > 0 && touch({Item::Kind::kBody, id}, to)) {
            std::vector<std::int64_t> path;
            for (std::int64_t p = id; p != from; p = parent.at(p)) path.push_back(p);
            std::reverse(path.begin(), path.end());
            return path;
          }
          const auto it = neighbours.find(id);
          if (it == neighbours.end()) continue;
          std::vector<std::int64_t> near = it->second;
          std::stable_sort(near.begin(), near.end(), [&](std::int64_t a, std::int64_t z) {
            const rundir::Body &ba = *b.Find(a), &bz = *b.Find(z);
            return std::hypot(ba.x - f.cx, ba.y - f.cy) < std::hypot(bz.x - f.cx, bz.y - f.cy);
          });
          for (std::int64_t n : near)
            if (b.Find(n) && parent.emplace(n, id).second) next.push_back(n);
        }
        level = std::move(next);
      }
      return std::vector<std::int64_t>{};
    };

    // The edge as objects; then every dead-end excursion A B ... B A cut back to A.
    std::vector<Item> edge;
    for (const silo::CavityBound& e : cavity.edge) {
      if (e.kind == silo::CavityBound::Kind::kDisc) {
        edge.push_back({Item::Kind::kBody, discs[static_cast<std::size_t>(e.index)].mol});
      } else if (e.kind == silo::CavityBound::Kind::kElement) {
        const int k = circle_of[static_cast<std::size_t>(e.index)];
        edge.push_back(k >= 0 ? Item{Item::Kind::kObstacle, k}
                              : Item{e.s < 0 ? Item::Kind::kLeft : Item::Kind::kRight, 0});
      }
    }
    // The edge starts and ends at the gap's sides; a body over a side of the gap may hide it from
    // the probe, but the walls are there.
    if (edge.empty() || edge.front().kind != Item::Kind::kLeft) edge.insert(edge.begin(), Item{Item::Kind::kLeft, 0});
    if (edge.back().kind != Item::Kind::kRight) edge.push_back({Item::Kind::kRight, 0});
    std::vector<std::int64_t> dead;
    std::vector<Item> stretch;
    if (!Stretch(CutDeadEnds(edge, dead), stretch)) continue;
    // The probe sees the bodies nearest the outlet; the arch is a chain of touching bodies. Where
    // two neighbours along the edge do not touch (a body over the gap's edge held by one beside
    // it, a body hanging close under the arch), the fewest touching bodies between them join it,
    // and what then hangs off the chain is cut again.
    std::vector<Item> chain{stretch.front()};
    int gaps = 0;
    for (std::size_t k = 1; k < stretch.size(); ++k) {
      const Item& u = chain.back();
      const Item& v = stretch[k];
      if (!touch(u, v) && (u.kind == Item::Kind::kBody || v.kind == Item::Kind::kBody)) {
        const bool from_u = u.kind == Item::Kind::kBody;
        std::vector<std::int64_t> path = bridge(from_u ? u.id : v.id, from_u ? v : u);
        if (!from_u) std::reverse(path.begin(), path.end());
        if (path.empty()) ++gaps;
        for (std::int64_t id : path) chain.push_back({Item::Kind::kBody, id});
      }
      chain.push_back(v);
    }
    std::vector<Item> arch_items;
    if (!Stretch(CutDeadEnds(chain, dead), arch_items)) continue;

    Arch arch;
    arch.outlet = o;
    int max_type = 0;
    for (const rundir::Body& body : b.list) max_type = std::max(max_type, body.type);
    arch.per_type.assign(static_cast<std::size_t>(max_type), 0);
    arch.gaps = gaps;
    for (std::size_t k = 1; k + 1 < arch_items.size(); ++k) {
      if (arch_items[k].kind == Item::Kind::kObstacle) {
        arch.obstacle = true;
        arch.obstacles.push_back(static_cast<int>(arch_items[k].id));
        continue;
      }
      const std::size_t bi = b.index.at(arch_items[k].id);
      const rundir::Body& body = b.list[bi];
      ArchBody ab;
      ab.id = body.id;
      ab.type = body.type;
      ab.discs = body.n_discs;
      ab.x = body.x;
      ab.y = body.y;
      ab.s = (body.x - f.cx) * f.ax + (body.y - f.cy) * f.ay;
      ab.h = (body.x - f.cx) * f.nx + (body.y - f.cy) * f.ny;
      ab.theta = AngularPosition(ab.s, ab.h);
      ab.axis = axes[bi].angle;
      ab.pressure = pressure[bi];
      arch.bodies.push_back(ab);
    }
    const std::vector<ArchBody>& ch = arch.bodies;
    arch.n = static_cast<int>(ch.size());
    if (ch.empty()) continue;
    std::set<std::int64_t> in_arch;
    for (const ArchBody& ab : ch) in_arch.insert(ab.id);
    std::sort(dead.begin(), dead.end());
    dead.erase(std::unique(dead.begin(), dead.end()), dead.end());
    for (std::int64_t id : dead)
      if (!in_arch.count(id)) arch.dead_ends.push_back(id);
    arch.supported =
        touch(arch_items.front(), arch_items[1]) && touch(arch_items[arch_items.size() - 2], arch_items.back());
    // Metrics.
    double top_h = -std::numeric_limits<double>::max(), pressure_sum = 0;
    std::size_t top = 0;
    int elongated = 0, pressures = 0;
    arch.perimeter = 0;
    for (std::size_t k = 0; k < ch.size(); ++k) {
      if (ch[k].h > top_h) top_h = ch[k].h, top = k;
      if (ch[k].discs >= 2) ++elongated;
      if (ch[k].type >= 1) ++arch.per_type[static_cast<std::size_t>(ch[k].type - 1)];
      if (std::isfinite(ch[k].pressure)) pressure_sum += ch[k].pressure, ++pressures;
      if (k > 0) {
        arch.perimeter += std::hypot(ch[k].s - ch[k - 1].s, ch[k].h - ch[k - 1].h);
      }
    }
    arch.width = std::fabs(ch.back().s - ch.front().s);
    arch.height = top_h - 0.5 * (ch.front().h + ch.back().h);
    arch.arc = ArcThrough(ch.front().s, ch.front().h, ch[top].s, ch[top].h, ch.back().s, ch.back().h);
    arch.c_over_p = arch.perimeter > 0 ? arch.arc / arch.perimeter : kNaN;
    arch.elongated_fraction = static_cast<double>(elongated) / static_cast<double>(ch.size());
    arch.mean_pressure = pressures > 0 ? pressure_sum / pressures : kNaN;
    for (std::size_t k = 1; k + 1 < ch.size(); ++k) {
      const double u = std::atan2(ch[k - 1].h - ch[k].h, ch[k - 1].s - ch[k].s);
      const double v = std::atan2(ch[k + 1].h - ch[k].h, ch[k + 1].s - ch[k].s);
      double phi = std::fmod(v - u, 2 * kPi);
      if (phi < 0) phi += 2 * kPi;
      arch.max_angle = std::isnan(arch.max_angle) ? phi : std::max(arch.max_angle, phi);
      arch.concave += phi > kPi;
    }
    out.arches.push_back(std::move(arch));
  }
  return out;
}

ClogArches AnalyseClog(const rundir::ClogState& clog, const nlohmann::json& spec) {
  double top = 0;
  for (const rundir::Disc& d : clog.frame.discs) top = std::max(top, d.y + d.radius);
  return AnalyseClog(clog, SiloOf(spec, top + 1));
}

}  // namespace granary::analysis

namespace granary::analysis {

nlohmann::json to_json(const ClogArches& clog) {
  nlohmann::json arches = nlohmann::json::array();
  for (const Arch& a : clog.arches) {
    nlohmann::json bodies = nlohmann::json::array();
    for (const ArchBody& b : a.bodies)
      bodies.push_back({{"id", b.id},
                        {"type", b.type},
                        {"discs", b.discs},
                        {"x", JsonNumber(b.x)},
                        {"y", JsonNumber(b.y)},
                        {"s", JsonNumber(b.s)},
                        {"h", JsonNumber(b.h)},
                        {"theta", JsonNumber(b.theta)},
                        {"axis", JsonNumber(b.axis)},
                        {"pressure", JsonNumber(b.pressure)}});
    arches.push_back({{"outlet", a.outlet},
                      {"obstacle", a.obstacle},
                      {"obstacles", a.obstacles},
                      {"bodies", bodies},
                      {"dead_ends", a.dead_ends},
                      {"gaps", a.gaps},
                      {"supported", a.supported},
                      {"n", a.n},
                      {"width", JsonNumber(a.width)},
                      {"height", JsonNumber(a.height)},
                      {"perimeter", JsonNumber(a.perimeter)},
                      {"arc", JsonNumber(a.arc)},
                      {"c_over_p", JsonNumber(a.c_over_p)},
                      {"elongated_fraction", JsonNumber(a.elongated_fraction)},
                      {"per_type", a.per_type},
                      {"mean_pressure", JsonNumber(a.mean_pressure)},
                      {"max_angle", JsonNumber(a.max_angle)},
                      {"concave", a.concave}});
  }
  const ContactTypes& t = clog.contact_types;
  return {{"timestep", clog.timestep},
          {"time", JsonNumber(clog.time)},
          {"bodies", clog.bodies},
          {"sealed_outlets", clog.sealed_outlets},
          {"contact_types",
           {{"small_small", t.small_small},
            {"large_small", t.large_small},
            {"large_large", t.large_large},
            {"other", t.other}}},
          {"arches", arches}};
}

ClogArches ClogArchesFromJson(const nlohmann::json& j) {
  ClogArches c;
  c.timestep = j.value("timestep", std::int64_t{0});
  c.time = NumberAt(j, "time");
  c.bodies = j.value("bodies", 0);
  c.sealed_outlets = j.value("sealed_outlets", std::vector<int>{});
  if (const auto t = j.find("contact_types"); t != j.end()) {
    c.contact_types.small_small = t->value("small_small", 0);
    c.contact_types.large_small = t->value("large_small", 0);
    c.contact_types.large_large = t->value("large_large", 0);
    c.contact_types.other = t->value("other", 0);
  }
  for (const nlohmann::json& a : j.value("arches", nlohmann::json::array())) {
    Arch arch;
    arch.outlet = a.value("outlet", 0);
    arch.obstacle = a.value("obstacle", false);
    arch.obstacles = a.value("obstacles", std::vector<int>{});
    for (const nlohmann::json& b : a.value("bodies", nlohmann::json::array()))
      arch.bodies.push_back({b.value("id", std::int64_t{-1}), b.value("type", 1), b.value("discs", 1), NumberAt(b, "x"),
                             NumberAt(b, "y"), NumberAt(b, "s"), NumberAt(b, "h"), NumberAt(b, "theta"),
                             NumberAt(b, "axis"), NumberAt(b, "pressure")});
    arch.dead_ends = a.value("dead_ends", std::vector<std::int64_t>{});
    arch.gaps = a.value("gaps", 0);
    arch.supported = a.value("supported", true);
    arch.n = a.value("n", 0);
    arch.width = NumberAt(a, "width");
    arch.height = NumberAt(a, "height");
    arch.perimeter = NumberAt(a, "perimeter");
    arch.arc = NumberAt(a, "arc");
    arch.c_over_p = NumberAt(a, "c_over_p");
    arch.elongated_fraction = NumberAt(a, "elongated_fraction");
    arch.per_type = a.value("per_type", std::vector<int>{});
    arch.mean_pressure = NumberAt(a, "mean_pressure");
    arch.max_angle = NumberAt(a, "max_angle");
    arch.concave = a.value("concave", 0);
    c.arches.push_back(std::move(arch));
  }
  return c;
}

ArchSummary SummarizeArches(const std::vector<const ClogArches*>& clogs, const ArchSummaryOptions& o) {
  ArchSummary s;
  std::vector<double> n, width, height, perimeter, cp, elongated, pressure, angle, concave, dead;
  std::vector<double> ss, ls, ll, other;
  const int tb = std::max(1, o.theta_bins), ab = std::max(1, o.axis_bins);
  std::vector<std::vector<double>> theta_pressure(static_cast<std::size_t>(tb));
  std::vector<std::vector<int>> theta_axes(static_cast<std::size_t>(tb),
                                           std::vector<int>(static_cast<std::size_t>(ab), 0));
  std::map<int, std::vector<double>> by_n;
  for (const ClogArches* c : clogs) {
    ++s.clogs;
    s.sealed += static_cast<int>(c->sealed_outlets.size());
    const ContactTypes& t = c->contact_types;
    if (t.Total() > 0) {
      const double total = t.Total();
      ss.push_back(t.small_small / total);
      ls.push_back(t.large_small / total);
      ll.push_back(t.large_large / total);
      other.push_back(t.other / total);
    }
    for (const Arch& a : c->arches) {
      ++s.arches;
      (a.obstacle ? s.obstacle_arches : s.particle_arches) += 1;
      s.with_gaps += a.gaps > 0;
      s.with_defects += !a.dead_ends.empty() || a.concave > 0;
      s.unsupported += !a.supported;
      if (a.obstacle && !o.obstacle_arches) continue;
      n.push_back(a.n);
      width.push_back(a.width);
      height.push_back(a.height);
      perimeter.push_back(a.perimeter);
      cp.push_back(a.c_over_p);
      elongated.push_back(a.elongated_fraction);
      pressure.push_back(a.mean_pressure);
      angle.push_back(a.max_angle);
      concave.push_back(a.concave);
      dead.push_back(static_cast<double>(a.dead_ends.size()));
      if (std::isfinite(a.mean_pressure)) by_n[a.n].push_back(a.mean_pressure);
      for (const ArchBody& b : a.bodies) {
        if (!std::isfinite(b.theta)) continue;
        const int k = std::clamp(static_cast<int>(b.theta / kPi * tb), 0, tb - 1);
        if (std::isfinite(b.pressure)) theta_pressure[static_cast<std::size_t>(k)].push_back(b.pressure);
        if (std::isfinite(b.axis)) {
          const int m = std::clamp(static_cast<int>(b.axis / kPi * ab), 0, ab - 1);
          ++theta_axes[static_cast<std::size_t>(k)][static_cast<std::size_t>(m)];
        }
      }
    }
  }
  s.n = MeanSeFinite(n);
  s.width = MeanSeFinite(width);
  s.height = MeanSeFinite(height);
  s.perimeter = MeanSeFinite(perimeter);
  s.c_over_p = MeanSeFinite(cp);
  s.elongated_fraction = MeanSeFinite(elongated);
  s.mean_pressure = MeanSeFinite(pressure);
  s.max_angle = MeanSeFinite(angle);
  s.concave = MeanSeFinite(concave);
  s.dead_ends = MeanSeFinite(dead);
  auto sd = [](const MeanSe& m) { return m.n >= 2 ? m.se * std::sqrt(static_cast<double>(m.n)) : kNaN; };
  s.width_sd = sd(s.width);
  s.height_sd = sd(s.height);
  s.n_values = n;
  for (int k = 0; k < tb; ++k) {
    ThetaBin bin;
    bin.theta = (k + 0.5) * kPi / tb;
    bin.pressure = MeanSeFinite(theta_pressure[static_cast<std::size_t>(k)]);
    const std::vector<int>& axes = theta_axes[static_cast<std::size_t>(k)];
    const auto most = std::max_element(axes.begin(), axes.end());
    for (int c : axes) bin.elongated += c;
    if (bin.elongated > 0) bin.axis_mode = (static_cast<double>(most - axes.begin()) + 0.5) * kPi / ab;
    s.theta.push_back(bin);
  }
  for (const auto& [size, p] : by_n) s.pressure_by_n.push_back({size, MeanAndSe(p)});
  s.small_small = MeanAndSe(ss);
  s.large_small = MeanAndSe(ls);
  s.large_large = MeanAndSe(ll);
  s.other = MeanAndSe(other);
  return s;
}

}  // namespace granary::analysis

#include "silo/stall.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>

namespace granary::silo {

double PassageProbe(const std::vector<DiscAt>& discs, const std::vector<std::int64_t>& body_of) {
  std::unordered_map<std::int64_t, double> largest;
  for (std::size_t i = 0; i < discs.size(); ++i) {
    double& r = largest[body_of[i]];
    r = std::max(r, discs[i].r);
  }
  double probe = std::numeric_limits<double>::infinity();
  for (const auto& [body, r] : largest) probe = std::min(probe, r);
  return probe;
}
namespace {

// Grid cells whose centre a probe of radius `probe` can occupy without overlapping anything,
// over the silo and `margin` around it. Cell (i, k) has its centre at (x0 + (i + 0.5) h,
// y0 + (k + 0.5) h). With `owners`, a blocked cell also knows the object whose surface is
// nearest its centre (a disc k as k, a wall element e as -(e + 2)), which is what the edge of a
// cavity is made of.
class FreeSpace {
 public:
  FreeSpace(const SiloGeometry& g, const std::vector<DiscAt>& discs, double probe, bool owners, double margin = 0)
      : probe_(probe), h_(probe / 3), owners_(owners), half_width_(g.half_width) {
    double top = 0;
    for (const DiscAt& d : discs) top = std::max(top, d.y + d.r);
    for (const OutletFrame& o : g.outlets) top = std::max(top, o.cy + o.width / 2);
    x0_ = -g.half_width - margin;
    y0_ = -margin;
    nx_ = static_cast<int>(std::ceil((2 * g.half_width + 2 * margin) / h_));
    ny_ = static_cast<int>(std::ceil((top + probe + 2 * h_ + margin) / h_));  // the top row is above every disc
    free_.assign(static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_), 1);
    if (owners_) {
      owner_.assign(free_.size(), -1);
      clearance_.assign(free_.size(), std::numeric_limits<float>::max());
    }
    for (std::size_t k = 0; k < discs.size(); ++k) BlockDisc(discs[k].x, discs[k].y, discs[k].r, static_cast<int>(k));
    for (std::size_t e = 0; e < g.elements.size(); ++e) {
      const WallElement& el = g.elements[e];
      if (el.group == WallGroup::kPlug) continue;  // outlets open
      const int owner = -(static_cast<int>(e) + 2);
      switch (el.kind) {
        case ElementKind::kCircle: BlockDisc(el.ax, el.ay, el.radius, owner); break;
        case ElementKind::kPoint: BlockDisc(el.ax, el.ay, 0.0, owner); break;
        case ElementKind::kSegment: BlockSegment(el, owner); break;
      }
    }
  }

  int Nx() const { return nx_; }
  int Ny() const { return ny_; }
  double H() const { return h_; }
  double CentreX(int i) const { return x0_ + (i + 0.5) * h_; }
  double CentreY(int k) const { return y0_ + (k + 0.5) * h_; }
  std::size_t Index(int i, int k) const {
    return static_cast<std::size_t>(k) * static_cast<std::size_t>(nx_) + static_cast<std::size_t>(i);
  }
  bool Inside(int i, int k) const { return i >= 0 && i < nx_ && k >= 0 && k < ny_; }
  bool Free(int i, int k) const { return free_[Index(i, k)] != 0; }
  // Whether the centre of cell (i, k) is in the silo (between the side walls, above the base).
  bool InSilo(int i, int k) const { return CentreY(k) >= 0 && std::fabs(CentreX(i)) <= half_width_; }
  int Owner(int i, int k) const { return owner_[Index(i, k)]; }

 private:
  // Blocks the cells whose squared distance from the object is below reach^2, recording `owner`
  // where its surface (`surface` beyond that distance) is the nearest yet.
  void BlockWithin(double xlo, double xhi, double ylo, double yhi, int owner, auto&& distance2, double reach,
                   double surface) {
    const int ilo = std::max(0, static_cast<int>(std::floor((xlo - x0_) / h_)));
    const int ihi = std::min(nx_ - 1, static_cast<int>(std::floor((xhi - x0_) / h_)));
    const int klo = std::max(0, static_cast<int>(std::floor((ylo - y0_) / h_)));
    const int khi = std::min(ny_ - 1, static_cast<int>(std::floor((yhi - y0_) / h_)));
    for (int k = klo; k <= khi; ++k)
      for (int i = ilo; i <= ihi; ++i) {
        const double d2 = distance2(CentreX(i), CentreY(k));
        if (!(d2 < reach * reach)) continue;
        const std::size_t c = Index(i, k);
        free_[c] = 0;
        if (!owners_) continue;
        const double gap = std::sqrt(d2) - surface;
        if (gap < clearance_[c]) {
          clearance_[c] = static_cast<float>(gap);
          owner_[c] = owner;
        }
      }
  }
  void BlockDisc(double cx, double cy, double radius, int owner) {
    const double reach = radius + probe_;
    BlockWithin(
        cx - reach, cx + reach, cy - reach, cy + reach, owner,
        [&](double x, double y) { return (x - cx) * (x - cx) + (y - cy) * (y - cy); }, reach, radius);
  }
  void BlockSegment(const WallElement& e, int owner) {
    const double ex = e.bx - e.ax, ey = e.by - e.ay, len2 = ex * ex + ey * ey;
    BlockWithin(
        std::min(e.ax, e.bx) - probe_, std::max(e.ax, e.bx) + probe_, std::min(e.ay, e.by) - probe_,
        std::max(e.ay, e.by) + probe_, owner,
        [&](double x, double y) {
          const double t = len2 > 0 ? std::clamp(((x - e.ax) * ex + (y - e.ay) * ey) / len2, 0.0, 1.0) : 0.0;
          const double dx = x - (e.ax + t * ex), dy = y - (e.ay + t * ey);
          return dx * dx + dy * dy;
        },
        probe_, 0.0);
  }

  double probe_, h_, x0_ = 0, y0_ = 0;
  bool owners_;
  double half_width_;
  int nx_ = 0, ny_ = 0;
  std::vector<std::uint8_t> free_;
  std::vector<int> owner_;
  std::vector<float> clearance_;
};

// Marks in `seen` the free cells reachable from the free cells of `mouth` (within the gap, up to
// a probe radius and two cells into the silo); whether the top row is among them. With
// `stop_at_top` the fill ends as soon as it gets there. Outside the silo only the gap's own
// passage, `below` deep, is open (a grid with a margin: the fill then starts below the bodies
// that sit in the gap itself).
bool Reach(const FreeSpace& space, const OutletFrame& mouth, double probe, std::vector<std::uint8_t>& seen,
           std::vector<int>& queue, bool stop_at_top, double below = 0) {
  std::fill(seen.begin(), seen.end(), 0);
  queue.clear();
  auto open = [&](int i, int k) {
    if (!space.Free(i, k)) return false;
    if (space.InSilo(i, k)) return true;
    const double px = space.CentreX(i) - mouth.cx, py = space.CentreY(k) - mouth.cy;
    return std::fabs(px * mouth.ax + py * mouth.ay) < mouth.width / 2 && px * mouth.nx + py * mouth.ny >= -below;
  };
  for (int k = 0; k < space.Ny(); ++k) {
    for (int i = 0; i < space.Nx(); ++i) {
      const double px = space.CentreX(i) - mouth.cx, py = space.CentreY(k) - mouth.cy;
      const double s = px * mouth.ax + py * mouth.ay, h = px * mouth.nx + py * mouth.ny;
      if (std::fabs(s) < mouth.width / 2 && h >= -below && h < probe + 2 * space.H() && open(i, k)) {
        seen[space.Index(i, k)] = 1;
        queue.push_back(static_cast<int>(space.Index(i, k)));
      }
    }
  }
  bool top = false;
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const int i = queue[head] % space.Nx(), k = queue[head] / space.Nx();
    if (k == space.Ny() - 1) {
      top = true;
      if (stop_at_top) return true;
    }
    const int di[4] = {1, -1, 0, 0}, dk[4] = {0, 0, 1, -1};
    for (int d = 0; d < 4; ++d) {
      const int a = i + di[d], c = k + dk[d];
      if (!space.Inside(a, c) || !open(a, c) || seen[space.Index(a, c)]) continue;
      seen[space.Index(a, c)] = 1;
      queue.push_back(static_cast<int>(space.Index(a, c)));
    }
  }
  return top;
}

constexpr int kDi[4] = {1, 0, -1, 0};  // east, north, west, south
constexpr int kDk[4] = {0, 1, 0, -1};

}  // namespace

std::vector<bool> SealedOutlets(const SiloGeometry& geometry, const std::vector<DiscAt>& discs, double probe) {
  std::vector<bool> sealed(geometry.outlets.size(), false);
  if (discs.empty()) return sealed;
  const FreeSpace space(geometry, discs, probe, false);
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(space.Nx()) * static_cast<std::size_t>(space.Ny()));
  std::vector<int> queue;
  for (std::size_t o = 0; o < sealed.size(); ++o)
    sealed[o] = !Reach(space, geometry.outlets[o], probe, seen, queue, true);
  return sealed;
}

OutletCavity CavityUnder(const SiloGeometry& geometry, const std::vector<DiscAt>& discs, double probe, int outlet) {
  OutletCavity cavity;
  if (discs.empty() || outlet < 0 || outlet >= static_cast<int>(geometry.outlets.size())) return cavity;
  const OutletFrame& mouth = geometry.outlets[static_cast<std::size_t>(outlet)];
  // A margin round the silo, so the fill starts in the gap's passage below the base even when
  // bodies sit in the gap itself.
  const double margin = 2 * probe;
  const FreeSpace space(geometry, discs, probe, true, margin);
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(space.Nx()) * static_cast<std::size_t>(space.Ny()));
  std::vector<int> queue;
  const double below = margin - space.H();  // how far below the mouth the fill starts
  if (Reach(space, mouth, probe, seen, queue, false, below) || queue.empty()) return cavity;
  cavity.sealed = true;
  auto in = [&](int i, int k) { return space.Inside(i, k) && seen[space.Index(i, k)] != 0; };
  auto frame = [&](int i, int k, double& s, double& h) {
    const double px = space.CentreX(i) - mouth.cx, py = space.CentreY(k) - mouth.cy;
    s = px * mouth.ax + py * mouth.ay;
    h = px * mouth.nx + py * mouth.ny;
  };
  // Beyond the cavity: out of the grid, outside the silo beside the gap's passage, or in the
  // passage below where the fill starts, is open (the way out); anything else is blocked by its
  // owner. The last matters when bodies hang into the gap from both edges: the cavity is then a
  // pocket of the passage that reaches neither of its sides.
  auto opening = [&](int i, int k) {
    if (!space.Inside(i, k)) return true;
    if (space.InSilo(i, k)) return false;
    double s = 0, h = 0;
    frame(i, k, s, h);
    return !(std::fabs(s) < mouth.width / 2) || h < -below;
  };
  // The edge starts at an open side of the cavity cell furthest to the s < 0 end of the mouth.
  int si = -1, sk = -1, sside = -1;
  double best = std::numeric_limits<double>::max();
  for (int cell : queue) {
    const int i = cell % space.Nx(), k = cell / space.Nx();
    for (int side = 0; side < 4; ++side) {
      if (!opening(i + kDi[side], k + kDk[side])) continue;
      double s = 0, h = 0;
      frame(i, k, s, h);
      if (s < best) {
        best = s;
        si = i, sk = k, sside = side;
      }
    }
  }
  if (si < 0) return cavity;  // cannot happen: the passage's bottom row faces the way out
  // Walk the edge once round with the cavity on the right (the outside on the left), one step
  // per cell side, and note the object beyond each side.
  std::vector<CavityBound> loop;
  int i = si, k = sk, side = sside;
  const std::size_t max_steps = 4 * queue.size() + 4;
  for (std::size_t step = 0; step < max_steps; ++step) {
    const int oi = i + kDi[side], ok = k + kDk[side];
    CavityBound b;
    frame(oi, ok, b.s, b.h);
    if (!opening(oi, ok) && !space.Free(oi, ok)) {
      const int owner = space.Owner(oi, ok);
      b.kind = owner >= 0 ? CavityBound::Kind::kDisc : CavityBound::Kind::kElement;
      b.index = owner >= 0 ? owner : -owner - 2;
    }
    loop.push_back(b);
    const int move = (side + 3) % 4;
    const int ai = i + kDi[move], ak = k + kDk[move];
    if (!in(ai, ak)) {
      side = move;  // turn right, round a corner of the cavity
    } else if (in(ai + kDi[side], ak + kDk[side])) {
      i = ai + kDi[side], k = ak + kDk[side];  // turn left, into a bay
      side = (side + 1) % 4;
    } else {
      i = ai, k = ak;  // straight on
    }
    if (i == si && k == sk && side == sside) break;
  }
  // Cut the loop at the mouth: from just after the run of open sides that holds the start round
  // to just before it.
  const std::size_t n = loop.size();
  std::size_t first = 0;
  while (first < n && loop[first].kind == CavityBound::Kind::kOpen) ++first;
  std::size_t last = n;
  while (last > first && loop[last - 1].kind == CavityBound::Kind::kOpen) --last;
  for (std::size_t p = first; p < last; ++p) {
    const CavityBound& b = loop[p];
    if (!cavity.edge.empty() && cavity.edge.back().kind == b.kind && cavity.edge.back().index == b.index) continue;
    cavity.edge.push_back(b);
  }
  if (cavity.edge.size() >= 2 && cavity.edge.front().s > cavity.edge.back().s)
    std::reverse(cavity.edge.begin(), cavity.edge.end());
  return cavity;
}

}  // namespace granary::silo

#include "engine/stall.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace granary::engine {
namespace {

// Grid cells whose centre a probe of radius `probe` can occupy without overlapping anything.
// Cell (i, k) has its centre at (x0 + (i + 0.5) h, y0 + (k + 0.5) h).
class FreeSpace {
 public:
  FreeSpace(const SiloGeometry& g, const std::vector<DiscAt>& discs, double probe) : probe_(probe), h_(probe / 3) {
    double top = 0;
    for (const DiscAt& d : discs) top = std::max(top, d.y + d.r);
    for (const OutletFrame& o : g.outlets) top = std::max(top, o.cy + o.width / 2);
    x0_ = -g.half_width;
    y0_ = 0;
    nx_ = static_cast<int>(std::ceil(2 * g.half_width / h_));
    ny_ = static_cast<int>(std::ceil((top + probe + 2 * h_) / h_));  // the top row is above every disc
    free_.assign(static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_), 1);
    for (const DiscAt& d : discs) BlockDisc(d.x, d.y, d.r + probe);
    for (const WallElement& e : g.elements) {
      if (e.group == WallGroup::kPlug) continue;  // outlets open
      switch (e.kind) {
        case ElementKind::kCircle: BlockDisc(e.ax, e.ay, e.radius + probe); break;
        case ElementKind::kPoint: BlockDisc(e.ax, e.ay, probe); break;
        case ElementKind::kSegment: BlockSegment(e); break;
      }
    }
  }

  int nx() const { return nx_; }
  int ny() const { return ny_; }
  double h() const { return h_; }
  double CentreX(int i) const { return x0_ + (i + 0.5) * h_; }
  double CentreY(int k) const { return y0_ + (k + 0.5) * h_; }
  std::size_t Index(int i, int k) const { return static_cast<std::size_t>(k) * static_cast<std::size_t>(nx_) + static_cast<std::size_t>(i); }
  bool Free(int i, int k) const { return free_[Index(i, k)] != 0; }

 private:
  void BlockWithin(double xlo, double xhi, double ylo, double yhi, auto&& inside) {
    const int ilo = std::max(0, static_cast<int>(std::floor((xlo - x0_) / h_)));
    const int ihi = std::min(nx_ - 1, static_cast<int>(std::floor((xhi - x0_) / h_)));
    const int klo = std::max(0, static_cast<int>(std::floor((ylo - y0_) / h_)));
    const int khi = std::min(ny_ - 1, static_cast<int>(std::floor((yhi - y0_) / h_)));
    for (int k = klo; k <= khi; ++k)
      for (int i = ilo; i <= ihi; ++i)
        if (inside(CentreX(i), CentreY(k))) free_[Index(i, k)] = 0;
  }
  void BlockDisc(double cx, double cy, double radius) {
    BlockWithin(cx - radius, cx + radius, cy - radius, cy + radius, [&](double x, double y) {
      return (x - cx) * (x - cx) + (y - cy) * (y - cy) < radius * radius;
    });
  }
  void BlockSegment(const WallElement& e) {
    const double ex = e.bx - e.ax, ey = e.by - e.ay, len2 = ex * ex + ey * ey;
    BlockWithin(std::min(e.ax, e.bx) - probe_, std::max(e.ax, e.bx) + probe_, std::min(e.ay, e.by) - probe_,
                std::max(e.ay, e.by) + probe_, [&](double x, double y) {
                  const double t = len2 > 0 ? std::clamp(((x - e.ax) * ex + (y - e.ay) * ey) / len2, 0.0, 1.0) : 0.0;
                  const double dx = x - (e.ax + t * ex), dy = y - (e.ay + t * ey);
                  return dx * dx + dy * dy < probe_ * probe_;
                });
  }

  double probe_, h_, x0_ = 0, y0_ = 0;
  int nx_ = 0, ny_ = 0;
  std::vector<std::uint8_t> free_;
};

// Whether a free path leads from the free cells of `mouth` (within the gap, up to a probe radius
// and two cells into the silo) to the top row.
bool OpenToTheTop(const FreeSpace& space, const OutletFrame& mouth, double probe, std::vector<std::uint8_t>& seen,
                  std::vector<int>& queue) {
  std::fill(seen.begin(), seen.end(), 0);
  queue.clear();
  for (int k = 0; k < space.ny(); ++k) {
    for (int i = 0; i < space.nx(); ++i) {
      const double px = space.CentreX(i) - mouth.cx, py = space.CentreY(k) - mouth.cy;
      const double s = px * mouth.ax + py * mouth.ay, h = px * mouth.nx + py * mouth.ny;
      if (std::fabs(s) < mouth.width / 2 && h >= 0 && h < probe + 2 * space.h() && space.Free(i, k)) {
        seen[space.Index(i, k)] = 1;
        queue.push_back(static_cast<int>(space.Index(i, k)));
      }
    }
  }
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const int i = queue[head] % space.nx(), k = queue[head] / space.nx();
    if (k == space.ny() - 1) return true;
    const int di[4] = {1, -1, 0, 0}, dk[4] = {0, 0, 1, -1};
    for (int d = 0; d < 4; ++d) {
      const int a = i + di[d], c = k + dk[d];
      if (a < 0 || a >= space.nx() || c < 0 || c >= space.ny() || !space.Free(a, c) || seen[space.Index(a, c)]) continue;
      seen[space.Index(a, c)] = 1;
      queue.push_back(static_cast<int>(space.Index(a, c)));
    }
  }
  return false;
}

}  // namespace

std::vector<bool> SealedOutlets(const SiloGeometry& geometry, const std::vector<DiscAt>& discs, double probe) {
  std::vector<bool> sealed(geometry.outlets.size(), false);
  if (discs.empty()) return sealed;
  const FreeSpace space(geometry, discs, probe);
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(space.nx()) * static_cast<std::size_t>(space.ny()));
  std::vector<int> queue;
  for (std::size_t o = 0; o < sealed.size(); ++o) sealed[o] = !OpenToTheTop(space, geometry.outlets[o], probe, seen, queue);
  return sealed;
}

std::vector<bool> SealedOutlets(const World& w) {
  double probe = std::numeric_limits<double>::max();
  for (double r : w.dr_) probe = std::min(probe, r);
  std::vector<DiscAt> discs;
  for (int i = 0; i < w.disc_count(); ++i)
    if (w.active_[w.dbody_[i]]) discs.push_back({w.dx_[i], w.dy_[i], w.dr_[i]});
  return SealedOutlets(w.geometry(), discs, probe);
}

}  // namespace granary::engine

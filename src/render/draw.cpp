// Svg, Pixels and WritePng: one drawing order (Paint) for both back ends, so the SVG and the PNG
// of a scene show the same thing.
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <utility>

#include "render/scene.h"

namespace granary::render {
namespace {

constexpr double kBand = 0.5;  // wall and outlet bands, d wide, outside the silo (as silo.vtk)
constexpr Rgb kWall = {0.55, 0.55, 0.55}, kOutlet = {0.85, 0.15, 0.1}, kObstacle = {0.3, 0.3, 0.3};
constexpr Rgb kBackground = {1, 1, 1}, kInk = {0.1, 0.1, 0.1};
// Marks: a shaded region in translucent gold over the bodies (they show through), outlines and
// dimension lines in near-black.
constexpr Rgb kShade = {1.0, 0.78, 0.0};
constexpr double kShadeOpacity = 0.35;

struct Point {
  double x, y;
};

// What a back end draws, in pixels (y down).
class Painter {
 public:
  virtual ~Painter() = default;
  virtual void Polygon(const std::vector<Point>& p, Rgb fill, const char* cls) = 0;
  virtual void Circle(double x, double y, double r, Rgb fill, Rgb stroke, double stroke_width, const char* cls) = 0;
  virtual void Segment(double x1, double y1, double x2, double y2, double width, Rgb colour, const char* cls) = 0;
  virtual void Text(double x, double y, double size, const std::string& text, bool right) = 0;
  // An axis-aligned rectangle, filled with `opacity` (0: not filled) and outlined.
  virtual void Rectangle(double x, double y, double w, double h, Rgb fill, double opacity, double stroke_width,
                         const char* cls) = 0;
  // `text` centred on (x, y) on a white box, or from (x, y) rightwards when not `centred`.
  virtual void Label(double x, double y, double size, const std::string& text, bool centred) = 0;
  virtual double TextWidth(double size, const std::string& text) = 0;
};

double FontSize(int width) { return std::clamp(width / 45.0, 11.0, 28.0); }
// The strip above the silo for the caption and the legend.
double HeaderHeight(const Scene& s, int width) {
  return FontSize(width) * (0.5 + 1.2 * static_cast<double>(std::max<std::size_t>(1, s.legend.size())));
}

// The marks, clipped to the window (the header strip above it stays clear); lines at least
// 2 px wide, dimension ticks and labels sized to the font so that they read at report size.
void PaintMarks(const Scene& s, double k, double top, double width, double font, Painter& p) {
  const Window& w = s.window;
  const auto px = [&](double x) { return (x - w.x_lo) * k; };
  const auto py = [&](double y) { return top + (w.y_hi - y) * k; };
  const double line = std::max(0.18 * font, 0.2 * k);
  for (const Mark& m : s.marks) {
    if (m.kind == Mark::Kind::kRect) {
      const double x0 = std::max(std::min(m.x0, m.x1), w.x_lo), x1 = std::min(std::max(m.x0, m.x1), w.x_hi);
      const double y0 = std::max(std::min(m.y0, m.y1), w.y_lo), y1 = std::min(std::max(m.y0, m.y1), w.y_hi);
      if (!(x1 > x0 && y1 > y0)) continue;
      p.Rectangle(px(x0), py(y1), (x1 - x0) * k, (y1 - y0) * k, kShade, m.shade ? kShadeOpacity : 0.0, line,
                  m.shade ? "mark shaded" : "mark");
      if (!m.label.empty()) p.Label(px(x0) + 0.4 * font, py(y1) + 1.3 * font, font, m.label, false);
      continue;
    }
    if (m.kind == Mark::Kind::kOrigin) {
      if (m.x0 < w.x_lo || m.x0 > w.x_hi || m.y0 < w.y_lo || m.y0 > w.y_hi) continue;
      // A dot, and arrows 2.5 font sizes long along +x and +y with their names at the tips.
      const double ox = px(m.x0), oy = py(m.y0), arm = 2.5 * font, head = 0.5 * font;
      p.Circle(ox, oy, 0.3 * font, kInk, kInk, 0, "origin");
      p.Segment(ox, oy, ox + arm, oy, line, kInk, "origin");
      p.Segment(ox + arm, oy, ox + arm - head, oy - 0.6 * head, line, kInk, "origin");
      p.Segment(ox + arm, oy, ox + arm - head, oy + 0.6 * head, line, kInk, "origin");
      p.Segment(ox, oy, ox, oy - arm, line, kInk, "origin");
      p.Segment(ox, oy - arm, ox - 0.6 * head, oy - arm + head, line, kInk, "origin");
      p.Segment(ox, oy - arm, ox + 0.6 * head, oy - arm + head, line, kInk, "origin");
      // The names above the x arrow's tip and beside the y arrow's, clear of a dimension below the base.
      p.Label(ox + arm, oy - 0.8 * font, font, "x", true);
      p.Label(ox + 0.8 * font, oy - arm, font, "y", true);
      if (!m.label.empty())
        p.Label(ox - 0.5 * (p.TextWidth(font, m.label) + 0.6 * font) - 0.3 * font, oy - 0.9 * font, font, m.label,
                true);
      continue;
    }
    // A dimension: both ends clamped into the window; nothing when it lies wholly outside.
    const double mx = 0.5 * (m.x0 + m.x1), my = 0.5 * (m.y0 + m.y1);
    if (mx < w.x_lo || mx > w.x_hi || my < w.y_lo || my > w.y_hi) continue;
    const auto cx = [&](double x) { return px(std::clamp(x, w.x_lo, w.x_hi)); };
    const auto cy = [&](double y) { return py(std::clamp(y, w.y_lo, w.y_hi)); };
    const double ax = cx(m.x0), ay = cy(m.y0), bx = cx(m.x1), by = cy(m.y1);
    // A short line (a disc's diameter, a few pixels wide) is drawn finer and with shorter ticks,
    // so that two beside each other (a snowman's) stay apart.
    const double len = std::hypot(bx - ax, by - ay), tick = std::min(0.5 * font, 0.3 * len);
    const double stroke = std::min(line, std::max(1.0, 0.12 * len));
    p.Segment(ax, ay, bx, by, stroke, kInk, "dimension");
    const double nx = len > 0 ? -(by - ay) / len : 0, ny = len > 0 ? (bx - ax) / len : 1;
    for (const auto& [ex, ey] : {std::pair{ax, ay}, std::pair{bx, by}})
      p.Segment(ex - tick * nx, ey - tick * ny, ex + tick * nx, ey + tick * ny, stroke, kInk, "dimension");
    if (m.label.empty()) continue;
    // On the line's middle where it fits; else beside it: above a level line, right of another.
    double lx = 0.5 * (ax + bx), ly = 0.5 * (ay + by);
    const double text = p.TextWidth(font, m.label) + 0.6 * font;
    const double away = std::hypot(m.away_x, m.away_y);
    if (away > 0) {
      // Set off along `away` (y flips in pixels): past the half line (what it measures reaches
      // as far that way: a disc's radius) and half the label's own extent that way.
      const double ux = m.away_x / away, uy = -m.away_y / away;
      const double off = 0.5 * len + 0.3 * font + 0.5 * (std::fabs(ux) * text + std::fabs(uy) * 1.3 * font);
      lx += ux * off;
      ly += uy * off;
    } else if (std::fabs(bx - ax) >= std::fabs(by - ay)) {
      if (text > 0.9 * len) ly -= 1.4 * font;
    } else if (1.4 * font > 0.9 * len) {
      lx += 0.5 * text + 0.3 * font;
    }
    // Inside the picture: a line along its edge (a side outlet's W) moves its label inwards.
    lx = std::clamp(lx, 0.5 * text + 2, std::max(0.5 * text + 2, width - 0.5 * text - 2));
    // And below the header strip, above the window's bottom (a label set off upwards).
    ly = std::clamp(ly, top + 0.8 * font, std::max(top + 0.8 * font, py(w.y_lo) - 0.8 * font));
    p.Label(lx, ly, font, m.label, true);
  }
}

void Paint(const Scene& s, PixelSize size, Painter& p) {
  const Window& w = s.window;
  const double k = size.width / (w.x_hi - w.x_lo);
  const double top = HeaderHeight(s, size.width);
  const auto px = [&](double x) { return (x - w.x_lo) * k; };
  const auto py = [&](double y) { return top + (w.y_hi - y) * k; };
  const auto band = [&](const silo::OutlineSegment& g, Rgb fill, const char* cls) {
    p.Polygon({{px(g.ax), py(g.ay)},
               {px(g.bx), py(g.by)},
               {px(g.bx + kBand * g.ox), py(g.by + kBand * g.oy)},
               {px(g.ax + kBand * g.ox), py(g.ay + kBand * g.oy)}},
              fill, cls);
  };
  for (const auto& g : s.silo.walls) band(g, kWall, "wall");
  for (const auto& g : s.silo.outlets) band(g, kOutlet, "outlet");
  for (const auto& c : s.silo.obstacles) p.Circle(px(c.x), py(c.y), c.r * k, kObstacle, kObstacle, 0, "obstacle");
  for (const auto& d : s.discs) {
    const Rgb edge = d.highlight ? kInk : Rgb{d.fill.r * 0.6, d.fill.g * 0.6, d.fill.b * 0.6};
    p.Circle(px(d.x), py(d.y), d.r * k, d.fill, edge, (d.highlight ? 0.16 : 0.04) * k,
             d.highlight ? "disc highlight" : "disc");
  }
  for (const auto& l : s.forces) p.Segment(px(l.x1), py(l.y1), px(l.x2), py(l.y2), l.width * k, l.colour, "force");
  const double font = FontSize(size.width);
  // The report shows pictures at about half their width: marks' labels half as large again as
  // the caption, so that they read there.
  PaintMarks(s, k, top, size.width, 1.6 * font, p);
  // The header strip clear of bodies that reach above the window (a zoom into the bed).
  p.Polygon({{0, 0}, {static_cast<double>(size.width), 0}, {static_cast<double>(size.width), top}, {0, top}},
            kBackground, "header");
  if (!s.caption.empty()) p.Text(font * 0.6, font * 1.3, font, s.caption, false);
  double y = font * 1.3;
  for (const auto& key : s.legend) {
    const double x = size.width - font * 0.6;
    p.Text(x - font * 1.3, y, font * 0.8, key.label, true);
    p.Polygon({{x - font, y - font * 0.75}, {x, y - font * 0.75}, {x, y + font * 0.1}, {x - font, y + font * 0.1}},
              key.colour, "key");
    y += font * 1.2;
  }
}

std::string Hex(Rgb c) {
  char buf[8];
  const auto b = [](double v) { return static_cast<int>(std::lround(std::clamp(v, 0.0, 1.0) * 255)); };
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", b(c.r), b(c.g), b(c.b));
  return buf;
}

std::string Escape(const std::string& t) {
  std::string out;
  for (char c : t) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else
      out += c;
  }
  return out;
}

class SvgPainter : public Painter {
 public:
  std::string out;
  void Polygon(const std::vector<Point>& p, Rgb fill, const char* cls) override {
    out += "<polygon class=\"" + std::string(cls) + "\" fill=\"" + Hex(fill) + "\" points=\"";
    for (const auto& q : p) out += Num(q.x) + "," + Num(q.y) + " ";
    out += "\"/>\n";
  }
  void Circle(double x, double y, double r, Rgb fill, Rgb stroke, double sw, const char* cls) override {
    out += "<circle class=\"" + std::string(cls) + "\" cx=\"" + Num(x) + "\" cy=\"" + Num(y) + "\" r=\"" + Num(r) +
           "\" fill=\"" + Hex(fill) + "\"";
    if (sw > 0) out += " stroke=\"" + Hex(stroke) + "\" stroke-width=\"" + Num(sw) + "\"";
    out += "/>\n";
  }
  void Segment(double x1, double y1, double x2, double y2, double width, Rgb colour, const char* cls) override {
    out += "<line class=\"" + std::string(cls) + "\" x1=\"" + Num(x1) + "\" y1=\"" + Num(y1) + "\" x2=\"" + Num(x2) +
           "\" y2=\"" + Num(y2) + "\" stroke=\"" + Hex(colour) + "\" stroke-width=\"" + Num(width) +
           "\" stroke-linecap=\"round\"/>\n";
  }
  void Text(double x, double y, double size, const std::string& text, bool right) override {
    out += "<text x=\"" + Num(x) + "\" y=\"" + Num(y) + "\" font-size=\"" + Num(size) + "\"" +
           (right ? " text-anchor=\"end\"" : "") + ">" + Escape(text) + "</text>\n";
  }
  void Rectangle(double x, double y, double w, double h, Rgb fill, double opacity, double sw,
                 const char* cls) override {
    out += "<rect class=\"" + std::string(cls) + "\" x=\"" + Num(x) + "\" y=\"" + Num(y) + "\" width=\"" + Num(w) +
           "\" height=\"" + Num(h) + "\" fill=\"" + (opacity > 0 ? Hex(fill) : "none") + "\"" +
           (opacity > 0 ? " fill-opacity=\"" + Num(opacity) + "\"" : "") + " stroke=\"" + Hex(kInk) +
           "\" stroke-width=\"" + Num(sw) + "\"/>\n";
  }
  // No font metrics here: 0.6 em per character, as sans-serif roughly is.
  double TextWidth(double size, const std::string& text) override {
    return 0.6 * size * static_cast<double>(text.size());
  }
  void Label(double x, double y, double size, const std::string& text, bool centred) override {
    const double w = TextWidth(size, text) + 0.6 * size, h = 1.3 * size;
    const double left = centred ? x - 0.5 * w : x - 0.3 * size, baseline = centred ? y + 0.35 * size : y;
    out += "<rect class=\"label-box\" x=\"" + Num(left) + "\" y=\"" + Num(baseline - 0.95 * size) + "\" width=\"" +
           Num(w) + "\" height=\"" + Num(h) + "\" fill=\"" + Hex(kBackground) + "\" fill-opacity=\"0.85\"/>\n";
    out += "<text class=\"label\" x=\"" + Num(x) + "\" y=\"" + Num(baseline) + "\" font-size=\"" + Num(size) + "\"" +
           (centred ? " text-anchor=\"middle\"" : "") + ">" + Escape(text) + "</text>\n";
  }

 private:
  static std::string Num(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f", v);
    return buf;
  }
};

class CairoPainter : public Painter {
 public:
  explicit CairoPainter(cairo_t* cr) : cr_(cr) {}
  void Polygon(const std::vector<Point>& p, Rgb fill, const char*) override {
    if (p.empty()) return;
    cairo_move_to(cr_, p[0].x, p[0].y);
    for (std::size_t i = 1; i < p.size(); ++i) cairo_line_to(cr_, p[i].x, p[i].y);
    cairo_close_path(cr_);
    Set(fill);
    cairo_fill(cr_);
  }
  void Circle(double x, double y, double r, Rgb fill, Rgb stroke, double sw, const char*) override {
    cairo_new_sub_path(cr_);
    cairo_arc(cr_, x, y, r, 0, 2 * M_PI);
    Set(fill);
    if (sw > 0) {
      cairo_fill_preserve(cr_);
      Set(stroke);
      cairo_set_line_width(cr_, sw);
      cairo_stroke(cr_);
    } else {
      cairo_fill(cr_);
    }
  }
  void Segment(double x1, double y1, double x2, double y2, double width, Rgb colour, const char*) override {
    cairo_move_to(cr_, x1, y1);
    cairo_line_to(cr_, x2, y2);
    Set(colour);
    cairo_set_line_width(cr_, width);
    cairo_set_line_cap(cr_, CAIRO_LINE_CAP_ROUND);
    cairo_stroke(cr_);
  }
  void Text(double x, double y, double size, const std::string& text, bool right) override {
    cairo_select_font_face(cr_, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr_, size);
    cairo_text_extents_t e;
    cairo_text_extents(cr_, text.c_str(), &e);
    cairo_move_to(cr_, right ? x - e.x_advance : x, y);
    Set(kInk);
    cairo_show_text(cr_, text.c_str());
  }
  void Rectangle(double x, double y, double w, double h, Rgb fill, double opacity, double sw, const char*) override {
    cairo_rectangle(cr_, x, y, w, h);
    if (opacity > 0) {
      cairo_set_source_rgba(cr_, fill.r, fill.g, fill.b, opacity);
      cairo_fill_preserve(cr_);
    }
    Set(kInk);
    cairo_set_line_width(cr_, sw);
    cairo_stroke(cr_);
  }
  double TextWidth(double size, const std::string& text) override {
    cairo_select_font_face(cr_, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr_, size);
    cairo_text_extents_t e;
    cairo_text_extents(cr_, text.c_str(), &e);
    return e.x_advance;
  }
  void Label(double x, double y, double size, const std::string& text, bool centred) override {
    cairo_select_font_face(cr_, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr_, size);
    cairo_text_extents_t e;
    cairo_text_extents(cr_, text.c_str(), &e);
    const double w = e.x_advance + 0.6 * size, h = 1.3 * size;
    const double left = centred ? x - 0.5 * w : x - 0.3 * size, baseline = centred ? y + 0.35 * size : y;
    cairo_rectangle(cr_, left, baseline - 0.95 * size, w, h);
    cairo_set_source_rgba(cr_, kBackground.r, kBackground.g, kBackground.b, 0.85);
    cairo_fill(cr_);
    cairo_move_to(cr_, centred ? x - 0.5 * e.x_advance : x, baseline);
    Set(kInk);
    cairo_show_text(cr_, text.c_str());
  }

 private:
  void Set(Rgb c) { cairo_set_source_rgb(cr_, c.r, c.g, c.b); }
  cairo_t* cr_;
};

// Draws `scene` on a fresh white ARGB32 surface; the caller destroys it.
cairo_surface_t* Draw(const Scene& scene, PixelSize size) {
  cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, size.width, size.height);
  cairo_t* cr = cairo_create(surface);
  cairo_set_source_rgb(cr, kBackground.r, kBackground.g, kBackground.b);
  cairo_paint(cr);
  CairoPainter painter(cr);
  Paint(scene, size, painter);
  const cairo_status_t status = cairo_status(cr);
  cairo_destroy(cr);
  if (status != CAIRO_STATUS_SUCCESS) {
    cairo_surface_destroy(surface);
    throw std::runtime_error(std::string("cairo: ") + cairo_status_to_string(status));
  }
  cairo_surface_flush(surface);
  return surface;
}

}  // namespace

PixelSize SizeFor(const Scene& scene, int width_px) {
  const int width = std::max(2, width_px & ~1);
  const Window& w = scene.window;
  const double h = width * (w.y_hi - w.y_lo) / (w.x_hi - w.x_lo) + HeaderHeight(scene, width);
  return {width, std::max(2, static_cast<int>(std::lround(h) + 1) & ~1)};
}

std::string Svg(const Scene& scene, int width_px) {
  const PixelSize size = SizeFor(scene, width_px);
  SvgPainter p;
  p.out = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(size.width) + "\" height=\"" +
          std::to_string(size.height) + "\" viewBox=\"0 0 " + std::to_string(size.width) + " " +
          std::to_string(size.height) + "\" font-family=\"sans-serif\">\n<rect width=\"100%\" height=\"100%\" fill=\"" +
          Hex(kBackground) + "\"/>\n";
  Paint(scene, size, p);
  p.out += "</svg>\n";
  return p.out;
}

std::vector<unsigned char> Pixels(const Scene& scene, PixelSize size) {
  cairo_surface_t* surface = Draw(scene, size);
  const int stride = cairo_image_surface_get_stride(surface);
  const unsigned char* data = cairo_image_surface_get_data(surface);
  std::vector<unsigned char> out(static_cast<std::size_t>(size.width) * static_cast<std::size_t>(size.height) * 4);
  for (int row = 0; row < size.height; ++row)
    std::copy_n(data + static_cast<std::ptrdiff_t>(row) * stride, static_cast<std::size_t>(size.width) * 4,
                out.begin() + static_cast<std::ptrdiff_t>(row) * size.width * 4);
  cairo_surface_destroy(surface);
  return out;
}

void WritePng(const Scene& scene, int width_px, const std::filesystem::path& file) {
  cairo_surface_t* surface = Draw(scene, SizeFor(scene, width_px));
  const cairo_status_t status = cairo_surface_write_to_png(surface, file.c_str());
  cairo_surface_destroy(surface);
  if (status != CAIRO_STATUS_SUCCESS)
    throw std::runtime_error("cannot write " + file.string() + ": " + cairo_status_to_string(status));
}

}  // namespace granary::render

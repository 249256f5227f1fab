// Pictures of a silo: a Scene (bodies to scale, walls, outlets, obstacles, an optional
// contact-force network, marks such as regions and dimensions) made from one frame, drawn as SVG text or as PNG pixels (cairo).
// Pure: no files but the one WritePng is asked to write. The verbs `campaign snapshot` and
// `campaign movie` (src/runner) and the report's pictures are thin layers over it; a caller
// marks bodies to draw outlined (an arch, say) through SceneOptions::highlight.
#pragma once

#include <cstdint>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "rundir/contacts.h"
#include "rundir/frames.h"
#include "rundir/run_directory.h"
#include "silo/silo_outline.h"

namespace granary::render {

struct Rgb {
  double r = 0, g = 0, b = 0;  // 0..1
};

// The part of the silo plane a picture shows.
struct Window {
  double x_lo = -1, x_hi = 1, y_lo = -1, y_hi = 1;
};

struct DiscShape {
  double x = 0, y = 0, r = 0.5;
  Rgb fill;
  bool highlight = false;
};
struct Line {
  double x1 = 0, y1 = 0, x2 = 0, y2 = 0, width = 0.1;  // width in silo units (d)
  Rgb colour;
};

// A mark over the picture, in silo units: a rectangle (a region, a zoom's outline), outlined
// and perhaps shaded, its label inside its top left corner; a dimension line between two
// points with end ticks, its label on a white box at its middle ("W = 11 d"); the discs of
// one body measured (kDiscs: the body nearest (x0, y0) in the frame, one dimension line
// across a disc of each size, smallest first, labelled `labels` "= D d"; MakeScene turns it
// into kDimension marks); or a point with short x and y arrows (kOrigin: the origin at (x0, y0)).
struct Mark {
  enum class Kind { kRect, kDimension, kDiscs, kOrigin } kind = Kind::kRect;
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  std::string label;
  bool shade = false;
  // kDiscs: one label per disc size, smallest first; empty: "D" for one size, "D_s" and "D_b"
  // for two (a snowman's head and body, thesis fig. 6.1), "D_1", "D_2", ... for more.
  std::vector<std::string> labels = {};
  // kDimension: the label set off the line's middle this way (silo units; 0, 0: on the line
  // or just beside it): a disc's diameter labels outwards along its body's axis, clear of it.
  double away_x = 0, away_y = 0;
};

struct Scene {
  Window window;
  silo::SiloOutline silo;
  std::vector<DiscShape> discs;  // one per constituent disc: a dumbbell is two
  std::vector<Line> forces;      // contact-force network, if asked for
  std::string caption;           // top left, e.g. "t = 12.5"
  struct Key {
    Rgb colour;
    std::string label;
  };
  std::vector<Key> legend;  // top right: a swatch and a label each
  std::vector<Mark> marks;  // over the bodies, clipped to the window
};

// kDisc: each disc by its species and its place in the body, the largest first (a snowman's
// body and head apart, thesis figs. 6.1, 6.3; a dumbbell's two discs apart).
enum class Colour { kSpecies, kSpeed, kRotation, kForce, kDisc };
// "species", "speed", "rotation", "force", "disc"; throws std::invalid_argument naming the choices.
Colour ColourFromName(const std::string& name);

struct SceneOptions {
  Window window;
  Colour colour = Colour::kSpecies;
  const rundir::ContactFrame* contacts = nullptr;  // needed by Colour::kForce and forces
  bool forces = false;                             // draw the contact-force network
  std::set<std::int64_t> highlight;                // body ids drawn outlined
  std::vector<std::string> species;                // names by type - 1, for the legend
  std::string caption;
  std::vector<Mark> marks;
};

// The window of a silo's pictures: the silo's width (and its side outlets' fall zone) and from
// below the exit line up to just above `top` (the bed's top, so every frame of a run fits).
Window SiloWindow(const silo::SiloOutline& silo, double exit_distance, double top);

// Throws std::invalid_argument when a kDiscs mark finds no body in the frame, or its labels
// are not one per disc size of that body.
Scene MakeScene(const rundir::Frame& frame, const silo::SiloOutline& silo, const SceneOptions& options);

// Pixel size of a picture `width_px` wide: the window to scale under a strip for the caption
// and the legend (both even, as video encoders need).
struct PixelSize {
  int width = 0, height = 0;
};
PixelSize SizeFor(const Scene& scene, int width_px);

// An SVG document: one <circle> per disc (in pixels, y up), walls and outlets as <polygon>s,
// obstacles as <circle class="obstacle">, forces as <line>s, marks as <rect class="mark">,
// <line class="dimension">s and an origin's <circle class="origin"> and <line class="origin">
// arrows, with their labels as <text class="label">.
std::string Svg(const Scene& scene, int width_px);

// The same picture in pixels: cairo's ARGB32 (premultiplied, native-endian: B G R A bytes on
// x86), `size.width * size.height * 4` bytes, row by row from the top.
std::vector<unsigned char> Pixels(const Scene& scene, PixelSize size);
void WritePng(const Scene& scene, int width_px, const std::filesystem::path& file);

}  // namespace granary::render

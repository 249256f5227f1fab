// The shapes a run spec can name (shape_table.h).
#include "rundir/shape_table.h"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <numbers>
#include <stdexcept>

namespace granary {

using nlohmann::json;

namespace {

DiscLayout Disc(const Species& s) { return {{0.0}, {s.diameter / 2}}; }

// Two discs of diameter d, centres d apart.
DiscLayout Dumbbell(const Species& s) { return {{-s.diameter / 2, s.diameter / 2}, {s.diameter / 2, s.diameter / 2}}; }

// The small disc D_s and the big disc D_b touching: centres (D_s + D_b)/2 apart.
DiscLayout Snowman(const Species& s) {
  return {{0.0, (s.diameter + s.big_diameter) / 2}, {s.diameter / 2, s.big_diameter / 2}};
}

// n touching discs of diameter d in a line.
DiscLayout Rod(const Species& s) {
  DiscLayout l;
  for (int k = 0; k < s.n; ++k) {
    l.x.push_back(static_cast<double>(k) * s.diameter);
    l.r.push_back(s.diameter / 2);
  }
  return l;
}

// D_b/D_s in [1, 2]: the thesis' snowmen (a ratio of 1 is a dumbbell).
void CheckSnowman(const Species& s, const std::string& path) {
  const double ratio = s.big_diameter / s.diameter;
  if (ratio < 1.0 || ratio > 2.0) {
    throw SpecError(path + "/big_diameter", "D_b/D_s must be in [1, 2] (got " + json(s.big_diameter).dump() + "/" +
                                                json(s.diameter).dump() + " = " + json(ratio).dump() + ")");
  }
}

}  // namespace

const std::vector<ShapeRow>& ShapeTable() {
  static const std::vector<ShapeRow> kTable = {
      {Shape::kDisc, "disc", "disc", "disc of diameter {diameter}", "X_d", true, Disc, nullptr},
      {Shape::kDumbbell, "dumbbell", "dumbbell", "dumbbell: two touching discs of diameter {diameter}", "X_db", true,
       Dumbbell, nullptr},
      {Shape::kSnowman, "snowman", "snowman", "snowman: discs of diameter {diameter} and {big_diameter}, touching",
       "X_sm", false, Snowman, CheckSnowman},
      {Shape::kRod, "rod", "rod{n}", "rod: {n} touching discs of diameter {diameter} in a line", "", true, Rod,
       nullptr},
  };
  return kTable;
}

const ShapeRow& ShapeRowOf(Shape shape) {
  for (const ShapeRow& row : ShapeTable())
    if (row.shape == shape) return row;
  throw std::logic_error("shape table: no row for shape " + std::to_string(static_cast<int>(shape)));
}

const ShapeRow* FindShapeRow(const std::string& name) {
  for (const ShapeRow& row : ShapeTable())
    if (name == row.name) return &row;
  return nullptr;
}

DiscLayout DiscsOf(const Species& species) { return ShapeRowOf(species.shape).layout(species); }

std::string ShapeText(const std::string& pattern, const std::function<std::string(const std::string& key)>& value) {
  std::string out;
  for (std::size_t i = 0; i < pattern.size();) {
    const std::size_t close = pattern[i] == '{' ? pattern.find('}', i) : std::string::npos;
    if (close == std::string::npos) {
      out += pattern[i++];
      continue;
    }
    out += value(pattern.substr(i + 1, close - i - 1));
    i = close + 1;
  }
  return out;
}

double BodyLength(const Species& species) {
  const DiscLayout l = DiscsOf(species);
  if (l.x.empty()) return 0.0;
  double lo = l.x[0] - l.r[0], hi = l.x[0] + l.r[0];
  for (std::size_t k = 1; k < l.x.size(); ++k) {
    lo = std::min(lo, l.x[k] - l.r[k]);
    hi = std::max(hi, l.x[k] + l.r[k]);
  }
  return hi - lo;
}

double BodyArea(const Species& species) {
  double area = 0.0;
  for (double r : DiscsOf(species).r) area += std::numbers::pi * r * r;
  return area;
}

}  // namespace granary

// The shapes a run spec can name, one row each. Every body is a rigid clump of discs whose
// centres lie on the body's axis; a row says how a species' parameters lay those discs out.
// Whatever depends on a body's shape reads it off the row or its layout: the spec's names and
// checks (run_spec.cpp), the bodies' mass and inertia (silo/shapes.h), the estimate's sample
// discs (runner/estimate.cpp), the external backends' templates, the report's wording. A new
// shape is a value of `Shape` (run_spec.h) and a row in shape_table.cpp.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "rundir/run_spec.h"

namespace granary {

// The discs of one body along its axis, in units of the spec's lengths: centre x[k] and radius
// r[k] (the origin is any point of the axis: silo::MakeTemplate moves it to the centre of
// mass). Neighbouring discs touch.
struct DiscLayout {
  std::vector<double> x, r;
};

struct ShapeRow {
  Shape shape;
  const char* name;  // as the spec writes it (bodies/species/*/shape)
  // The species' name when the spec gives none ({n} as below).
  const char* default_name;
  // How the report describes a species of this shape; {diameter}, {big_diameter} and {n}
  // stand for the species' values.
  const char* form;
  // The thesis' symbol of this species' number fraction ("X_db"), or "" (then the report
  // names it by the species' name).
  const char* fraction_symbol;
  // A half turn maps the body onto itself (discs, dumbbells, rods; not snowmen): half the
  // orientations cover all of them.
  bool half_turn_symmetric;
  DiscLayout (*layout)(const Species& species);
  // Bounds of this shape's parameters beyond each one's own (run_spec.cpp checks those): throws
  // SpecError under `path` (the species' JSON Pointer). nullptr: none.
  void (*check)(const Species& species, const std::string& path);
};

// Every shape, in the order the spec's documentation lists them.
const std::vector<ShapeRow>& ShapeTable();
// The row of `shape` (every value of Shape has one).
const ShapeRow& ShapeRowOf(Shape shape);
// The row named `name`, or nullptr.
const ShapeRow* FindShapeRow(const std::string& name);
// The discs of one body of `species`.
DiscLayout DiscsOf(const Species& species);

// `pattern` (a row's form or default_name) with {diameter}, {big_diameter} and {n} replaced by
// Value(key).
std::string ShapeText(const std::string& pattern, const std::function<std::string(const std::string& key)>& value);

// Derived from the layout: the body's extent along its axis, and the area of its discs (the
// discs touch without overlapping).
double BodyLength(const Species& species);
double BodyArea(const Species& species);

}  // namespace granary

// See spec_table.h.
#include "rundir/spec_table.h"

#include <cstdio>
#include <stdexcept>

namespace granary {

using nlohmann::json;

namespace {

std::string Number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string Parent(const std::string& pattern) {
  const auto slash = pattern.rfind('/');
  return slash == std::string::npos ? std::string() : pattern.substr(0, slash);
}

std::string Last(const std::string& pattern) { return pattern.substr(pattern.rfind('/') + 1); }

}  // namespace

std::string SpecPattern(const std::string& pointer) {
  std::string out;
  std::size_t i = 0;
  while (i < pointer.size()) {
    const std::size_t next = pointer.find('/', i + 1);
    const std::string token = pointer.substr(i + 1, (next == std::string::npos ? pointer.size() : next) - i - 1);
    const bool index = !token.empty() && token.find_first_not_of("0123456789") == std::string::npos;
    out += "/" + (index ? std::string("*") : token);
    if (next == std::string::npos) break;
    i = next;
  }
  return out;
}

std::string SpecBoundError(const SpecField& f, double v) {
  const bool low = f.minimum && (f.minimum->exclusive ? !(v > f.minimum->value) : !(v >= f.minimum->value));
  const bool high = f.maximum && (f.maximum->exclusive ? !(v < f.maximum->value) : !(v <= f.maximum->value));
  if (!low && !high) return "";
  const std::string kind = f.type == SpecType::kInteger || f.type == SpecType::kUnsigned ? "an integer " : "";
  if (f.minimum && f.maximum)
    return "must be " + kind + "in " + (f.minimum->exclusive ? "(" : "[") + Number(f.minimum->value) + ", " +
           Number(f.maximum->value) + (f.maximum->exclusive ? ")" : "]");
  if (f.minimum) return "must be " + kind + (f.minimum->exclusive ? "> " : ">= ") + Number(f.minimum->value);
  return "must be " + kind + (f.maximum->exclusive ? "< " : "<= ") + Number(f.maximum->value);
}

SpecTable::SpecTable(std::vector<SpecField> fields) : fields_(std::move(fields)) {
  for (const SpecField& f : fields_) {
    if (f.pattern.empty()) continue;
    const SpecField* parent = Parent(f.pattern).empty() ? nullptr : Find(Parent(f.pattern));
    const bool ok =
        Parent(f.pattern).empty() ||
        (parent && (Last(f.pattern) == "*" ? parent->type == SpecType::kArray : parent->type == SpecType::kObject));
    if (!ok) throw std::logic_error("spec table: " + f.pattern + " has no object or array row above it");
  }
}

const SpecField* SpecTable::Find(const std::string& pattern) const {
  for (const SpecField& f : fields_)
    if (f.pattern == pattern) return &f;
  return nullptr;
}

const SpecField& SpecTable::At(const std::string& pattern) const {
  if (const SpecField* f = Find(pattern)) return *f;
  throw std::logic_error("spec table: no row " + pattern);
}

std::vector<std::string> SpecTable::Keys(const std::string& pattern) const {
  std::vector<std::string> out;
  for (const SpecField& f : fields_)
    if (!f.pattern.empty() && Parent(f.pattern) == pattern && Last(f.pattern) != "*") out.push_back(Last(f.pattern));
  return out;
}

std::string SpecTable::PointerRegex(const std::vector<std::string>& leave_out) const {
  std::string alternatives;
  for (const SpecField& f : fields_) {
    if (f.pattern.empty()) continue;
    bool skip = false;
    for (const auto& l : leave_out) skip = skip || f.pattern == l;
    if (skip) continue;
    std::string re;
    for (const char c : f.pattern) re += c == '*' ? std::string("[0-9]+") : std::string(1, c);
    alternatives += (alternatives.empty() ? "" : "|") + re;
  }
  return "^(" + alternatives + ")$";
}

json SpecTable::JsonSchema(const std::string& pattern, const std::string& axis_pattern) const {
  const SpecField* f = pattern.empty() ? nullptr : Find(pattern);
  json s = json::object();
  if (f && !f->description.empty()) s["description"] = f->description;
  if (f && !f->default_value.is_null()) s["default"] = f->default_value;
  const SpecType type = f ? f->type : SpecType::kObject;
  auto bounds = [&](json& j) {
    if (f->minimum) j[f->minimum->exclusive ? "exclusiveMinimum" : "minimum"] = f->minimum->value;
    if (f->maximum) j[f->maximum->exclusive ? "exclusiveMaximum" : "maximum"] = f->maximum->value;
  };
  switch (type) {
    case SpecType::kObject: {
      s["type"] = "object";
      json properties = json::object();
      json required = json::array();
      for (const std::string& key : Keys(pattern)) {
        const std::string child = pattern + "/" + key;
        properties[key] = JsonSchema(child, axis_pattern);
        if (At(child).required) required.push_back(key);
      }
      s["properties"] = properties;
      if (!required.empty()) s["required"] = required;
      s["additionalProperties"] = false;
      break;
    }
    case SpecType::kOpenObject: s["type"] = "object"; break;
    case SpecType::kArray:
      s["type"] = "array";
      if (Find(pattern + "/*")) s["items"] = JsonSchema(pattern + "/*", axis_pattern);
      if (f->min_items > 0) s["minItems"] = f->min_items;
      break;
    case SpecType::kNumber:
      s["type"] = "number";
      bounds(s);
      break;
    case SpecType::kInteger:
      s["type"] = "integer";
      bounds(s);
      break;
    case SpecType::kUnsigned:
      s["type"] = "integer";
      s["minimum"] = 0;
      break;
    case SpecType::kBoolean: s["type"] = "boolean"; break;
    case SpecType::kString:
      s["type"] = "string";
      if (f->min_length > 0) s["minLength"] = f->min_length;
      break;
    case SpecType::kEnum:
      s["type"] = "string";
      s["enum"] = f->values;
      break;
    case SpecType::kEnumOrList:
      s["oneOf"] = json::array({{{"type", "string"}, {"enum", f->values}},
                                {{"type", "array"},
                                 {"items", {{"type", "string"}, {"enum", f->values}}},
                                 {"minItems", 1},
                                 {"uniqueItems", true}}});
      break;
    case SpecType::kAxisValues:
      s["type"] = "object";
      s["propertyNames"] = {{"pattern", axis_pattern}};
      s["additionalProperties"] = {{"type", "array"}, {"minItems", 1}};
      break;
    case SpecType::kAxisPoints:
      s["type"] = "array";
      s["minItems"] = 1;
      s["items"] = {{"type", "object"}, {"propertyNames", {{"pattern", axis_pattern}}}};
      break;
    case SpecType::kRunSpec: s["$ref"] = "#/definitions/run_spec"; break;
  }
  return s;
}

}  // namespace granary

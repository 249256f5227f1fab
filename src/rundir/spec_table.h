// The keys, types, defaults and allowed ranges of a JSON spec as one table, read by the
// validator (RunSpec::from_json, CampaignSpec::from_json: which keys exist, what type each
// has, what range a number must be in) and by the JSON Schema generator (`campaign schema`,
// for editors). A key added to a table is known to both at once; nothing else lists keys.
//
// A row names its place by a pattern: a JSON Pointer whose array indices are "*"
// ("/silo/base_outlets/*/width"). Checks that relate several values (an outlet narrower than
// the silo, fractions summing to 1) are not in the table: they stay in the validators.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace granary {

enum class SpecType {
  kObject,      // the keys are the rows below it
  kOpenObject,  // any keys (checked elsewhere, e.g. /report by the analysis library)
  kArray,       // its elements are the row "<pattern>/*"
  kNumber,
  kInteger,
  kUnsigned,  // an integer >= 0
  kBoolean,
  kString,
  kEnum,        // one of `values`
  kEnumOrList,  // one of `values`, or a non-empty list of distinct ones (the campaign's engine)
  kAxisValues,  // {JSON Pointer into the run spec: [values]} (sweep grid and zip)
  kAxisPoints,  // [{JSON Pointer into the run spec: value}] (sweep points)
  kRunSpec,     // a run spec (its own table)
};

struct SpecBound {
  double value = 0.0;
  bool exclusive = false;  // > rather than >=, < rather than <=
};

struct SpecField {
  SpecField(std::string pattern_, SpecType type_, std::string description_, nlohmann::json default_ = nullptr)
      : pattern(std::move(pattern_)),
        type(type_),
        description(std::move(description_)),
        default_value(std::move(default_)) {}
  std::string pattern;  // "/silo/base_outlets/*/width"
  SpecType type = SpecType::kNumber;
  std::string description;
  nlohmann::json default_value;  // null: none (required, computed from other keys, or set by the runner)
  std::optional<SpecBound> minimum;
  std::optional<SpecBound> maximum;
  std::vector<std::string> values;  // kEnum, kEnumOrList
  std::size_t min_items = 0;        // kArray
  bool required = false;
  std::size_t min_length = 0;  // kString
};

class SpecTable {
 public:
  explicit SpecTable(std::vector<SpecField> fields);
  const std::vector<SpecField>& Fields() const { return fields_; }
  // The row of a pattern, or nullptr.
  const SpecField* Find(const std::string& pattern) const;
  // The row of a pattern; a missing row is a programming error (std::logic_error).
  const SpecField& At(const std::string& pattern) const;
  // The keys of the object at `pattern`, in table order ("" is the root).
  std::vector<std::string> Keys(const std::string& pattern) const;
  // JSON Schema (draft-07) of the value at `pattern` ("" is the root). kRunSpec and the axis
  // kinds refer to "#/definitions/run_spec" and use `axis_pattern` (a regular expression of the
  // JSON Pointers an axis may be).
  nlohmann::json JsonSchema(const std::string& pattern, const std::string& axis_pattern = "") const;
  // A regular expression matching every JSON Pointer this table allows ("*" = any index):
  // "^(/seed|/silo/base_outlets/[0-9]+/width|...)$". Patterns in `leave_out` are left out.
  std::string PointerRegex(const std::vector<std::string>& leave_out = {}) const;

 private:
  std::vector<SpecField> fields_;
};

// The pattern of a concrete JSON Pointer: every array index (all digits) becomes "*".
std::string SpecPattern(const std::string& pointer);

// "" if `value` is within the field's bounds, else what is allowed: "must be > 0",
// "must be in [0, 1]", "must be an integer >= 1".
std::string SpecBoundError(const SpecField& field, double value);

}  // namespace granary

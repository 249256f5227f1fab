// JSON numbers with NaN as null (JSON has no NaN), and back: how every analysis result and
// the arch records of a run directory store a number that may be missing.
#pragma once

#include <nlohmann/json.hpp>

namespace granary::analysis {

nlohmann::json JsonNumber(double value);
// The number, or NaN when it is null or not a number.
double NumberOf(const nlohmann::json& value);
// The number at `key` of an object, or NaN when the key is absent or not a number.
double NumberAt(const nlohmann::json& object, const char* key);

}  // namespace granary::analysis

#include "analysis/json_numbers.h"

#include <cmath>
#include <limits>

namespace granary::analysis {

nlohmann::json JsonNumber(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

double NumberOf(const nlohmann::json& value) {
  return value.is_number() ? value.get<double>() : std::numeric_limits<double>::quiet_NaN();
}

double NumberAt(const nlohmann::json& object, const char* key) {
  return object.is_object() && object.contains(key) ? NumberOf(object.at(key))
                                                    : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace granary::analysis

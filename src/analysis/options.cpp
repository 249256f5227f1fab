// See options.h.
#include "analysis/options.h"

#include <cmath>
#include <cstdio>

namespace granary::analysis {
namespace {

std::string Shown(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace

OptionError::OptionError(const std::string& path, const nlohmann::json& value, const std::string& allowed)
    : std::invalid_argument(path + ": " + allowed + " (got " + value.dump() + ")"), path_(path) {}

double OptionNumber(const nlohmann::json& value, const std::string& path, double lo, double hi) {
  if (!value.is_number()) throw OptionError(path, value, "must be a number");
  const double v = value.get<double>();
  if (!(v >= lo && v <= hi)) throw OptionError(path, value, "must be in [" + Shown(lo) + ", " + Shown(hi) + "]");
  return v;
}

int OptionInteger(const nlohmann::json& value, const std::string& path, int lo, int hi) {
  const double v = OptionNumber(value, path, lo, hi);
  if (v != std::floor(v)) throw OptionError(path, value, "must be an integer");
  return static_cast<int>(v);
}

bool OptionBool(const nlohmann::json& value, const std::string& path) {
  if (!value.is_boolean()) throw OptionError(path, value, "must be true or false");
  return value.get<bool>();
}

const nlohmann::json& OptionObject(const nlohmann::json& value, const std::string& path,
                                   std::initializer_list<const char*> known) {
  std::string list;
  for (const char* k : known) list += (list.empty() ? "" : ", ") + std::string(k);
  if (!value.is_object()) throw OptionError(path, value, "must be an object with the keys " + list);
  for (const auto& [key, v] : value.items()) {
    bool found = false;
    for (const char* k : known) found = found || key == k;
    if (!found) throw OptionError(path + "/" + key, v, "unknown key (known: " + list + ")");
  }
  return value;
}

}  // namespace granary::analysis

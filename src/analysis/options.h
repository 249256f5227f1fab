// Reading analysis options from the campaign spec's "/report" object: every error names the
// JSON path, the bad value and what is allowed, e.g.
// "/report/window/start_fraction: must be in [0, 1] (got 1.5)".
#pragma once

#include <initializer_list>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

namespace granary::analysis {

class OptionError : public std::invalid_argument {
 public:
  OptionError(const std::string& path, const nlohmann::json& value, const std::string& allowed);
  const std::string& Path() const { return path_; }

 private:
  std::string path_;
};

// A number in [lo, hi].
double OptionNumber(const nlohmann::json& value, const std::string& path, double lo, double hi);
// An integer in [lo, hi].
int OptionInteger(const nlohmann::json& value, const std::string& path, int lo, int hi);
bool OptionBool(const nlohmann::json& value, const std::string& path);
// An object whose keys are all in `known` (else: "unknown key (known: a, b)").
const nlohmann::json& OptionObject(const nlohmann::json& value, const std::string& path,
                                   std::initializer_list<const char*> known);

}  // namespace granary::analysis

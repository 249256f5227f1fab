// The --only filters of `campaign run`, `status`, `report` and `export` (docs/cli.md): each
// is a run-id prefix, or POINTER=VALUE on the resolved parameters, where an axis' short name as
// the report prints it ("D_b=1.5", analysis/axes.h) or a short name that ends exactly one sweep
// axis ("width=9" for /silo/base_outlets/0/width=9) stands for it, or NAME=VALUE on a derived
// axis of the campaign spec's /axes ("D_eq=1.80278"; resolved into the ids of the runs it selects).
// Several filters: values of one parameter are alternatives (--only width=5 --only width=7),
// different parameters must all hold, and run-id prefixes are alternatives among themselves.
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "runner/campaign_db.h"

namespace granary::runner {

// A filter that cannot select anything; the message says what there is to choose from.
class FilterError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

class RunFilter {
 public:
  RunFilter() = default;  // passes every run
  // Filters written with full pointers (no short names). Throws FilterError for a malformed
  // JSON Pointer.
  explicit RunFilter(const std::vector<std::string>& filters);

  bool empty() const { return prefixes_.empty() && values_.empty(); }
  bool Matches(const RunRow& row) const;
  // The filters as given to the constructor (full pointers), e.g. for CampaignRunOptions::only.
  const std::vector<std::string>& Texts() const { return texts_; }

 private:
  std::vector<std::string> texts_;
  std::vector<std::string> prefixes_;
  // pointer -> the VALUE texts given for it
  std::map<std::string, std::vector<std::string>> values_;
};

// Does the value at `pointer` of `row`'s parameters equal VALUE (a JSON value, or the text of
// a string)? Numbers compare as numbers (9 == 9.0).
bool ParameterMatches(const RunRow& row, const std::string& pointer, const std::string& value);

// Resolves short names against the campaign's sweep axes and checks that every filter, and
// all of them together, select at least one of `runs` that is not retired. Throws FilterError
// naming the run ids, axes or values there are.
RunFilter ResolveFilters(const std::vector<std::string>& filters, const CampaignRow& campaign,
                         const std::vector<RunRow>& runs);

}  // namespace granary::runner

// What `status` asks of the report family: the reproduction table's counts.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace granary::runner::cli {

// The campaign spec in `db` states expected values (/expect): analyse its finished runs (the
// runs' caches first; nothing is written to the database) and count the verdicts, "7 agree,
// 1 disagrees, 3 not yet". nullopt without /expect or without the analysis library.
std::optional<std::string> ExpectationCounts(const std::string& db, std::ostream& err,
                                             const std::vector<std::string>& only);

}  // namespace granary::runner::cli

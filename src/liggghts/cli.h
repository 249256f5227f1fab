// Verbs of granary-liggghts (docs/liggghts.md): the thin front end over backend.h.
#pragma once

#include <string>
#include <vector>

namespace granary::liggghts {

// Returns the process exit status: 0 success, 1 run failed, 2 usage or spec error.
int LiggghtsMain(const std::vector<std::string>& args);

}  // namespace granary::liggghts

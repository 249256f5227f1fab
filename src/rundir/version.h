// Granary's version and the commit it was built from, for provenance (summary.json, the
// database, reports, --version).
#pragma once

#ifndef GRANARY_VERSION
#define GRANARY_VERSION "0.0.0"
#endif

namespace granary {

// Short commit id of the checkout at build time, "<id>-dirty" with uncommitted changes to
// tracked files, "unknown" outside git. Generated at every build (cmake/git_commit.cmake).
const char* GitCommit();

}  // namespace granary

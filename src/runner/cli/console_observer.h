// The display of `campaign run` (and compare): on a terminal, a bar and one line per active
// run redrawn in place; otherwise a progress line every 10 s. Every state change is a line.
#pragma once

#include <iosfwd>
#include <map>
#include <memory>
#include <string>

#include "runner/scheduler.h"

namespace granary::runner::cli {

// `tty`: `out` is a terminal, so the display may move the cursor and redraw.
// `short_names`: pointer -> short name of the campaign's axes, for the points in progress lines.
std::unique_ptr<RunObserver> MakeConsoleObserver(std::ostream& out, bool tty,
                                                 std::map<std::string, std::string> short_names = {});

}  // namespace granary::runner::cli

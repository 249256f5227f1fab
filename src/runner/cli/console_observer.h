// The display of `campaign run` (and compare): on a terminal, a bar and one line per active
// run redrawn in place; otherwise a progress line every 10 s. Every state change is a line.
#pragma once

#include <iosfwd>
#include <memory>

#include "runner/scheduler.h"

namespace granary::runner::cli {

// `tty`: `out` is a terminal, so the display may move the cursor and redraw.
std::unique_ptr<RunObserver> MakeConsoleObserver(std::ostream& out, bool tty);

}  // namespace granary::runner::cli

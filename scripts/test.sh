#!/usr/bin/env bash
# Set up (install, build) and run the whole test suite. This is what CI runs.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$here/scripts/setup.sh"
build="${GRANARY_BUILD_DIR:-$here/build}"
cd "$build"
ctest --output-on-failure -j "$(nproc)" -LE validation "$@"

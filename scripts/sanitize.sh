#!/usr/bin/env bash
# The test suite under AddressSanitizer and UndefinedBehaviorSanitizer: a separate build
# (build-asan, or $GRANARY_SANITIZE_BUILD_DIR) of everything with -fsanitize=address,undefined
# (every finding fatal), then the same tests as scripts/test.sh. The engines and the
# `campaign` binary the tests start are sanitized builds too. Not part of scripts/test.sh:
# the second build alone takes about 8 minutes on 2 cores (docs/architecture.md "Tests").
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
GRANARY_BUILD_DIR="$here/build" "$here/scripts/setup.sh" >/dev/null  # packages (and the normal build)
build="${GRANARY_SANITIZE_BUILD_DIR:-$here/build-asan}"
cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DGRANARY_SANITIZE=ON >/dev/null
cmake --build "$build" -j "$(nproc)"
cd "$build"
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}"
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$here/scripts/lsan.supp}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
ctest --output-on-failure -j "$(nproc)" -LE validation "$@"

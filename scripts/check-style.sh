#!/usr/bin/env bash
# The tree's one style, checked by tools: layout by clang-format (.clang-format) and names by
# clang-tidy's readability-identifier-naming (.clang-tidy), over every C++ file under src/ and
# tests/. The test command runs it (ctest: Style.Format, Style.Naming).
#
#   scripts/check-style.sh format [--fix]     layout; --fix rewrites the files in place
#   scripts/check-style.sh naming [--fix] [REGEX...]
#                                             names; needs BUILD/compile_commands.json
#                                             (GRANARY_BUILD_DIR, default build/);
#                                             --fix renames declarations and every use in the
#                                             files parsed; REGEX limits those files (default:
#                                             everything under src/ and tests/)
# Exit codes: 0 clean (or fixed), 1 a file departs from the style, 2 bad usage or tool missing.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${GRANARY_BUILD_DIR:-$here/build}"
what="${1:-}"
shift || true
fix=""
if [ "${1:-}" = "--fix" ]; then fix="--fix"; shift; fi
usage() { echo "usage: scripts/check-style.sh format [--fix] | naming [--fix] [REGEX...]" >&2; exit 2; }
need() { command -v "$1" >/dev/null || { echo "check-style: $1 not found (scripts/setup.sh installs it)" >&2; exit 2; }; }
cd "$here"
mapfile -t files < <(git ls-files 'src/*.cpp' 'src/*.h' 'tests/*.cpp' 'tests/*.h' 2>/dev/null ||
                     find src tests -name '*.cpp' -o -name '*.h')
case "$what" in
  format)
    (($#)) && usage
    need clang-format
    if [ -n "$fix" ]; then
      clang-format -i "${files[@]}"
    else
      clang-format --dry-run --Werror "${files[@]}" || {
        echo "check-style: layout departs from .clang-format (scripts/check-style.sh format --fix)" >&2; exit 1; }
    fi ;;
  naming)
    need run-clang-tidy
    [ -f "$build/compile_commands.json" ] || { echo "check-style: no $build/compile_commands.json (configure with cmake first)" >&2; exit 2; }
    # The compiler's warnings are GCC's to give (the build has them as errors); clang parses
    # only to see the names. Clang leaves sized deallocation off by default, GCC on.
    args=(-p "$build" -quiet -j "$(nproc)" -extra-arg=-w -extra-arg=-fsized-deallocation)
    [ -n "$fix" ] && args+=(-fix)
    log="$(mktemp)"; trap 'rm -f "$log"' EXIT
    filters=("$@")
    ((${#filters[@]})) || filters=("$here/src/" "$here/tests/")
    if run-clang-tidy "${args[@]}" "${filters[@]}" >"$log" 2>&1; then
      echo "check-style: names follow .clang-tidy"
    elif [ -n "$fix" ]; then
      # clang-tidy reports what it found before it renamed; uses it cannot see (a template's
      # dependent calls) show up in the build.
      echo "check-style: renamed what departed; build, then run scripts/check-style.sh naming again"
    else
      grep -E "error:|warning:" "$log" | grep -v "^Error while processing" | sort -u | head -200 >&2 || true
      echo "check-style: names depart from .clang-tidy (scripts/check-style.sh naming --fix renames them)" >&2
      exit 1
    fi ;;
  *) usage ;;
esac

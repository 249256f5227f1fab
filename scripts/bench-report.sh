#!/usr/bin/env bash
# Times `campaign report` on a finished campaign (docs/benchmarks.md): cold (every run's cached
# analysis results removed first), cached, and cached without figures, in interleaved rounds.
# With OLD=path/to/an/older/campaign and OLD_DB=its own copy of the database (an older binary
# refuses a newer schema), the older binary's report is timed in each round too.
# Usage: [OLD=... OLD_DB=...] scripts/bench-report.sh DB [ROUNDS]    (run it under `cpu bench`)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
db="$1"
rounds="${2:-3}"
new="${NEW:-$here/build/bin/campaign}"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
runs="$(dirname "$(realpath "$db")")/runs"
seconds() {
  local start end
  start=$(date +%s.%N)
  "$@" > /dev/null 2>&1 || { echo "failed: $*" >&2; exit 1; }
  end=$(date +%s.%N)
  echo "$end - $start" | bc
}
for round in $(seq 1 "$rounds"); do
  if [ -n "${OLD:-}" ]; then
    echo "round=$round before=$(seconds "$OLD" report --db "$OLD_DB" --out "$out/old")"
    echo "round=$round before_no_figures=$(seconds "$OLD" report --db "$OLD_DB" --out "$out/old2" --no-figures)"
  fi
  rm -rf "$runs"/*/analyses
  echo "round=$round cold=$(seconds "$new" report --db "$db" --out "$out/new")"
  echo "round=$round cached=$(seconds "$new" report --db "$db" --out "$out/new")"
  echo "round=$round cached_no_figures=$(seconds "$new" report --db "$db" --out "$out/new2" --no-figures)"
done

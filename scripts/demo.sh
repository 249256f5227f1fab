#!/usr/bin/env bash
# The demo: build Granary (scripts/setup.sh), then plan, run and report the small demo
# campaign campaigns/demo.json into demo/ (database demo/granary.db, report demo/report/).
# Re-running it continues where it stopped (finished runs are kept).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${GRANARY_BUILD_DIR:-$here/build}"
"$here/scripts/setup.sh"
campaign="$build/bin/campaign"
mkdir -p "$here/demo"
cd "$here/demo"
"$campaign" plan "$here/campaigns/demo.json" --db granary.db
status=0
"$campaign" run --db granary.db || status=$?
if [ "$status" = 130 ]; then exit 130; fi
"$campaign" status --db granary.db
"$campaign" report --db granary.db --out report
echo
echo "demo: report in $here/demo/report/report.html (and report.md)"
exit "$status"

#!/usr/bin/env bash
# Measures the disk cost of frames: one native run of N dumbbells (default 4000) in a silo of
# width 60, reinject mode, frames and contact frames every 0.5 for 5 time units, written plain
# and gzip-compressed (output.compress). Prints bytes per disc row and per contact row, for both.
# Usage: scripts/dump-cost.sh [BODIES]   (docs/run-directory.md "Disk cost" has the figures)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
engine="${GRANARY_BUILD_DIR:-$here/build}/bin/granary-engine"
bodies="${1:-4000}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
for compress in false true; do
  mkdir -p "$work/$compress"
  cat > "$work/$compress/run.json" <<JSON
{"run_id": "dump-cost", "seed": 1,
 "silo": {"width": 60, "base_outlets": [{"center": 0, "width": 10}]},
 "bodies": {"count": $bodies, "species": [{"shape": "dumbbell"}]},
 "bed": {"cache_file": "$work/bed.json"},
 "discharge": {"mode": "reinject", "max_time": 5, "stop_on_clog": false},
 "output": {"frame_interval": 0.5, "contact_forces": true, "compress": $compress, "checkpoint_interval": 0}}
JSON
  "$engine" run "$work/$compress" > /dev/null
done
python3 - "$work" <<'PY'
import gzip, os, sys
work = sys.argv[1]
def rows(text, item):
    n = 0
    lines = text.splitlines()
    for i, l in enumerate(lines):
        if l == "ITEM: NUMBER OF " + item: n += int(lines[i + 1])
    return n
for name, item in (("frames.dump", "ATOMS"), ("contacts.dump", "ENTRIES")):
    plain = os.path.getsize(os.path.join(work, "false", name))
    gz = os.path.getsize(os.path.join(work, "true", name + ".gz"))
    text = gzip.open(os.path.join(work, "true", name + ".gz"), "rt").read()
    blocks = text.count("ITEM: TIMESTEP")
    n = rows(text, item)
    print(f"{name}: {blocks} frames, {n / blocks:.0f} rows per frame; plain {plain} B = {plain / n:.1f} B/row, "
          f"gzip {gz} B = {gz / n:.1f} B/row ({100 * gz / plain:.0f} %)")
PY

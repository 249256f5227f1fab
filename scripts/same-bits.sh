#!/usr/bin/env bash
# Same bits: the three cases of `granary-engine bench` (discs, dumbbells, the ch. 4 mixture;
# 8000 bodies, W = 14, reinject) run with two engine binaries at 1 and 2 threads, and their
# frames, contact frames and events compared byte for byte (docs/benchmarks.md).
#
#   scripts/same-bits.sh BEFORE AFTER        e.g. /tmp/main-engine build/bin/granary-engine
#
# Environment: STEPS (default 15000 steps of 1e-4: exits begin), FRAME (frame interval, default 0.1),
# SHAPES (default "disc dumbbell mixture"), THREADS (default "1 2"), WORK (a directory
# kept between calls: the settled beds are cached there, prepared once by BEFORE's bench;
# default a new temporary directory). Exits 1 at the first file that differs.
set -euo pipefail

if [ $# -ne 2 ]; then
  echo "usage: $0 BEFORE_ENGINE AFTER_ENGINE" >&2
  exit 2
fi
before=$(realpath "$1")
after=$(realpath "$2")
steps=${STEPS:-15000}
frame=${FRAME:-0.1}
shapes=${SHAPES:-disc dumbbell mixture}
threads_list=${THREADS:-1 2}
work=${WORK:-$(mktemp -d -t granary-same-bits-XXXXXX)}
mkdir -p "$work"
echo "same-bits: $before against $after, $steps steps, work directory $work"

# The bench's run spec (src/engine/bench.cpp BenchSpec) with frames and contact frames.
write_spec() {  # shape bed_file dir
  python3 - "$1" "$2" "$steps" "$frame" > "$3/run.json" <<'PY'
import json, math, sys
shape, bed, steps, frame = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4])
species = {"disc": [{"shape": "disc"}], "dumbbell": [{"shape": "dumbbell"}],
           "mixture": [{"shape": "dumbbell", "fraction": 0.5},
                       {"shape": "disc", "diameter": math.sqrt(2), "fraction": 0.5}]}[shape]
print(json.dumps({
    "run_id": "bench", "seed": 1,
    "silo": {"width": 100.0, "base_outlets": [{"center": 0.0, "width": 14.0}]},
    "bodies": {"count": 8000, "species": species},
    "discharge": {"mode": "reinject", "max_time": steps * 1e-4, "stop_on_clog": False},
    "output": {"checkpoint_interval": 0.0, "frame_interval": frame, "contact_forces": True},
    "bed": {"batch_size": 2000, "settle_ke_per_body": 1e-4, "max_settle_time": 30.0, "cache_file": bed}}, indent=1))
PY
}

for shape in $shapes; do
  bed="$work/bed-$shape.json"
  if [ ! -e "$bed" ]; then
    echo "same-bits: preparing the $shape bed (once)"
    "$before" bench --shape "$shape" --steps 1 --threads-list 1 --bed "$bed" > "$work/bed-$shape.log"
  fi
  for threads in $threads_list; do
    for which in before after; do
      dir="$work/$shape-t$threads-$which"
      rm -rf "$dir"
      mkdir -p "$dir"
      write_spec "$shape" "$bed" "$dir"
      engine=$before
      [ "$which" = after ] && engine=$after
      "$engine" run "$dir" --threads "$threads" > "$dir/engine.log" 2>&1
    done
    a="$work/$shape-t$threads-before"
    b="$work/$shape-t$threads-after"
    for f in frames.dump contacts.dump events.csv; do
      [ -s "$a/$f" ] || { echo "same-bits: $a/$f missing or empty" >&2; exit 1; }
    done
    for f in frames.dump frames.data contacts.dump events.csv clog_frames.dump clog_contacts.dump; do
      [ -e "$a/$f" ] || [ -e "$b/$f" ] || continue
      cmp "$a/$f" "$b/$f"
    done
    echo "same-bits: $shape, $threads thread(s): identical ($(grep -c '^ITEM: TIMESTEP' "$a/frames.dump") frames," \
         "$(wc -l < "$a/contacts.dump") contact-dump lines, $(($(wc -l < "$a/events.csv") - 1)) events;" \
         "frames.dump sha256 $(sha256sum "$a/frames.dump" | cut -c1-16))"
  done
done
echo "same-bits: all identical"

"""How fast python/granary reads frames: every frame of a run with its contact frame and its
bodies rebuilt, best of R passes, as seconds per frame (wall and CPU) (the figure granary-read-run bench
gives for the C++ readers; docs/benchmarks.md).

    /usr/bin/python3 -m granary.bench RUN_DIR [--repeat R]
"""

import argparse
import json
import sys
import time

from . import open_run


def main(argv=None):
    p = argparse.ArgumentParser(prog="python3 -m granary.bench", description=__doc__.split("\n\n")[0])
    p.add_argument("run", help="a run directory with frames and contact frames")
    p.add_argument("--repeat", type=int, default=3, help="passes; the best is reported (default 3)")
    a = p.parse_args(argv)
    run = open_run(a.run)
    best = best_cpu = float("inf")
    frames = discs = contacts = 0
    for _ in range(max(a.repeat, 1)):
        t0, c0 = time.perf_counter(), time.process_time()
        frames = discs = contacts = 0
        for frame in run.frames(contacts=True):
            frame.bodies()
            frames += 1
            discs += len(frame)
            contacts += len(frame.contacts)
        best = min(best, time.perf_counter() - t0)
        best_cpu = min(best_cpu, time.process_time() - c0)
    if frames == 0:
        print(f"{a.run}: no frames with contacts", file=sys.stderr)
        return 1
    print(json.dumps({"frames": frames, "discs_per_frame": discs // frames, "contacts_per_frame": contacts // frames,
                      "seconds_per_frame": best / frames, "cpu_seconds_per_frame": best_cpu / frames,
                      "repeat": a.repeat}))
    return 0


if __name__ == "__main__":
    sys.exit(main())

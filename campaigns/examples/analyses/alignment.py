"""Fraction of the dumbbells above the outlet whose axis lies within `angle` degrees of the
vertical, averaged over the frames of the discharge (a campaign's Python analysis:
docs/python.md). Options: angle (degrees, default 30), half_width and height of the region
above the outlet (in d, default 4 and 8), start (the first time used, default 2)."""

import math

import numpy as np


def analyse(run, options):
    angle = math.radians(options.get("angle", 30))
    half_width = options.get("half_width", 4.0)
    height = options.get("height", 8.0)
    outlet = run.silo().outlets.iloc[0]  # base outlet 0, as the engine wrote it in silo.vtk
    cx, cy = (outlet.ax + outlet.bx) / 2, (outlet.ay + outlet.by) / 2
    fractions = []
    for frame in run.frames(window=(options.get("start", 2.0), None)):
        bodies = frame.bodies()
        dumbbells = bodies[bodies["n_discs"] == 2]
        above = dumbbells[(np.abs(dumbbells["x"] - cx) < half_width) & (dumbbells["y"] > cy)
                          & (dumbbells["y"] < cy + height)]
        if len(above) == 0:
            continue
        # theta is the axis' angle from +x; within `angle` of vertical: |sin theta| >= cos(angle).
        fractions.append(np.mean(np.abs(np.sin(above["theta"])) >= math.cos(angle)))
    if not fractions:
        raise ValueError("no dumbbell above the outlet in any frame after t = %g" % options.get("start", 2.0))
    f = np.array(fractions)
    # Frames are correlated, so this se is a lower bound; the report's point se is over replicas.
    se = f.std(ddof=1) / math.sqrt(len(f)) if len(f) > 1 else None
    return {"aligned_fraction": (f.mean(), se, "1"), "aligned_frames": (len(f), None, "frames")}

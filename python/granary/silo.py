"""silo.vtk read back into the silo's outline (docs/run-directory.md, "silo.vtk").

The engines write each wall and each outlet as a band of two triangles over four points
(a, b, b + t n, a + t n: the segment a-b and its copy moved t along the outward normal n),
walls grey, outlets red, in outlet order; each obstacle as 48 dark-grey triangles around its
centre. Reading the bands back gives the segments and normals exactly as written."""

import math

import numpy as np
import pandas as pd

from .errors import FormatError

WALL_COLOUR = (0.55, 0.55, 0.55)
OUTLET_COLOUR = (0.85, 0.15, 0.1)
OBSTACLE_COLOUR = (0.3, 0.3, 0.3)


class Silo:
    """`walls` and `outlets`: DataFrames of segments (ax, ay, bx, by, ox, oy: from a to b,
    (ox, oy) the unit normal out of the silo), outlets in outlet order (base outlets first in
    spec order, then side outlets: the `outlet` index of events); `obstacles`: a DataFrame of
    circles (x, y, r)."""

    def __init__(self, walls, outlets, obstacles):
        self.walls = walls
        self.outlets = outlets
        self.obstacles = obstacles

    def __repr__(self):
        return f"<Silo walls={len(self.walls)} outlets={len(self.outlets)} obstacles={len(self.obstacles)}>"


def read_silo(path):
    with open(path, "r", encoding="latin-1") as f:
        tokens = f.read().split("\n")
    lines = iter(enumerate(tokens, 1))
    points = cells = colours = None
    n = 0

    def fail(line, what):
        raise FormatError(f"{path}:{line}: {what}")

    for number, line in lines:
        f = line.split()
        if not f:
            continue
        if f[0] == "POINTS":
            n = int(f[1])
            rows = [next(lines, (number, "")) for _ in range(n)]
            try:
                points = np.array([[float(v) for v in r.split()[:2]] for _, r in rows])
            except ValueError:
                fail(number, "a POINTS row is not numbers")
        elif f[0] == "CELLS":
            n = int(f[1])
            rows = [next(lines, (number, "")) for _ in range(n)]
            try:
                cells = np.array([[int(v) for v in r.split()[1:4]] for _, r in rows], dtype=np.int64)
            except ValueError:
                fail(number, "a CELLS row is not integers")
        elif f[0] == "COLOR_SCALARS":
            rows = [next(lines, (number, "")) for _ in range(len(cells) if cells is not None else 0)]
            try:
                colours = [tuple(float(v) for v in r.split()) for _, r in rows]
            except ValueError:
                fail(number, "a COLOR_SCALARS row is not numbers")
    if points is None or cells is None or colours is None:
        raise FormatError(f"{path}: not a silo mesh (no POINTS, CELLS and COLOR_SCALARS)")
    if len(colours) != len(cells) or (len(cells) and cells.shape[1] != 3):
        raise FormatError(f"{path}: {len(cells)} cells and {len(colours)} colours")

    def near(c, ref):
        return len(c) == 3 and all(abs(a - b) < 1e-6 for a, b in zip(c, ref))

    walls, outlets, obstacles = [], [], {}
    k = 0
    while k < len(cells):
        c = colours[k]
        if near(c, WALL_COLOUR) or near(c, OUTLET_COLOUR):
            a, b, cc = cells[k]
            pa, pb, pc = points[a], points[b], points[cc]
            t = math.hypot(*(pc - pb))
            o = (pc - pb) / t if t > 0 else np.zeros(2)
            (walls if near(c, WALL_COLOUR) else outlets).append((pa[0], pa[1], pb[0], pb[1], o[0], o[1]))
            k += 2  # the band's second triangle
        elif near(c, OBSTACLE_COLOUR):
            centre, first = cells[k][0], cells[k][1]
            if centre not in obstacles:
                x, y = points[centre]
                obstacles[centre] = (x, y, math.hypot(*(points[first] - points[centre])))
            k += 1
        else:
            raise FormatError(f"{path}: cell {k} has the colour {c}, which is no wall, outlet or obstacle")
    columns = ["ax", "ay", "bx", "by", "ox", "oy"]
    return Silo(pd.DataFrame(walls, columns=columns), pd.DataFrame(outlets, columns=columns),
                pd.DataFrame(list(obstacles.values()), columns=["x", "y", "r"]))

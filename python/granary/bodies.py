"""Bodies rebuilt from their discs, as the C++ rundir::BodiesOf does (frames.h): centre of
mass, mass-weighted velocity, the first disc's angular velocity, the moment of inertia about
the centre of mass and the axis from the lowest-id to the highest-id disc."""

import numpy as np

BODY_DTYPE = np.dtype([("id", "<i8"), ("type", "<i4"), ("n_discs", "<i4"), ("mass", "<f8"),
                       ("x", "<f8"), ("y", "<f8"), ("vx", "<f8"), ("vy", "<f8"), ("omega", "<f8"),
                       ("inertia", "<f8"), ("theta", "<f8"), ("area", "<f8")])


def bodies_of(discs):
    """The bodies of a frame's discs (a DISC_DTYPE array), ordered by body id: `theta` is the
    angle of the axis from the lowest-id disc to the highest-id one in (-pi, pi], 0 for a body
    of one disc; `inertia` is sum m |r - R|^2 + (2/5) m r^2 over its discs."""
    discs = np.asarray(discs)
    n = len(discs)
    if n == 0:
        return np.zeros(0, BODY_DTYPE)
    mol, ident = discs["mol"], discs["id"]
    # Engines write the discs of a body together and bodies in order: usually nothing to sort.
    ordered = bool(np.all((mol[1:] > mol[:-1]) | ((mol[1:] == mol[:-1]) & (ident[1:] > ident[:-1]))))
    d = discs if ordered else discs[np.lexsort((ident, mol))]
    mol = d["mol"]
    first = np.concatenate(([0], np.flatnonzero(mol[1:] != mol[:-1]) + 1))
    last = np.append(first[1:], n) - 1
    counts = last - first + 1
    # The fields as contiguous columns (a structured array's fields are strided views, and
    # arithmetic on those is several times slower), the sums of a body in one reduceat.
    m, x, y, r = (np.ascontiguousarray(d[f]) for f in ("mass", "x", "y", "radius"))
    cols = np.empty((n, 5))
    cols[:, 0] = m
    np.multiply(m, x, out=cols[:, 1])
    np.multiply(m, y, out=cols[:, 2])
    np.multiply(m, d["vx"], out=cols[:, 3])
    np.multiply(m, d["vy"], out=cols[:, 4])
    sums = np.add.reduceat(cols, first, axis=0)
    out = np.zeros(len(first), BODY_DTYPE)
    out["id"] = mol[first]
    out["type"] = d["type"][first]
    out["n_discs"] = counts
    mass = sums[:, 0]
    out["mass"] = mass
    has = mass > 0
    safe = np.where(has, mass, 1.0)
    means = np.where(has[:, None], sums[:, 1:] / safe[:, None], 0.0)
    cx, cy = means[:, 0], means[:, 1]
    out["x"], out["y"] = cx, cy
    out["vx"], out["vy"] = means[:, 2], means[:, 3]
    out["omega"] = d["omega"][first]
    body = np.repeat(np.arange(len(first)), counts)
    dx, dy = x - cx[body], y - cy[body]
    out["inertia"] = np.add.reduceat(m * (dx * dx + dy * dy) + 0.4 * m * r * r, first)
    out["theta"] = np.where(counts >= 2, np.arctan2(y[last] - y[first], x[last] - x[first]), 0.0)
    out["area"] = np.add.reduceat(np.pi * r * r, first)
    return out

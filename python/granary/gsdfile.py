"""The run directory's GSD files (output.format "gsd"; docs/run-directory.md "Binary frames"):
frames.gsd (HOOMD's schema) and contacts.gsd (schema "granary-contacts"), read with NumPy
from GSD's documented file layer (gsd.readthedocs.io, "File layer", 2.0). The C++ reader
(src/rundir/gsd.cpp) is the reference: the same chunks, the same disc velocities rebuilt
from each body's centre-of-mass velocity and angular velocity. A frame's bodies are read from
those per-body chunks too (Frame.bodies(): no rebuilding from the discs, the C++ BodiesOf's
to rounding), and what depends on the per-disc constants alone is computed once per file.

Registered after the text dumps: a run directory that had both (none does) would be read
from its text dumps, as the C++ RunData does.
Debian's python3-gsd reads these files too (gsd.hoomd.open(path, "rb")); this module needs
only NumPy.
"""

import os
import warnings

import numpy as np

from .bodies import BODY_DTYPE
from .dump import CONTACT_DTYPE, DISC_DTYPE
from .errors import FormatError, MissingFileError, NewerFormatError, TruncatedError
from .formats import Entry, register

MAGIC = 0x65DF65DF65DF65DF
_HEADER = np.dtype([("magic", "<u8"), ("index_location", "<u8"), ("index_allocated_entries", "<u8"),
                    ("namelist_location", "<u8"), ("namelist_allocated_entries", "<u8"),
                    ("schema_version", "<u4"), ("gsd_version", "<u4"), ("application", "S64"),
                    ("schema", "S64"), ("reserved", "S80")])
_ENTRY = np.dtype([("frame", "<u8"), ("N", "<u8"), ("location", "<i8"), ("M", "<u4"), ("id", "<u2"),
                   ("type", "u1"), ("flags", "u1")])
_TYPES = {1: "<u1", 2: "<u2", 3: "<u4", 4: "<u8", 5: "<i1", 6: "<i2", 7: "<i4", 8: "<i8", 9: "<f4",
          10: "<f8", 11: "<u1"}
_NAME_SLOT = 64


class GsdFile:
    """A GSD file read through its index: `frames`, `schema`, chunk(frame, name) -> an N x M
    array or None. Frames whose data is not all in the file (a writer at work, or a cut file)
    are left out and `cut` is set."""

    def __init__(self, path):
        self.path = os.fspath(path)
        try:
            self._fd = os.open(self.path, os.O_RDONLY)
        except FileNotFoundError:
            raise MissingFileError(f"{self.path}: no such file") from None
        size = os.fstat(self._fd).st_size
        if size < _HEADER.itemsize:
            self._fail(f"{size} bytes, shorter than a GSD header (256)")
        h = np.frombuffer(self._read(_HEADER.itemsize, 0), _HEADER)[0]
        if int(h["magic"]) != MAGIC:
            self._fail("not a GSD file (no magic number)")
        major, minor = int(h["gsd_version"]) >> 16, int(h["gsd_version"]) & 0xFFFF
        if major not in (1, 2):
            os.close(self._fd)
            raise NewerFormatError(f"{self.path}: GSD file layer version {major}.{minor} is newer than this "
                                   f"reader reads (1.x, 2.x)")
        self.schema = h["schema"].split(b"\0", 1)[0].decode()
        name_bytes = int(h["namelist_allocated_entries"]) * _NAME_SLOT
        index_bytes = int(h["index_allocated_entries"]) * _ENTRY.itemsize
        if (int(h["namelist_location"]) + name_bytes > size or int(h["index_location"]) + index_bytes > size):
            self._fail(f"the header points past the end of the file ({size} bytes)")
        raw = self._read(name_bytes, int(h["namelist_location"]))
        if major == 1:
            slots = [raw[k:k + _NAME_SLOT] for k in range(0, len(raw), _NAME_SLOT)]
        else:
            slots = raw.split(b"\0")
        self.names = []
        for s in slots:
            name = s.split(b"\0", 1)[0]
            if not name:
                break
            self.names.append(name.decode())
        index = np.frombuffer(self._read(index_bytes, int(h["index_location"])), _ENTRY)
        unused = np.flatnonzero(index["location"] == 0)
        index = index[:unused[0]] if unused.size else index
        if index.size:
            bad_type = ~np.isin(index["type"], list(_TYPES))
            bad = np.flatnonzero(bad_type | (index["id"] >= len(self.names)) | (index["location"] < 0))
            if bad.size:
                k = int(bad[0])
                self._fail(f"index entry {k} is corrupt (type {int(index['type'][k])}, name id "
                           f"{int(index['id'][k])} of {len(self.names)})")
            if np.any(np.diff(index["frame"].astype(np.int64)) < 0):
                self._fail("the index goes back to an earlier frame")
            itemsize = np.array([np.dtype(_TYPES[int(t)]).itemsize for t in index["type"]], dtype=np.int64)
            ends = index["location"] + index["N"].astype(np.int64) * index["M"].astype(np.int64) * itemsize
            past = np.flatnonzero(ends > size)
            self.cut = bool(past.size)
            if past.size:
                index = index[index["frame"] < index["frame"][past[0]]]
        else:
            self.cut = False
        self.frames = int(index["frame"][-1]) + 1 if index.size else 0
        # frame -> {name: (N, M, location, type)}
        self._chunks = [dict() for _ in range(self.frames)]
        names = self.names
        for frame, n, location, m, ident, typ in zip(index["frame"].tolist(), index["N"].tolist(),
                                                     index["location"].tolist(), index["M"].tolist(),
                                                     index["id"].tolist(), index["type"].tolist()):
            self._chunks[frame][names[ident]] = (n, m, location, typ)

    def _fail(self, what):
        try:
            os.close(self._fd)
        except OSError:
            pass
        raise FormatError(f"{self.path}: {what}")

    def _read(self, n, at):
        data = os.pread(self._fd, n, at)
        if len(data) != n:
            raise FormatError(f"{self.path}: cannot read {n} bytes at {at}: the file ends")
        return data

    def close(self):
        os.close(self._fd)

    def has(self, frame, name):
        return frame < self.frames and name in self._chunks[frame]

    def chunk(self, frame, name):
        """The chunk as an N x M array, or None if the frame has none of that name."""
        if frame >= self.frames:
            return None
        found = self._chunks[frame].get(name)
        if found is None:
            return None
        n, m, location, typ = found
        dtype = np.dtype(_TYPES[typ])
        return np.frombuffer(self._read(n * m * dtype.itemsize, location), dtype).reshape(n, m)


class _Reader:
    """The frames (or contact frames) of one GSD file, as formats.Entry objects."""

    def __init__(self, path, kind, finished=True, density=1.0):
        self.path = os.fspath(path)
        self.kind = "frames" if kind in ("frames", "clog_frames") else "contacts"
        self.finished = finished
        self.file = GsdFile(path)
        want = "hoomd" if self.kind == "frames" else "granary-contacts"
        if self.file.schema != want:
            self.file.close()
            raise FormatError(f"{self.path}: a GSD file of schema '{self.file.schema}', not '{want}'")
        self._constants_from = None

    def close(self):
        self.file.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _header(self, f):
        g = self.file
        step = g.chunk(f, "configuration/step")
        if step is None and f > 0:
            step = g.chunk(0, "configuration/step")
        timestep = int(step[0, 0]) if step is not None else 0
        t = g.chunk(f, "log/granary/time")
        time = float(t[0, 0]) if t is not None else float(timestep)
        b = g.chunk(f, "log/granary/box")
        if b is not None:
            if b.size != 6:
                raise FormatError(f"{self.path}: log/granary/box of frame {f} has {b.size} values, not 6")
            box = b.astype(np.float64).reshape(3, 2).copy()
        else:
            hb = g.chunk(f, "configuration/box")
            if hb is None:
                hb = g.chunk(0, "configuration/box")
            lengths = hb.ravel()[:3].astype(np.float64) if hb is not None else np.ones(3)
            box = np.stack([-lengths / 2, lengths / 2], axis=1)
        return timestep, time, box

    def entries(self):
        g = self.file
        count_name = "particles/N" if self.kind == "frames" else "contacts/N"
        rows_name = "particles/position" if self.kind == "frames" else "contacts/force"
        for f in range(g.frames):
            count = g.chunk(f, count_name)
            if count is None or (int(count[0, 0]) > 0 and not g.has(f, rows_name)):
                self._cut_short(f"frame {f} lacks {count_name if count is None else rows_name}")
                return
            timestep, time, box = self._header(f)
            n = int(count[0, 0])
            if self.kind == "frames":
                # What load() read that the frame's bodies are made of (its per-body chunks).
                held = {}
                yield Entry(timestep, time, box, n, lambda f=f, n=n, box=box, held=held: self._discs(f, n, box, held),
                            lambda held=held: self._bodies(held))
            else:
                yield Entry(timestep, time, box, n, lambda f=f, n=n, box=box: self._contacts(f, n, box))
        if g.cut:
            self._cut_short("the file ends inside a frame")

    def _cut_short(self, what):
        message = f"{self.path}: {what}"
        if self.finished:
            raise TruncatedError(message + " (the run has its DONE, so the file is damaged or was cut)")
        warnings.warn(message + "; the run is not finished (no DONE): read up to there", stacklevel=4)

    def _need(self, f, name, rows, cols):
        a = self.file.chunk(f, name)
        if a is None or a.shape != (rows, cols):
            got = "missing" if a is None else f"{a.shape[0]} x {a.shape[1]}"
            raise FormatError(f"{self.path}: {name} of frame {f} is {got}, expected {rows} x {cols}")
        return a

    def _constants(self, f, n):
        """The per-disc chunks (frame 0's, or the frame's own when it has them) and what follows
        from them alone, computed once for the frames that share them: the discs' constant
        fields, each body's mass, area, type, disc count and first and last disc."""
        source = f if self.file.has(f, "particles/typeid") else 0
        if self._constants_from == (source, n):
            return self._consts
        c = {name: self._need(source, name, n, 1)[:, 0]
             for name in ("particles/typeid", "particles/mass", "particles/diameter", "particles/body",
                          "log/particles/id")}
        body = c["particles/body"].astype(np.int64)
        ident = c["log/particles/id"].astype(np.int64)
        # Per-body rows in increasing body id, as the writer orders them. Writers put a body's
        # discs together, bodies in id order and discs in id order: then no sort is needed.
        in_order = bool(np.all((body[1:] > body[:-1]) | ((body[1:] == body[:-1]) & (ident[1:] > ident[:-1]))))
        if in_order:
            starts = np.concatenate(([0], np.flatnonzero(body[1:] != body[:-1]) + 1))
            ids = body[starts]
            row = np.zeros(n, np.int64)
            row[starts[1:]] = 1
            np.cumsum(row, out=row)
        else:
            ids, row = np.unique(body, return_inverse=True)
            row = row.ravel()
        nb = len(ids)
        m = c["particles/mass"].astype(np.float64)
        r = 0.5 * c["particles/diameter"].astype(np.float64)
        template = np.zeros(n, DISC_DTYPE)
        template["id"] = ident
        template["mol"] = body
        template["type"] = c["particles/typeid"].astype(np.int64) + 1
        template["radius"] = r
        template["mass"] = m
        mass = np.bincount(row, m, nb)
        # A body's discs in the order BodiesOf takes them (body id, then disc id): its first
        # disc gives the type and the axis starts there, its last disc ends the axis.
        order = np.arange(n) if in_order else np.lexsort((ident, body))
        counts = np.bincount(row, minlength=nb)
        ends = np.cumsum(counts)
        first, last = order[ends - counts], order[ends - 1]
        bodies = np.zeros(nb, BODY_DTYPE)
        bodies["id"] = ids
        bodies["type"] = template["type"][first]
        bodies["n_discs"] = counts
        bodies["mass"] = mass
        bodies["area"] = np.bincount(row, np.pi * r * r, nb)
        self._consts = {"n": n, "row": row, "bodies": nb, "m": m, "mass": mass, "massive": mass > 0,
                        "all_massive": bool(np.all(mass > 0)), "safe": np.where(mass > 0, mass, 1.0),
                        "template": template, "body_template": bodies, "first": first, "last": last,
                        "two": counts >= 2, "spin_inertia": 0.4 * m * r * r}
        self._constants_from = (source, n)
        return self._consts

    def _discs(self, f, n, box, held):
        if n == 0:
            held["n"] = 0
            return np.zeros(n, DISC_DTYPE)
        c = self._constants(f, n)
        pos = self._need(f, "particles/position", n, 3)
        nb = c["bodies"]
        vel = self._need(f, "log/bodies/velocity", nb, 2)
        vx, vy = vel[:, 0].astype(np.float64), vel[:, 1].astype(np.float64)
        omega = self._need(f, "log/bodies/omega", nb, 1)[:, 0].astype(np.float64)
        cx, cy = 0.5 * (box[0, 0] + box[0, 1]), 0.5 * (box[1, 0] + box[1, 1])
        # Widened first, as the C++ reader casts then adds (float32 + a Python float stays float32).
        x = np.add(pos[:, 0], cx, dtype=np.float64)
        y = np.add(pos[:, 1], cy, dtype=np.float64)
        m, row = c["m"], c["row"]
        # Disc velocities of a rigid body: V + omega x (r - R), R its centre of mass.
        X = np.bincount(row, m * x, nb) / c["safe"]
        Y = np.bincount(row, m * y, nb) / c["safe"]
        rx = x - X[row]
        ry = y - Y[row]
        if not c["all_massive"]:
            X[~c["massive"]] = 0.0
            Y[~c["massive"]] = 0.0
            rx[~c["massive"][row]] = 0.0
            ry[~c["massive"][row]] = 0.0
        w = omega[row]
        out = _copy(c["template"])
        out["x"] = x
        out["y"] = y
        out["vx"] = vx[row] - w * ry
        out["vy"] = vy[row] + w * rx
        out["omega"] = w
        # Not the offsets rx, ry: a frame kept in memory holds only what bodies() cannot redo.
        held.update(n=n, consts=c, x=x, y=y, X=X, Y=Y, vx=vx, vy=vy, omega=omega)
        return out

    def _bodies(self, held):
        """The bodies of a loaded frame from the file's per-body chunks (velocity, angular
        velocity) and its discs' positions: the fields of bodies.bodies_of (the C++ BodiesOf),
        whose velocity the C++ reader's disc velocities give back to rounding."""
        if "n" not in held:
            raise RuntimeError("Frame.bodies() of a GSD frame before its discs were read")
        if held["n"] == 0:
            return np.zeros(0, BODY_DTYPE)
        c = held["consts"]
        out = _copy(c["body_template"])
        x, y, first, last, row = held["x"], held["y"], c["first"], c["last"], c["row"]
        # The offsets from the centre of mass, as _discs computed them (BodiesOf's dx, dy).
        rx = x - held["X"][row]
        ry = y - held["Y"][row]
        if not c["all_massive"]:
            rx[~c["massive"][row]] = 0.0
            ry[~c["massive"][row]] = 0.0
        out["x"] = held["X"]
        out["y"] = held["Y"]
        out["vx"] = held["vx"]
        out["vy"] = held["vy"]
        out["omega"] = held["omega"]
        out["inertia"] = np.bincount(row, c["m"] * (rx * rx + ry * ry) + c["spin_inertia"], c["bodies"])
        two = c["two"]
        out["theta"] = np.where(two, np.arctan2(y[last] - y[first], x[last] - x[first]), 0.0)
        return out

    def _contacts(self, f, n, box):
        out = np.empty(n, CONTACT_DTYPE)  # every field is written below
        if n == 0:
            return out
        body = self._need(f, "contacts/body", n, 2)
        centres = self._need(f, "contacts/centres", n, 4)
        point = self._need(f, "contacts/point", n, 2)
        force = self._need(f, "contacts/force", n, 2)
        cx, cy = 0.5 * (box[0, 0] + box[0, 1]), 0.5 * (box[1, 0] + box[1, 1])
        # Every field of CONTACT_DTYPE is 8 bytes: the rows as an n x 10 table (body_i body_j |
        # xi yi xj yj | cx cy | fx fy), the float columns widened in one concatenate and the
        # box centre added a column at a time (a ufunc over a few strided columns at once,
        # or with a cast, runs several times slower).
        as_float = out.view(np.float64).reshape(n, 10)
        out.view(np.int64).reshape(n, 10)[:, 0:2] = body
        np.concatenate((centres, point, force), axis=1, out=as_float[:, 2:10])
        for k, centre in enumerate((cx, cy, cx, cy, cx, cy)):
            column = as_float[:, 2 + k]
            np.add(column, centre, out=column)
        return out


def _copy(rows):
    """A copy of a structured array as one memcpy (ndarray.copy() copies a packed structured
    dtype field by field, several times slower)."""
    return rows.view(np.uint8).copy().view(rows.dtype)


def open_gsd(path, kind, finished=True, density=1.0):
    """The opener of frames.gsd and contacts.gsd for formats.register."""
    return _Reader(path, kind, finished, density)


register("frames", "frames.gsd", open_gsd)
register("contacts", "contacts.gsd", open_gsd)

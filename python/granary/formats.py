"""Where a run's frames and contact frames come from: the frame formats python/granary reads,
one module each, registered here by the files they read.

A format module registers an opener for each kind of file it reads ("frames", "contacts",
"clog_frames", "clog_contacts") and the file names it reads it from; `Run.frames()`,
`contacts()` and `clogs()` take the first registered name that the run directory has. The
opener is called as `opener(path, kind, finished=..., density=...)` and returns a reader:
a context manager whose `entries()` yields one `Entry` per frame in file order, with the frame's
header and a `load()` that parses its rows (DISC_DTYPE for frames, CONTACT_DTYPE for contacts;
None when the file ends inside it and the run is still being written). An entry whose load()
is not called is skipped unparsed. A format whose file holds the bodies themselves gives the
entry `bodies`, called (after load()) by `Frame.bodies()` instead of rebuilding them from the
discs (bodies.py). The text dumps (dump.py) register at import; a binary format
adds a module that calls `register` and is imported by granary/__init__.py.
"""

import collections
import math

import numpy as np

# One frame of a reader: timestep, time, box ([[xlo, xhi], [ylo, yhi], [zlo, zhi]]), count (rows),
# load() -> the rows (a structured array) or None, and bodies: None, or () -> the frame's bodies
# (BODY_DTYPE) read from the file.
Entry = collections.namedtuple("Entry", "timestep time box count load bodies", defaults=(None,))

KINDS = ("frames", "contacts", "clog_frames", "clog_contacts")
_FORMATS = {kind: [] for kind in KINDS}


def register(kind, name, opener, first=False):
    """Reads files called `name` of a run directory as `kind` with `opener`. first=True puts
    it before the formats registered so far (a run directory that has both is read from it)."""
    if kind not in _FORMATS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}, not {kind!r}")
    entries = _FORMATS[kind]
    entries[:] = [e for e in entries if e[0] != name]
    entries.insert(0 if first else len(entries), (name, opener))


def names(kind):
    """The file names `kind` is read from, in the order they are tried."""
    return [name for name, _ in _FORMATS[kind]]


def known_names():
    return {name for entries in _FORMATS.values() for name, _ in entries}


def opener_of(kind, name):
    for n, opener in _FORMATS[kind]:
        if n == name:
            return opener
    raise KeyError(f"no {kind} format reads '{name}'")


def select(entries, make, stride=1, window=None):
    """The frames of `entries` whose time is in `window` ((t0, t1), both ends included; None for
    either end: open), every `stride`-th of those, made by make(timestep, time, box, rows); stops
    once past the window. Frames left out are not parsed."""
    t0, t1 = window_of(window)
    stride = stride_of(stride)
    kept = 0
    for entry in entries:
        if entry.time > t1:
            return
        if entry.time < t0:
            continue
        kept += 1
        if (kept - 1) % stride:
            continue
        rows = entry.load()
        if rows is None:
            return
        made = make(entry.timestep, entry.time, entry.box, rows)
        if entry.bodies is not None:
            made.read_bodies = entry.bodies
        yield made


def window_of(window):
    if window is None:
        return -math.inf, math.inf
    try:
        t0, t1 = window
    except (TypeError, ValueError):
        raise ValueError(f"window must be (t0, t1) with None for an open end, not {window!r}") from None
    t0 = -math.inf if t0 is None else float(t0)
    t1 = math.inf if t1 is None else float(t1)
    if t1 < t0:
        raise ValueError(f"window ({t0:g}, {t1:g}) ends before it starts")
    return t0, t1


def stride_of(stride):
    if not isinstance(stride, (int, np.integer)) or isinstance(stride, bool) or stride < 1:
        raise ValueError(f"stride must be a whole number >= 1, not {stride!r}")
    return int(stride)

"""One run directory (docs/run-directory.md), read through its documented files."""

import json
import os

import numpy as np
import pandas as pd

from . import formats
from .dump import ContactFrame, Frame
from .errors import FormatError, MissingFileError, NewerFormatError, TruncatedError

# The file names of a run directory (src/rundir/layout.h).
RUN_SPEC = "run.json"
SUMMARY = "summary.json"
DONE = "DONE"
EVENTS = "events.csv"
FRAMES = "frames.dump"
CONTACTS = "contacts.dump"
FRAMES_GZ = "frames.dump.gz"
CONTACTS_GZ = "contacts.dump.gz"
CLOG_FRAMES = "clog_frames.dump"
CLOG_CONTACTS = "clog_contacts.dump"
SILO = "silo.vtk"
ANALYSES = "analyses"

_KNOWN = {RUN_SPEC, SUMMARY, DONE, EVENTS, SILO}


class Clog:
    """One clog: the configuration (`frame`, a Frame) and its contact forces (`contacts`, a
    ContactFrame) at the step the engine judged it."""

    __slots__ = ("frame", "contacts")

    def __init__(self, frame, contacts):
        self.frame = frame
        self.contacts = contacts

    @property
    def time(self):
        return self.frame.time

    @property
    def timestep(self):
        return self.frame.timestep

    def __repr__(self):
        return f"<Clog t={self.time:g} discs={len(self.frame)} contacts={len(self.contacts)}>"


class Run:
    """A run directory. `spec` (run.json, or the summary's copy), `summary` (summary.json),
    `events()`, `frames()`, `contacts()`, `clogs()`, `silo()`. Nothing is read before it is
    asked for; every error names the file."""

    def __init__(self, path, run_id=None, row=None):
        self.path = os.fspath(path)
        if not os.path.isdir(self.path):
            raise MissingFileError(f"{self.path}: no such run directory")
        self.id = run_id or os.path.basename(os.path.normpath(self.path))
        self.row = row  # the run's row of campaign.runs (a pandas Series) when opened from a campaign
        self._spec = None
        self._summary = None

    def __repr__(self):
        return f"<Run {self.id} at {self.path}>"

    def file(self, name):
        return os.path.join(self.path, name)

    def has(self, name):
        return os.path.exists(self.file(name))

    @property
    def done(self):
        """DONE exists: the engine finished, every other file is complete."""
        return self.has(DONE)

    def _json(self, name):
        path = self.file(name)
        try:
            with open(path, "rb") as f:
                text = f.read()
        except FileNotFoundError:
            raise MissingFileError(f"{path}: no such file" + ("" if self.done else " (the run is not finished: no DONE)")) from None
        try:
            return json.loads(text)
        except ValueError as e:
            if self.done:
                raise FormatError(f"{path}: not JSON ({e})") from None
            raise TruncatedError(f"{path}: not JSON ({e}); the run is not finished (no DONE)") from None

    @property
    def summary(self):
        """summary.json as a dict (engines may add keys; see docs/run-directory.md)."""
        if self._summary is None:
            self._summary = self._json(SUMMARY)
        return self._summary

    @property
    def spec(self):
        """The resolved run spec: run.json, or the summary's copy when run.json is gone."""
        if self._spec is None:
            if self.has(RUN_SPEC) or not self.has(SUMMARY):
                self._spec = self._json(RUN_SPEC)
            else:
                self._spec = self.summary.get("spec", {})
        return self._spec

    def events(self):
        """events.csv as a DataFrame (time, body, shape, mass, outlet), sorted by time (a stable
        sort); columns found by name, `time` required; a missing mass is NaN, a missing outlet 0."""
        path = self.file(EVENTS)
        if not os.path.exists(path):
            raise MissingFileError(f"{path}: no such file")
        if os.path.getsize(path) == 0:
            return pd.DataFrame({"time": pd.Series(dtype="f8"), "body": pd.Series(dtype="i8"),
                                 "shape": pd.Series(dtype="object"), "mass": pd.Series(dtype="f8"),
                                 "outlet": pd.Series(dtype="i8")})
        try:
            df = pd.read_csv(path, dtype={"shape": str}, skipinitialspace=True, float_precision="round_trip")
        except (ValueError, pd.errors.ParserError) as e:
            raise FormatError(f"{path}: {e}") from None
        df.columns = [c.strip() for c in df.columns]
        if "time" not in df.columns:
            raise FormatError(f"{path}:1: the header has no 'time' column ({', '.join(df.columns)})")
        for name, kind in (("time", "f8"), ("mass", "f8"), ("body", "i8"), ("outlet", "i8")):
            if name not in df.columns:
                continue
            converted = pd.to_numeric(df[name], errors="coerce")
            bad = converted.isna() & df[name].notna() if kind == "f8" else converted.isna() | (converted != converted.round())
            if bad.any():
                row = int(np.flatnonzero(bad.to_numpy())[0])
                if row == len(df) - 1 and not self.done:
                    df = df.iloc[:row]
                    break
                raise FormatError(f"{path}:{row + 2}: {name} '{df[name].iloc[row]}' is not "
                                  f"{'a number' if kind == 'f8' else 'an integer'}")
            df[name] = converted.astype(kind)
        if "body" not in df.columns:
            df["body"] = -1
        if "shape" not in df.columns:
            df["shape"] = ""
        if "mass" not in df.columns:
            df["mass"] = np.nan
        if "outlet" not in df.columns:
            df["outlet"] = 0
        df["shape"] = df["shape"].fillna("")
        df = df[["time", "body", "shape", "mass", "outlet"]]
        return df.sort_values("time", kind="stable").reset_index(drop=True)

    def _source(self, kind):
        """(path, opener) of the first file of `kind` this run directory has, in the order the
        formats registered them (formats.py); None when it has none."""
        for name in formats.names(kind):
            if os.path.exists(self.file(name)):
                return self.file(name), formats.opener_of(kind, name)
        self._check_newer_format(formats.names(kind)[0])
        return None

    def _check_newer_format(self, plain):
        stem = plain.split(".")[0]
        known = _KNOWN | formats.known_names()
        others = sorted(n for n in os.listdir(self.path) if n.startswith(stem + ".") and n not in known)
        if others:
            raise NewerFormatError(
                f"{self.path}: has {', '.join(others)} but no {plain}: its {stem} are in a format newer "
                "than this reader knows (docs/run-directory.md); use the python/granary of the Granary that "
                "wrote the run")

    def _open(self, kind, source, density=False):
        path, opener = source
        return opener(path, kind, finished=self.done, density=self._density() if density else 1.0)

    def _density(self):
        try:
            return float(self.spec.get("bodies", {}).get("density", 1.0))
        except (MissingFileError, AttributeError, TypeError, ValueError):
            return 1.0

    def _contact_interval(self):
        try:
            return int(self.spec.get("output", {}).get("contact_interval", 1))
        except (MissingFileError, AttributeError, TypeError, ValueError):
            return 1

    def _missing(self, kind, why):
        names = formats.names(kind)
        return MissingFileError(f"{self.file(names[0])}: no such file (nor {', '.join(names[1:])}); {why}")

    def frames(self, stride=1, window=None, contacts=False):
        """Iterates the frames of frames.dump (or frames.dump.gz, or another format a module
        registered: formats.py) one at a time, never holding the file: each a Frame with `time`,
        `timestep`, `box`, `discs` (a structured array: id mol type x y radius mass vx vy omega;
        `frame["x"]` works too) and `bodies()`. window=(t0, t1): only frames with
        t0 <= time <= t1 (None: open end); stride=k: every k-th of those. contacts=True: each
        frame also gets `contacts`, the contact frame of the same timestep from contacts.dump
        (an error if it has none; None for the frames between contact frames of a run with
        output/contact_interval > 1)."""
        source = self._source("frames")
        if source is None:
            raise self._missing("frames", "the spec's output/frame_interval decides whether a run writes frames")
        formats.window_of(window), formats.stride_of(stride)
        return self._frames(source, stride, window, contacts)

    def _frames(self, source, stride, window, contacts):
        with self._open("frames", source, density=True) as reader:
            if not contacts:
                yield from formats.select(reader.entries(), Frame, stride, window)
                return
            csource = self._source("contacts")
            if csource is None:
                raise self._missing("contacts", "a run writes contact frames when its spec sets output/contact_forces")
            # output/contact_interval k > 1: contact frames with every k-th frame only; the
            # frames between get contacts None.
            sparse = self._contact_interval() > 1
            with self._open("contacts", csource) as creader:
                centries = creader.entries()
                entry = None
                for frame in formats.select(reader.entries(), Frame, stride, window):
                    while entry is None or entry.timestep < frame.timestep:
                        entry = next(centries, None)
                        if entry is None:
                            break
                    if entry is None or entry.timestep > frame.timestep:
                        if sparse:
                            yield frame
                            continue
                        raise FormatError(f"{csource[0]}: no contact frame at timestep {frame.timestep} "
                                          f"(t = {frame.time:g}) of {source[0]}")
                    rows = entry.load()
                    entry = None
                    if rows is None:
                        return
                    frame.contacts = rows
                    yield frame

    def contacts(self, stride=1, window=None):
        """Iterates the contact frames of contacts.dump (or .gz, or a registered format) like
        frames(): each a ContactFrame with `time`, `timestep`, `box` and `contacts` (body_i
        body_j xi yi xj yj cx cy fx fy; body_j = -1 for a wall or obstacle; the force is on
        body i)."""
        source = self._source("contacts")
        if source is None:
            raise self._missing("contacts", "a run writes contact frames when its spec sets output/contact_forces")
        formats.window_of(window), formats.stride_of(stride)
        return self._contacts(source, stride, window)

    def _contacts(self, source, stride, window):
        with self._open("contacts", source) as reader:
            yield from formats.select(reader.entries(), ContactFrame, stride, window)

    def clogs(self):
        """Every clog the engine kept (clog_frames.dump with clog_contacts.dump), in the order
        they happened: a list of Clog (`frame`, `contacts`, `time`). Empty for a run that never
        clogged; MissingFileError for a run written before engines kept clogs."""
        fsource, csource = self._source("clog_frames"), self._source("clog_contacts")
        fpath, cpath = self.file(CLOG_FRAMES), self.file(CLOG_CONTACTS)
        if fsource is None and csource is None:
            raise MissingFileError(f"{self.path}: has no {CLOG_FRAMES} and {CLOG_CONTACTS}: the run was written "
                                   "before engines kept their clogs")
        if (fsource is None) != (csource is None):
            raise FormatError(f"{cpath if fsource else fpath}: missing beside its pair")
        fpath, cpath = fsource[0], csource[0]
        out = []
        with self._open("clog_frames", fsource, density=True) as frames, self._open("clog_contacts", csource) as contacts:
            f_iter = formats.select(frames.entries(), Frame)
            c_iter = formats.select(contacts.entries(), ContactFrame)
            while True:
                frame = next(f_iter, None)
                contact = next(c_iter, None)
                if frame is None and contact is None:
                    return out
                if contact is None:
                    raise FormatError(f"{cpath}: no block for the clog at timestep {frame.timestep}")
                if frame is None:
                    raise FormatError(f"{fpath}: no configuration for the contacts at timestep {contact.timestep}")
                if frame.timestep != contact.timestep:
                    raise FormatError(f"{cpath}: a block at timestep {contact.timestep} beside the configuration "
                                      f"at timestep {frame.timestep}")
                out.append(Clog(frame, contact))

    def silo(self):
        """The silo's walls, outlets (in outlet order: base outlets, then side outlets) and
        obstacles, read back from silo.vtk (a Silo)."""
        from .silo import read_silo
        path = self.file(SILO)
        if not os.path.exists(path):
            raise MissingFileError(f"{path}: no such file (engines write it since the silo outline was kept "
                                   "with the run; older run directories have none)")
        return read_silo(path)

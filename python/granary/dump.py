"""Streaming readers of the run directory's LAMMPS text dumps (docs/run-directory.md):
frames.dump, contacts.dump, their .gz forms and the clog files, block by block.

Each block's rows are cut out of the file as one bytes object and parsed by NumPy's C
parser (np.loadtxt, correctly rounded like the C++ readers' std::from_chars), so a frame
costs one pass of C code over its text; a block nobody asked for is skipped unparsed. The
C++ readers (src/rundir/frames.cpp, contacts.cpp, dump_text.cpp) are the reference: the same
items, the same column names, the same defaults for optional columns.
"""

import gzip
import io
import math
import os
import warnings

import numpy as np

from .errors import FormatError, MissingFileError, TruncatedError
from .formats import Entry, register, select
from .formats import stride_of as _stride, window_of as _window  # noqa: F401 (the names run.py used)

# A disc of frames.dump, the fields of the C++ rundir::Disc.
DISC_DTYPE = np.dtype([("id", "<i8"), ("mol", "<i8"), ("type", "<i4"), ("x", "<f8"), ("y", "<f8"),
                       ("radius", "<f8"), ("mass", "<f8"), ("vx", "<f8"), ("vy", "<f8"),
                       ("omega", "<f8")])
# A row of contacts.dump, the fields of the C++ rundir::ContactRow (body_j = -1: a wall).
CONTACT_DTYPE = np.dtype([("body_i", "<i8"), ("body_j", "<i8"), ("xi", "<f8"), ("yi", "<f8"),
                          ("xj", "<f8"), ("yj", "<f8"), ("cx", "<f8"), ("cy", "<f8"),
                          ("fx", "<f8"), ("fy", "<f8")])

# field of the structured array <- column name in the dump
_DISC_COLUMNS = {"id": "id", "mol": "mol", "type": "type", "x": "x", "y": "y", "radius": "radius",
                 "mass": "mass", "vx": "vx", "vy": "vy", "omega": "omegaz"}
_DISC_REQUIRED = ("id", "mol", "x", "y")
_CONTACT_COLUMNS = {name: name for name in CONTACT_DTYPE.names}

_CHUNK = 1 << 20
_GZIP_MAGIC = b"\x1f\x8b"


class _Lines:
    """The lines of a plain or gzip file (told apart by gzip's magic bytes), with whole
    blocks of rows cut out at once."""

    def __init__(self, path):
        self.path = os.fspath(path)
        try:
            raw = open(self.path, "rb")
        except FileNotFoundError:
            raise MissingFileError(f"{self.path}: no such file") from None
        self.compressed = raw.read(2) == _GZIP_MAGIC
        raw.seek(0)
        self._file = gzip.GzipFile(fileobj=raw, mode="rb") if self.compressed else raw
        self._raw = raw
        self._buf = b""
        self._pos = 0
        self._eof = False
        self.cut = False  # the gzip stream ended inside a member
        self.line = 0     # number of the last line handed out (1-based)

    def close(self):
        self._file.close()
        self._raw.close()

    def _fill(self, size):
        """Reads at least `size` more bytes unless the file ends; False at the end."""
        if self._eof:
            return False
        rest = self._buf[self._pos:]
        parts = [rest]
        got = 0
        while got < size:
            try:
                chunk = self._file.read(max(size - got, _CHUNK))
            except EOFError:  # a gzip member cut short: an engine still writing, or a cut file
                self.cut = True
                chunk = b""
            if not chunk:
                self._eof = True
                break
            parts.append(chunk)
            got += len(chunk)
        self._buf = b"".join(parts)
        self._pos = 0
        return got > 0

    def next_line(self):
        """The next line without its end, or None at the end of the file."""
        while True:
            end = self._buf.find(b"\n", self._pos)
            if end >= 0:
                line = self._buf[self._pos:end]
                self._pos = end + 1
                self.line += 1
                return line.rstrip(b"\r")
            if not self._fill(_CHUNK):
                if self._pos < len(self._buf):
                    line = self._buf[self._pos:]
                    self._pos = len(self._buf)
                    self.line += 1
                    return line
                return None

    def rows(self, n, keep=True):
        """The next n lines as one bytes object (None if not kept), and whether all n were
        there: (block, complete). A last line without its newline counts as a line.

        The rows end where the next block's "ITEM: " line starts (a row never holds "ITEM"),
        found with one bytes.find; the parser then checks that they are n. Only the last block
        of a file, which has no next one, has its lines counted."""
        if n == 0:
            return (b"" if keep else None), True
        scanned = 0  # bytes after _pos already searched without a hit
        while True:
            buf, pos = self._buf, self._pos
            hit = buf.find(b"\nITEM: ", pos + max(scanned - 8, 0))
            if hit >= 0:
                end = hit + 1
                block = buf[pos:end] if keep else None
                self._pos = end
                self.line += n
                return block, True
            scanned = len(buf) - pos
            if not self._fill(max(_CHUNK, scanned)):
                # The last block of the file: its lines are counted.
                block = buf[pos:]
                have = block.count(b"\n")
                complete = have >= n or (have == n - 1 and not block.endswith(b"\n") and not self.cut)
                self._pos = len(self._buf)
                self.line += min(have + (0 if block.endswith(b"\n") else 1), n) if block else 0
                return (block if keep else None), complete


class Block:
    """One block of a dump: its TIMESTEP, TIME, box and rows (a NumPy structured array).
    `frame["x"]`, `len(frame)` and `np.asarray(frame)` act on the rows."""

    __slots__ = ("timestep", "time", "box", "rows", "contacts")

    def __init__(self, timestep, time, box, rows):
        self.timestep = timestep
        self.time = time
        self.box = box
        self.rows = rows
        self.contacts = None

    def __len__(self):
        return len(self.rows)

    def __getitem__(self, key):
        return self.rows[key]

    def __array__(self, dtype=None):
        return self.rows if dtype is None else self.rows.astype(dtype)

    def __repr__(self):
        return f"<{type(self).__name__} t={self.time:g} timestep={self.timestep} rows={len(self.rows)}>"


class Frame(Block):
    """A frame of frames.dump: `discs` (DISC_DTYPE), `bodies()` rebuilt from them (or read from
    a file that holds them: `read_bodies`, set by formats.select) and, when asked for,
    `contacts` (the ContactFrame of the same time)."""

    __slots__ = ("read_bodies",)

    def __init__(self, timestep, time, box, rows):
        super().__init__(timestep, time, box, rows)
        self.read_bodies = None

    @property
    def discs(self):
        return self.rows

    def bodies(self):
        if self.read_bodies is not None:
            return self.read_bodies()
        from .bodies import bodies_of
        return bodies_of(self.rows)


class ContactFrame(Block):
    """A frame of contacts.dump: its rows (CONTACT_DTYPE), also as `contacts`."""

    __slots__ = ()

    def __init__(self, timestep, time, box, rows):
        super().__init__(timestep, time, box, rows)
        self.contacts = rows


class DumpReader:
    """Streams the blocks of one dump. kind: "frames" (ITEM: NUMBER OF ATOMS / ITEM: ATOMS)
    or "contacts" (ITEM: NUMBER OF ENTRIES / ITEM: ENTRIES). `finished`: the run has its DONE,
    so a block cut short is an error (TruncatedError) instead of the end of a file an engine is
    still writing (a warning). `density` gives the mass of discs without a mass column."""

    def __init__(self, path, kind, finished=True, density=1.0):
        if kind not in ("frames", "contacts"):
            raise ValueError(f"kind must be 'frames' or 'contacts', not {kind!r}")
        self.path = os.fspath(path)
        self.kind = kind
        self.finished = finished
        self.density = density
        self._count_item = b"ITEM: NUMBER OF ATOMS" if kind == "frames" else b"ITEM: NUMBER OF ENTRIES"
        self._columns_item = b"ITEM: ATOMS" if kind == "frames" else b"ITEM: ENTRIES"
        self._lines = _Lines(path)
        self._header = None

    @property
    def compressed(self):
        return self._lines.compressed

    def close(self):
        self._lines.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _fail(self, what, line=None):
        raise FormatError(f"{self.path}:{self._lines.line if line is None else line}: {what}")

    def _cut_short(self, what):
        message = f"{self.path}: {what}"
        if self.finished:
            raise TruncatedError(message + " (the run has its DONE, so the file is damaged or was cut)")
        warnings.warn(message + "; the run is not finished (no DONE): read up to there", stacklevel=4)

    def next_header(self):
        """Reads the next block's header: (timestep, time, box, count, columns), or None at
        the end of the file. The rows follow: read_rows() or skip_rows()."""
        if self._header is not None:
            self.skip_rows()
        lines = self._lines
        line = lines.next_line()
        while line is not None and not line.strip():
            line = lines.next_line()
        if line is None:
            if lines.cut:
                self._cut_short("the compressed stream ends inside a gzip member")
            return None
        start = lines.line
        time = 0.0
        timestep = None
        count = None
        box = np.array([[0.0, 0.0], [0.0, 0.0], [-0.5, 0.5]])

        def value():
            v = lines.next_line()
            if v is None:
                self._cut_short(f"the block starting at line {start} ends inside its header")
            return v

        while line in (b"ITEM: UNITS", b"ITEM: TIME"):
            item = line
            v = value()
            if v is None:
                return None
            if item == b"ITEM: TIME":
                time = self._number(v, "time")
            line = value()
            if line is None:
                return None
        if not line.startswith(b"ITEM: TIMESTEP"):
            self._fail(f"expected 'ITEM: TIMESTEP', got '{line.decode(errors='replace')}'")
        v = value()
        if v is None:
            return None
        timestep = self._integer(v, "timestep")
        while True:
            line = value()
            if line is None:
                return None
            if not line.startswith(b"ITEM: "):
                self._fail(f"expected an 'ITEM:' line, got '{line.decode(errors='replace')}'")
            if line.startswith(self._columns_item):
                break
            if line.startswith(b"ITEM: TIMESTEP"):
                self._fail("'ITEM: TIMESTEP' before the rows of the previous block")
            if line.startswith(b"ITEM: BOX BOUNDS"):
                for k in range(3):
                    v = value()
                    if v is None:
                        return None
                    f = v.split()
                    try:
                        box[k] = (float(f[0]), float(f[1]))
                    except (IndexError, ValueError):
                        self._fail(f"box bounds line '{v.decode(errors='replace')}' is not two numbers")
                continue
            v = value()
            if v is None:
                return None
            if line == self._count_item:
                count = self._integer(v, self._count_item[6:].decode().lower())
                if count < 0:
                    self._fail(f"{self._count_item[6:].decode().lower()} '{v.decode()}' is not a count")
            elif line == b"ITEM: TIME":
                time = self._number(v, "time")
        if count is None:
            self._fail(f"frame has no '{self._count_item.decode()}'")
        columns = [c.decode() for c in line[len(self._columns_item):].split()]
        self._header = (timestep, time, box, count, columns, start)
        return self._header[:5]

    def _number(self, text, what):
        try:
            return float(text)
        except ValueError:
            self._fail(f"{what} '{text.decode(errors='replace')}' is not a number")

    def _integer(self, text, what):
        try:
            return int(text)
        except ValueError:
            self._fail(f"{what} '{text.decode(errors='replace')}' is not an integer")

    def skip_rows(self):
        """Skips the rows of the block whose header was read; False if the file ends first."""
        if self._header is None:
            return True
        count, start = self._header[3], self._header[5]
        self._header = None
        _, complete = self._lines.rows(count, keep=False)
        if not complete:
            self._cut_short(f"the block starting at line {start} ends before its {count} rows")
        return complete

    def read_rows(self):
        """The rows of the block whose header was read, as a structured array; None if the
        file ends first (a block cut short)."""
        if self._header is None:
            raise RuntimeError("read_rows() without a header (call next_header() first)")
        timestep, time, box, count, columns, start = self._header
        self._header = None
        first_line = self._lines.line + 1
        block, complete = self._lines.rows(count)
        if not complete:
            self._cut_short(f"the block starting at line {start} ends before its {count} rows")
            return None
        if self.kind == "frames":
            return self._parse(block, count, columns, first_line, DISC_DTYPE, _DISC_COLUMNS, _DISC_REQUIRED)
        return self._parse(block, count, columns, first_line, CONTACT_DTYPE, _CONTACT_COLUMNS,
                           CONTACT_DTYPE.names)

    def _parse(self, block, count, columns, first_line, dtype, wanted, required):
        index = {name: k for k, name in enumerate(columns)}
        for name in required:
            if wanted[name] not in index:
                header = " ".join([self._columns_item.decode()] + columns)
                what = "atoms header" if self.kind == "frames" else "entries header"
                self._fail(f"{what} has no '{wanted[name]}' column ('{header}')", first_line - 1)
        present = [field for field in dtype.names if wanted[field] in index]
        usecols = [index[wanted[field]] for field in present]
        out = np.zeros(count, dtype)
        if count == 0:
            return self._defaults(out, present)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")  # an empty input warns in loadtxt
                values = np.loadtxt(io.BytesIO(block), dtype=np.float64, usecols=usecols, ndmin=2,
                                    comments=None, encoding="latin-1")
        except (ValueError, UserWarning):
            values = None
        if values is None or values.shape != (count, len(usecols)):
            values = self._parse_slowly(block, count, columns, first_line, present, usecols, wanted)
            if values is None:
                return None
        for k, field in enumerate(present):
            column = values[:, k]
            if dtype[field].kind == "i":
                as_int = column.astype(dtype[field])
                bad = np.flatnonzero(as_int != column)
                if bad.size:
                    row = int(bad[0])
                    self._fail(f"{wanted[field]} '{column[row]!r}' is not an integer", first_line + row)
                out[field] = as_int
            else:
                out[field] = column
        return self._defaults(out, present)

    def _defaults(self, out, present):
        if self.kind == "frames":
            if "type" not in present:
                out["type"] = 1
            if "radius" not in present:
                out["radius"] = 0.5
            if "mass" not in present:
                out["mass"] = self.density * math.pi * out["radius"] * out["radius"]
        return out

    def _parse_slowly(self, block, count, columns, first_line, present, usecols, wanted):
        """Row by row, to name the line that NumPy refused (or to take rows with more fields
        than the header names, as the C++ reader does)."""
        need = max(usecols) + 1
        values = np.empty((count, len(usecols)))
        lines = [line for line in block.split(b"\n") if line.strip()]
        unterminated = not block.endswith(b"\n")
        noun = "atom" if self.kind == "frames" else "entry"
        if len(lines) < count and not unterminated:
            self._fail(f"the block has {len(lines)} {noun} rows, its header says {count}", first_line + len(lines))
        if len(lines) > count:
            self._fail(f"the block has {len(lines)} {noun} rows, its header says {count} (an 'ITEM:' line "
                       f"expected)", first_line + count)
        for r in range(count):
            if r >= len(lines):
                self._cut_short(f"the block ends after {r} of its {count} rows")
                return None
            f = lines[r].split()
            if len(f) < need and r == count - 1 and unterminated:
                self._cut_short(f"the last row (line {first_line + r}) is cut short")
                return None
            if len(f) < need:
                self._fail(f"{noun} row has {len(f)} fields, the header "
                           f"names {len(columns)}", first_line + r)
            for k, c in enumerate(usecols):
                try:
                    values[r, k] = float(f[c])
                except ValueError:
                    self._fail(f"{wanted[present[k]]} '{f[c].decode(errors='replace')}' is not a number",
                               first_line + r)
        return values

    def entries(self):
        """One formats.Entry per block, in file order: its header and load() (read_rows). A
        block whose load() is not called is skipped unparsed by the next one."""
        while True:
            header = self.next_header()
            if header is None:
                return
            timestep, time, box, count, _ = header
            yield Entry(timestep, time, box, count, self.read_rows)

    def blocks(self, stride=1, window=None):
        """Yields the blocks (Frame or ContactFrame) whose time is in `window` ((t0, t1), both
        ends included; None for either end: open), every `stride`-th of those; stops once past
        the window. Skipped blocks are not parsed."""
        return select(self.entries(), Frame if self.kind == "frames" else ContactFrame, stride, window)


def open_dump(path, kind, finished=True, density=1.0):
    """The opener of the text dumps for formats.register: frames and clog frames are read as
    frames, contacts and clog contacts as contacts."""
    return DumpReader(path, "frames" if kind in ("frames", "clog_frames") else "contacts", finished, density)


# The run directory's text dumps (docs/run-directory.md), plain or gzip-compressed.
for _kind, _names in (("frames", ("frames.dump", "frames.dump.gz")), ("contacts", ("contacts.dump", "contacts.dump.gz")),
                      ("clog_frames", ("clog_frames.dump",)), ("clog_contacts", ("clog_contacts.dump",))):
    for _name in _names:
        register(_kind, _name, open_dump)

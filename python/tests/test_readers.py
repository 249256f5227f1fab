"""Every reader of python/granary against the C++ readers of src/rundir (granary-read-run):
the same frames, bodies, contacts, clogs and events, number for number, on the stored
regression runs and on fresh runs of the native engine and of LIGGGHTS, plain and gzip."""

import gzip
import math
import os
import shutil
import warnings

import numpy as np
import pandas as pd
import pytest

import granary
from conftest import cpp, regression_runs

DISC_FIELDS = ["id", "mol", "type", "x", "y", "radius", "mass", "vx", "vy", "omega"]
BODY_FIELDS = ["id", "type", "n_discs", "mass", "x", "y", "vx", "vy", "omega", "inertia", "theta", "area"]
CONTACT_FIELDS = ["body_i", "body_j", "xi", "yi", "xj", "yj", "cx", "cy", "fx", "fy"]


def table(rows, fields):
    """A structured array's fields as one float64 table (ids and counts are exact)."""
    return np.column_stack([np.asarray(rows[f], dtype=np.float64) for f in fields]) if len(rows) else \
        np.zeros((0, len(fields)))


def expect_same_frame(ours, theirs, path):
    assert ours.timestep == theirs["timestep"], path
    assert ours.time == theirs["time"], path
    assert ours.box.tolist() == theirs["box"], path
    expected = np.array(theirs["discs"], dtype=np.float64).reshape(-1, len(DISC_FIELDS))
    np.testing.assert_array_equal(table(ours.discs, DISC_FIELDS), expected, err_msg=f"{path} t={ours.time}")
    bodies = np.array(theirs["bodies"], dtype=np.float64).reshape(-1, len(BODY_FIELDS))
    # Same sums in the same order as the C++ BodiesOf; a last-bit difference would come only
    # from the compiler contracting a multiply-add, which the tolerance allows.
    np.testing.assert_allclose(table(ours.bodies(), BODY_FIELDS), bodies, rtol=1e-14, atol=1e-14,
                               err_msg=f"{path} bodies t={ours.time}")


def expect_same_contacts(ours, theirs, path):
    assert ours.timestep == theirs["timestep"], path
    assert ours.time == theirs["time"], path
    assert ours.box.tolist() == theirs["box"], path
    expected = np.array(theirs["contacts"], dtype=np.float64).reshape(-1, len(CONTACT_FIELDS))
    np.testing.assert_array_equal(table(ours.contacts, CONTACT_FIELDS), expected, err_msg=f"{path} t={ours.time}")


def expect_same_run(path):
    run = granary.open(path)
    assert isinstance(run, granary.Run)
    frames_file = next(os.path.join(path, n) for n in ("frames.dump", "frames.dump.gz") if os.path.exists(os.path.join(path, n)))
    theirs = cpp("frames", frames_file)
    ours = list(run.frames())
    assert len(ours) == len(theirs) > 0
    for o, t in zip(ours, theirs):
        expect_same_frame(o, t, frames_file)
    events = run.events()
    expected = cpp("events", os.path.join(path, "events.csv"))
    assert list(events.columns) == ["time", "body", "shape", "mass", "outlet"]
    assert len(events) == len(expected)
    for row, e in zip(events.itertuples(index=False), expected):
        assert (row.time, row.body, row.shape, row.outlet) == (e[0], e[1], e[2], e[4])
        assert row.mass == e[3] or (math.isnan(row.mass) and e[3] is None)
    contacts_file = [os.path.join(path, n) for n in ("contacts.dump", "contacts.dump.gz") if os.path.exists(os.path.join(path, n))]
    if contacts_file:
        theirs = cpp("contacts", contacts_file[0])
        ours = list(run.contacts())
        assert len(ours) == len(theirs) > 0
        for o, t in zip(ours, theirs):
            expect_same_contacts(o, t, contacts_file[0])
    return run


@pytest.mark.parametrize("path", regression_runs(), ids=lambda p: "/".join(p.split(os.sep)[-3::2]))
def test_stored_regression_runs_read_as_the_cpp_readers_read_them(path):
    expect_same_run(path)


ENGINE_RUNS = ["native", "native-gz", "liggghts", "liggghts-gz"]


@pytest.mark.parametrize("name", ENGINE_RUNS)
def test_engine_runs_read_as_the_cpp_readers_read_them(engine_runs, name):
    if name not in engine_runs:
        pytest.skip(f"no {name} run (engine not built or LIGGGHTS not installed)")
    path = engine_runs[name]
    assert os.path.exists(os.path.join(path, "frames.dump.gz" if name.endswith("gz") else "frames.dump"))
    run = expect_same_run(path)
    # The clogs: the configuration and its contact forces, as ReadClogs gives them.
    theirs = cpp("clogs", path)
    ours = run.clogs()
    assert run.summary["end_reason"] == "clogged", "the narrow outlet clogs the bed"
    assert len(ours) == len(theirs) >= 1
    for o, t in zip(ours, theirs):
        expect_same_frame(o.frame, t["frame"], path + "/clog_frames.dump")
        expect_same_contacts(o.contacts, t["contacts"], path + "/clog_contacts.dump")
        assert len(o.frame.bodies()) == 60 - run.summary["exited"] and len(o.contacts) > 20
    # Frames with their contacts: the contact frame of the same timestep.
    by_step = {c.timestep: c.contacts for c in run.contacts()}
    paired = list(run.frames(contacts=True))
    assert len(paired) == len(by_step) and sum(len(f.contacts) for f in paired) > 0
    for frame in paired:
        np.testing.assert_array_equal(frame.contacts, by_step[frame.timestep])
    # The silo: one base outlet 1.6 d wide at x = 0, side walls at x = +-8, normals out of it.
    silo = run.silo()
    assert len(silo.outlets) == 1 and len(silo.obstacles) == 0
    o = silo.outlets.iloc[0]
    assert math.hypot(o.bx - o.ax, o.by - o.ay) == pytest.approx(1.6, abs=1e-9)
    assert (o.ax + o.bx) / 2 == pytest.approx(0, abs=1e-9) and (o.ox, o.oy) == pytest.approx((0, -1))
    xs = np.concatenate([silo.walls.ax, silo.walls.bx])
    assert xs.min() == pytest.approx(-8) and xs.max() == pytest.approx(8)
    assert np.allclose(np.hypot(silo.walls.ox, silo.walls.oy), 1)


def test_frames_take_a_window_and_a_stride_and_skip_the_rest():
    path = regression_runs()[0]
    run = granary.open(path)
    times = [f.time for f in run.frames()]
    assert len(times) >= 5
    assert [f.time for f in run.frames(stride=2)] == times[::2]
    inside = [t for t in times if times[1] <= t <= times[3]]
    assert [f.time for f in run.frames(window=(times[1], times[3]))] == inside
    assert [f.time for f in run.frames(window=(times[1], None), stride=3)] == times[1::3]
    assert [f.time for f in run.frames(window=(None, times[0]))] == times[:1]
    with pytest.raises(ValueError, match="stride"):
        run.frames(stride=0)
    with pytest.raises(ValueError, match="ends before it starts"):
        run.frames(window=(3, 1))


def copy_run(tmp_path, name="run"):
    src = next(p for p in regression_runs() if os.path.exists(os.path.join(p, "contacts.dump")))
    dst = tmp_path / name
    shutil.copytree(src, dst)
    return dst


def test_a_missing_file_is_named(tmp_path):
    d = copy_run(tmp_path)
    os.remove(d / "contacts.dump")
    run = granary.open(d)
    with pytest.raises(granary.MissingFileError, match="contacts.dump: no such file.*contact_forces"):
        list(run.contacts())
    with pytest.raises(granary.MissingFileError, match="no clog_frames.dump and clog_contacts.dump"):
        run.clogs()
    with pytest.raises(granary.MissingFileError, match="silo.vtk: no such file"):
        run.silo()
    with pytest.raises(granary.MissingFileError, match="nothing: no such run directory or campaign database"):
        granary.open(tmp_path / "nothing")
    with pytest.raises(granary.MissingFileError, match="no such database"):
        granary.Campaign(tmp_path / "nothing.db")


def cut(path, fraction):
    data = path.read_bytes()
    path.write_bytes(data[:int(len(data) * fraction)])


def test_a_truncated_dump_of_a_finished_run_is_an_error_and_of_a_running_one_the_end(tmp_path):
    d = copy_run(tmp_path)
    whole = [f.time for f in granary.open(d).frames()]
    cut(d / "frames.dump", 0.7)
    with pytest.raises(granary.TruncatedError, match=r"frames.dump: the block starting at line \d+ ends before its \d+ rows.*DONE"):
        list(granary.open(d).frames())
    os.remove(d / "DONE")
    with pytest.warns(UserWarning, match="not finished"):
        partial = [f.time for f in granary.open(d).frames()]
    assert 0 < len(partial) < len(whole) and partial == whole[:len(partial)]


def test_a_truncated_gzip_dump_is_an_error(tmp_path):
    d = copy_run(tmp_path)
    with open(d / "frames.dump", "rb") as f, gzip.open(d / "frames.dump.gz", "wb") as g:
        g.write(f.read())
    os.remove(d / "frames.dump")
    assert len(list(granary.open(d).frames())) == len(cpp("frames", str(d / "frames.dump.gz")))
    cut(d / "frames.dump.gz", 0.5)
    with pytest.raises(granary.TruncatedError, match="frames.dump.gz"):
        list(granary.open(d).frames())


def test_a_malformed_row_names_its_line(tmp_path):
    d = copy_run(tmp_path)
    lines = (d / "frames.dump").read_text().split("\n")
    lines[12] = lines[12].replace(lines[12].split()[3], "1.5x", 1)
    (d / "frames.dump").write_text("\n".join(lines))
    with pytest.raises(granary.FormatError, match=r"frames.dump:13: x '1.5x' is not a number"):
        list(granary.open(d).frames())
    lines = (d / "events.csv").read_text().split("\n")
    lines[3] = "0.5,notabody,disc,1,0"
    (d / "events.csv").write_text("\n".join(lines))
    with pytest.raises(granary.FormatError, match=r"events.csv:4: body 'notabody' is not an integer"):
        granary.open(d).events()


def test_frames_in_a_newer_format_are_named_as_such(tmp_path):
    d = copy_run(tmp_path)
    os.rename(d / "frames.dump", d / "frames.v99")
    with pytest.raises(granary.NewerFormatError, match="frames.v99 but no frames.dump.*newer"):
        granary.open(d).frames()


def test_a_block_with_more_or_fewer_rows_than_its_header_says_names_its_line(tmp_path):
    d = copy_run(tmp_path)
    text = (d / "frames.dump").read_text()
    lines = text.split("\n")
    header = lines.index(next(line for line in lines if line.startswith("ITEM: ATOMS")))
    count = int(lines[lines.index("ITEM: NUMBER OF ATOMS") + 1])
    first_row = header + 2  # 1-based line number of the first row
    # One row dropped from the first block: the next block's ITEM line comes a row early.
    (d / "frames.dump").write_text("\n".join(lines[:header + 1] + lines[header + 2:]))
    with pytest.raises(granary.FormatError, match=rf"frames.dump:{first_row + count - 1}: the block has {count - 1} "
                                                  rf"atom rows, its header says {count}"):
        list(granary.open(d).frames())
    # One row too many.
    (d / "frames.dump").write_text("\n".join(lines[:header + 2] + lines[header + 1:]))
    with pytest.raises(granary.FormatError, match=rf"frames.dump:{first_row + count}: the block has {count + 1} "
                                                  rf"atom rows, its header says {count}"):
        list(granary.open(d).frames())


def test_a_frame_format_plugs_in_through_granary_formats(tmp_path):
    """A format module registers an opener per kind; Run reads through it, frames with their
    contacts paired by timestep, window and stride as for the dumps (here: NumPy .npz files
    made from the dumps, read back equal)."""
    d = copy_run(tmp_path)
    run = granary.open(d)
    frames, contacts = list(run.frames()), list(run.contacts())
    for name, blocks in (("frames.npz", frames), ("contacts.npz", contacts)):
        np.savez(d / name, **{f"b{k}": b.rows for k, b in enumerate(blocks)},
                 heads=np.array([(b.timestep, b.time) for b in blocks]))

    class NpzReader:
        def __init__(self, path, kind, finished=True, density=1.0):
            self.data = np.load(path)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.data.close()

        def entries(self):
            for k, (step, time) in enumerate(self.data["heads"]):
                yield granary.formats.Entry(int(step), float(time), np.zeros((3, 2)), None,
                                            lambda k=k: self.data[f"b{k}"])

    os.rename(d / "frames.dump", d / "frames.dump.old")
    os.rename(d / "contacts.dump", d / "contacts.dump.old")
    granary.formats.register("frames", "frames.npz", NpzReader)
    granary.formats.register("contacts", "contacts.npz", NpzReader)
    try:
        paired = list(granary.open(d).frames(contacts=True, stride=2, window=(frames[1].time, None)))
        assert [f.timestep for f in paired] == [f.timestep for f in frames[1::2]]
        for f in paired:
            np.testing.assert_array_equal(f.discs, next(g.discs for g in frames if g.timestep == f.timestep))
            np.testing.assert_array_equal(f.contacts, next(c.contacts for c in contacts if c.timestep == f.timestep))
    finally:
        for kind, name in (("frames", "frames.npz"), ("contacts", "contacts.npz")):
            granary.formats._FORMATS[kind][:] = [e for e in granary.formats._FORMATS[kind] if e[0] != name]


"""frames.gsd and contacts.gsd (output.format "gsd"): python/granary reads a native engine run
exactly as the C++ readers do (granary-read-run), Debian's python3-gsd (HOOMD's own reader)
opens the same file, contact frames at every k-th frame only (output.contact_interval), and a
cut file is an error for a finished run and the end for a running one."""

import json
import os
import shutil
import subprocess

import numpy as np
import pytest

from conftest import cpp, exe
from test_readers import expect_same_contacts, expect_same_frame

import granary


def gsd_spec(run_id, beds, contact_interval=1):
    return {"run_id": run_id, "seed": 3, "engine": "native",
            "silo": {"width": 16, "base_outlets": [{"center": 0, "width": 1.6}]},
            "bodies": {"count": 60, "species": [{"shape": "disc", "fraction": 0.5},
                                                {"shape": "dumbbell", "fraction": 0.5}]},
            "bed": {"settle_ke_per_body": 1e-3, "max_settle_time": 6, "cache_file": os.path.join(beds, "native.bed")},
            "discharge": {"mode": "remove", "max_time": 12, "clog_window": 1},
            "output": {"checkpoint_interval": 0, "frame_interval": 1.0, "contact_forces": True, "format": "gsd",
                       "contact_interval": contact_interval}}


@pytest.fixture(scope="module")
def gsd_runs(tmp_path_factory):
    engine = exe("granary-engine")
    root = tmp_path_factory.mktemp("gsd-runs")
    beds = root / "beds"
    beds.mkdir()
    out = {}
    for run_id, k in (("every", 1), ("every-3rd", 3)):
        d = root / run_id
        d.mkdir()
        (d / "run.json").write_text(json.dumps(gsd_spec(run_id, str(beds), k)))
        r = subprocess.run([engine, "run", str(d)], capture_output=True, text=True)
        assert r.returncode == 0, f"granary-engine run {d}: {r.stdout[-2000:]}{r.stderr[-2000:]}"
        out[run_id] = str(d)
    return out


def test_a_gsd_run_reads_as_the_cpp_readers_read_it(gsd_runs):
    path = gsd_runs["every"]
    assert os.path.exists(os.path.join(path, "frames.gsd")) and not os.path.exists(os.path.join(path, "frames.dump"))
    run = granary.open(path)
    theirs = cpp("frames", os.path.join(path, "frames.gsd"))
    ours = list(run.frames())
    assert len(ours) == len(theirs) > 1
    for o, t in zip(ours, theirs):
        expect_same_frame(o, t, "frames.gsd")
    theirs = cpp("contacts", os.path.join(path, "contacts.gsd"))
    ours = list(run.contacts())
    assert len(ours) == len(theirs) == len(list(run.frames()))
    assert sum(len(c.contacts) for c in ours) > 0
    for o, t in zip(ours, theirs):
        expect_same_contacts(o, t, "contacts.gsd")
    # Bodies come back whole: 60 less those that left, dumbbells with two discs.
    bodies = list(run.frames())[-1].bodies()
    assert len(bodies) == 60 - run.summary["exited"]
    assert set(bodies["n_discs"].tolist()) <= {1, 2}


def test_hoomds_own_reader_opens_the_frames(gsd_runs):
    hoomd = pytest.importorskip("gsd.hoomd", reason="Debian's python3-gsd (scripts/setup.sh installs it)")
    path = os.path.join(gsd_runs["every"], "frames.gsd")
    ours = list(granary.open(gsd_runs["every"]).frames())
    with hoomd.open(path, "rb") as trajectory:
        assert len(trajectory) == len(ours)
        for frame, o in zip(trajectory, ours):
            assert frame.configuration.step == o.timestep
            assert frame.configuration.dimensions == 2
            assert frame.particles.N == len(o)
            centre = o.box.mean(axis=1)
            np.testing.assert_array_equal(frame.particles.position[:, 0].astype(np.float64) + centre[0], o["x"])
            np.testing.assert_array_equal(frame.particles.position[:, 1].astype(np.float64) + centre[1], o["y"])
            np.testing.assert_array_equal(frame.particles.diameter.astype(np.float64) / 2, o["radius"])
            np.testing.assert_array_equal(frame.particles.typeid + 1, o["type"])
            np.testing.assert_array_equal(frame.particles.body, o["mol"])
            assert frame.configuration.box[0] == pytest.approx(o.box[0, 1] - o.box[0, 0])


def test_contact_frames_at_every_kth_frame_only(gsd_runs):
    run = granary.open(gsd_runs["every-3rd"])
    frames = list(run.frames(contacts=True))
    steps = [c.timestep for c in run.contacts()]
    assert len(frames) > 3
    assert steps == [f.timestep for f in frames[::3]]
    for k, f in enumerate(frames):
        assert (f.contacts is not None) == (k % 3 == 0), k


def test_a_cut_gsd_file_is_an_error_of_a_finished_run_and_the_end_of_a_running_one(gsd_runs, tmp_path):
    d = tmp_path / "cut"
    shutil.copytree(gsd_runs["every"], d)
    frames = d / "frames.gsd"
    whole = len(list(granary.open(str(d)).frames()))
    os.truncate(frames, os.path.getsize(frames) - 7)
    with pytest.raises(granary.TruncatedError, match="frames.gsd"):
        list(granary.open(str(d)).frames())
    os.remove(d / "DONE")
    with pytest.warns(UserWarning, match="not finished"):
        assert len(list(granary.open(str(d)).frames())) == whole - 1

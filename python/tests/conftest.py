"""Fixtures of the Python package's tests: the stored regression runs, fresh run directories
written by the native engine and by LIGGGHTS (plain and compressed, with contact frames and a
clog), and the C++ readers' view of any file (granary-read-run)."""

import json
import os
import shutil
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.environ.get("GRANARY_SOURCE_DIR", os.path.dirname(os.path.dirname(HERE)))
BIN = os.environ.get("GRANARY_BIN_DIR", os.path.join(SOURCE, "build", "bin"))
REGRESSION = os.path.join(SOURCE, "tests", "data", "regression")

sys.path.insert(0, os.path.join(SOURCE, "python"))


def exe(name):
    path = os.path.join(BIN, name)
    if not os.path.exists(path):
        pytest.skip(f"{path} is not built (cmake --build build)")
    return path


def regression_runs():
    out = []
    for campaign in sorted(os.listdir(REGRESSION)):
        runs = os.path.join(REGRESSION, campaign, "runs")
        if os.path.isdir(runs):
            out += [os.path.join(runs, r) for r in sorted(os.listdir(runs))]
    return out


def cpp(what, path):
    """What the C++ readers return for `path` (granary-read-run)."""
    r = subprocess.run([exe("granary-read-run"), what, path], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


# A narrow outlet in remove mode: the bed clogs within the first time units on both engines,
# so the run has frames, contact frames and a clog with its contact forces.
def run_spec(engine, compress, beds):
    return {"run_id": f"{engine}{'-gz' if compress else ''}", "seed": 3, "engine": engine,
            "silo": {"width": 16, "base_outlets": [{"center": 0, "width": 1.6}]},
            "bodies": {"count": 60, "species": [{"shape": "disc", "fraction": 0.5},
                                                {"shape": "dumbbell", "fraction": 0.5}]},
            "bed": {"settle_ke_per_body": 1e-3, "max_settle_time": 6, "cache_file": os.path.join(beds, f"{engine}.bed")},
            "discharge": {"mode": "remove", "max_time": 12, "clog_window": 1},
            "output": {"checkpoint_interval": 0, "frame_interval": 1.0, "contact_forces": True, "compress": compress}}


@pytest.fixture(scope="session")
def engine_runs(tmp_path_factory):
    """{"native": dir, "native-gz": dir, "liggghts": dir, "liggghts-gz": dir}: finished runs."""
    root = tmp_path_factory.mktemp("engine-runs")
    beds = root / "beds"
    beds.mkdir()
    out = {}
    for engine, program in (("native", "granary-engine"), ("liggghts", "granary-liggghts")):
        path = os.path.join(BIN, program)
        if not os.path.exists(path):
            continue
        if engine == "liggghts" and shutil.which("liggghts") is None and not os.path.exists("/usr/bin/liggghts"):
            continue
        for compress in (False, True):
            spec = run_spec(engine, compress, str(beds))
            d = root / spec["run_id"]
            d.mkdir()
            (d / "run.json").write_text(json.dumps(spec))
            r = subprocess.run([path, "run", str(d)], capture_output=True, text=True)
            assert r.returncode == 0, f"{program} run {d}: {r.stdout[-2000:]}{r.stderr[-2000:]}"
            out[spec["run_id"]] = str(d)
    return out

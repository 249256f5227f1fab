"""Python analyses of a campaign spec (/report/python) end to end: a tiny campaign on the
native engine, its report, export, database and `campaign show`; a failing script; the cache
and what invalidates it. Real processes throughout (campaign, granary-engine, the workers)."""

import csv
import json
import math
import os
import sqlite3
import subprocess

import numpy as np
import pytest

import granary
from conftest import exe

# The mean height of the bodies' centres of mass over the frames, with the se over frames, and
# the number of frames: numbers the test computes again from the run directory.
GOOD = '''
import numpy as np

def analyse(run, options):
    with open(options["log"], "a") as log:
        log.write(run.id + "\\n")
    heights = [frame.bodies()["y"].mean() * options["scale"] for frame in run.frames()]
    print("this goes nowhere near the answers")
    return {"mean_height": (float(np.mean(heights)), float(np.std(heights, ddof=1) / np.sqrt(len(heights))), "d"),
            "frames_seen": (len(heights), None, "frames")}
'''

# Fails on the narrow outlet only: the other run's metric is kept.
FAILS_ON_NARROW = '''
def analyse(run, options):
    if run.spec["silo"]["base_outlets"][0]["width"] == 3:
        raise ValueError("narrow outlet: no arch statistics here")
    return {"ok_metric": (1.0, None, "1")}
'''

GARBAGE = '''
import sys, os
def analyse(run, options):
    print("garbage garbage {not json")
    os.write(1, b"raw garbage on fd 1\\n")
    sys.stderr.write("more garbage\\n")
    return "not a dict"
'''

RETURNS_NAN = '''
def analyse(run, options):
    return {"nan_metric": (float("nan"), None, "1")}
'''

DIES = '''
import os
def analyse(run, options):
    os._exit(3)
'''


def campaign_cmd(*args, cwd):
    r = subprocess.run([exe("campaign"), *args], capture_output=True, text=True, cwd=cwd)
    return r


def write_spec(folder, python):
    spec = {"name": "py", "seed": 2, "replicas": 1,
            "base": {"bodies": {"count": 60}, "silo": {"width": 12},
                     "discharge": {"mode": "reinject", "max_time": 3},
                     "output": {"frame_interval": 1.0, "checkpoint_interval": 0}},
            "sweep": {"grid": {"/silo/base_outlets/0/width": [3, 5]}},
            "report": {"python": python}}
    (folder / "spec.json").write_text(json.dumps(spec))
    return str(folder / "spec.json")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """A planned and run campaign of two runs (W = 3 and 5), with its scripts beside the spec."""
    exe("granary-engine")
    d = tmp_path_factory.mktemp("py-campaign")
    os.environ["GRANARY_CACHE_DIR"] = str(d / "beds")
    (d / "analyses").mkdir()
    (d / "analyses" / "good.py").write_text(GOOD)
    spec = write_spec(d, [{"key": "heights", "script": "analyses/good.py",
                           "options": {"log": str(d / "calls.log"), "scale": 1.0}}])
    r = campaign_cmd("plan", spec, "--db", "study.db", cwd=d)
    assert r.returncode == 0, r.stdout + r.stderr
    r = campaign_cmd("run", "--db", "study.db", "--jobs", "2", cwd=d)
    assert r.returncode == 0, r.stdout + r.stderr
    return d


def computed(output):
    """(from caches, computed) of a report's or export's summary line."""
    for line in output.splitlines():
        if "from the runs' caches" in line:
            words = line.replace(",", "").split()
            return int(words[words.index("from") - 1]), int(words[words.index("computed") - 1])
    raise AssertionError(output)


def calls(d):
    return open(d / "calls.log").read().split() if os.path.exists(d / "calls.log") else []


def test_a_python_analysis_reaches_the_report_the_export_and_the_database(campaign):
    d = campaign
    r = campaign_cmd("report", "--db", "study.db", "--out", "report", "--no-figures", cwd=d)
    assert r.returncode == 0, r.stdout + r.stderr
    assert len(calls(d)) == 2, "one call per run"
    report = (d / "report" / "report.md").read_text()
    assert "## Python analysis heights" in report and "mean_height [d]" in report
    # The numbers, computed again here from the run directories.
    study = granary.open(d / "study.db")
    expected = {}
    for run in study.runs(state="done"):
        h = [f.bodies()["y"].mean() for f in run.frames()]
        expected[run.id] = (np.mean(h), np.std(h, ddof=1) / math.sqrt(len(h)), len(h))
    assert len(expected) == 2
    r = campaign_cmd("export", "--db", "study.db", "--out", "runs.csv", cwd=d)
    assert r.returncode == 0, r.stdout + r.stderr
    rows = list(csv.DictReader(open(d / "runs.csv")))
    assert {"mean_height", "mean_height_se", "frames_seen"} <= set(rows[0])
    # The axes carry the export's names (the symbol W here), in granary.open's tables too.
    header = open(d / "runs.csv").readline().strip().split(",")
    assert header[5] == "W" and "W" in granary.open(d / "study.db").runs.columns
    assert [r.id for r in granary.open(d / "study.db").runs(W=5)] == [r.id for r in study.runs(width=5)]
    for row in rows:
        mean, se, n = expected[row["run_id"]]
        assert float(row["mean_height"]) == pytest.approx(mean, rel=1e-12)
        assert float(row["mean_height_se"]) == pytest.approx(se, rel=1e-12)
        assert float(row["frames_seen"]) == n
    con = sqlite3.connect(d / "study.db")
    stored = con.execute("SELECT run_id, value, se, unit FROM metrics WHERE analysis = 'heights' "
                         "AND metric = 'mean_height'").fetchall()
    assert len(stored) == 2
    for run_id, value, se, unit in stored:
        assert (value, unit) == (pytest.approx(expected[run_id][0], rel=1e-12), "d")
    assert con.execute("SELECT COUNT(*) FROM metrics WHERE analysis = 'heights' AND metric = 'frames_seen' "
                       "AND se IS NULL").fetchone()[0] == 2
    con.close()
    # ... and granary.open sees them as columns, like the built-in ones.
    table = granary.open(d / "study.db").runs
    assert table.set_index("run_id").loc[rows[0]["run_id"], "mean_height"] == pytest.approx(float(rows[0]["mean_height"]))
    points = granary.open(d / "study.db").points
    assert list(points["mean_height_n"]) == [1, 1]
    r = campaign_cmd("status", "--db", "study.db", cwd=d)
    assert "metrics in the database for 2 of 2 done runs" in r.stdout


def test_results_are_cached_until_the_script_or_its_options_change(campaign):
    d = campaign
    before = len(calls(d))
    r = campaign_cmd("report", "--db", "study.db", "--out", "report", "--no-figures", cwd=d)
    assert r.returncode == 0 and computed(r.stdout + r.stderr)[1] == 0, r.stdout + r.stderr
    assert len(calls(d)) == before, "a second report reads the caches"
    # The same text saved again (a new mtime) is the same script.
    script = d / "analyses" / "good.py"
    script.write_text(script.read_text())
    r = campaign_cmd("export", "--db", "study.db", "--out", "again.csv", cwd=d)
    assert r.returncode == 0 and len(calls(d)) == before, r.stdout + r.stderr
    # Another script text: only this analysis, on every run.
    script.write_text(script.read_text() + "\n# a comment changes the hash\n")
    r = campaign_cmd("report", "--db", "study.db", "--out", "report", "--no-figures", cwd=d)
    assert r.returncode == 0 and computed(r.stdout + r.stderr)[1] == 2, r.stdout + r.stderr
    assert len(calls(d)) == before + 2
    # Other options (the spec planned again): recomputed, with the new option's effect.
    spec = write_spec(d, [{"key": "heights", "script": "analyses/good.py",
                           "options": {"log": str(d / "calls.log"), "scale": 2.0}}])
    assert campaign_cmd("plan", spec, "--db", "study.db", cwd=d).returncode == 0
    old = {r["run_id"]: float(r["mean_height"]) for r in csv.DictReader(open(d / "runs.csv"))}
    r = campaign_cmd("export", "--db", "study.db", "--out", "scaled.csv", cwd=d)
    assert r.returncode == 0 and len(calls(d)) == before + 4, r.stdout + r.stderr
    for row in csv.DictReader(open(d / "scaled.csv")):
        assert float(row["mean_height"]) == pytest.approx(2 * old[row["run_id"]], rel=1e-12)


def test_failing_scripts_fail_their_runs_and_never_the_report(campaign):
    d = campaign
    for name, text in (("narrow.py", FAILS_ON_NARROW), ("garbage.py", GARBAGE), ("nan.py", RETURNS_NAN),
                       ("dies.py", DIES)):
        (d / "analyses" / name).write_text(text)
    spec = write_spec(d, [{"key": "narrow", "script": "analyses/narrow.py"},
                          {"key": "garbage", "script": "analyses/garbage.py"},
                          {"key": "nan", "script": "analyses/nan.py"},
                          {"key": "dies", "script": "analyses/dies.py"}])
    assert campaign_cmd("plan", spec, "--db", "study.db", cwd=d).returncode == 0
    r = campaign_cmd("report", "--db", "study.db", "--out", "failing", "--no-figures", cwd=d)
    assert r.returncode == 0, r.stdout + r.stderr
    report = (d / "failing" / "report.md").read_text()
    assert "**Failed on 1 of 2 runs**" in report and "ValueError: narrow outlet: no arch statistics here" in report
    assert "analyse() returned str, not a dict" in report and "garbage garbage" in report
    assert "metric nan_metric: value is nan" in report
    assert "died without an answer (exit status 3" in report
    # The run that did not fail keeps its metric; the failed one has none.
    r = campaign_cmd("export", "--db", "study.db", "--out", "failing.csv", cwd=d)
    rows = {row["run_id"]: row for row in csv.DictReader(open(d / "failing.csv"))}
    study = granary.open(d / "study.db")
    narrow = study.runs(width=3)[0].id
    wide = study.runs(width=5)[0].id
    assert rows[wide]["ok_metric"] == "1" and rows[narrow]["ok_metric"] == ""
    # campaign show prints the traceback's last lines; --json has them.
    r = campaign_cmd("show", narrow, "--db", "study.db", cwd=d)
    assert "analysis narrow failed" in r.stdout and "ValueError: narrow outlet" in r.stdout
    r = campaign_cmd("show", narrow, "--db", "study.db", "--json", cwd=d)
    failures = {f["analysis"]: f["error"] for f in json.loads(r.stdout)["analysis_failures"]}
    assert set(failures) == {"narrow", "garbage", "nan", "dies"}
    assert 'raise ValueError("narrow outlet' in failures["narrow"]


def test_bad_python_entries_are_refused_by_plan_naming_the_path(campaign):
    d = campaign
    for python, message in (([{"key": "x", "script": "analyses/missing.py"}], "/report/python/0/script"),
                            ([{"key": "Bad-Key", "script": "analyses/good.py"}], "/report/python/0/key"),
                            ([{"key": "flow", "script": "analyses/good.py"}], "flow is taken"),
                            ({"key": "x"}, "/report/python")):
        spec = write_spec(d, python)
        r = campaign_cmd("plan", spec, "--db", "study.db", cwd=d)
        assert r.returncode == 2 and message in r.stderr, r.stdout + r.stderr

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

# Runs forever; with block_alarm it also blocks the worker's alarm, as a long C call would.
SLOW = '''
import signal, time
def analyse(run, options):
    with open(options["log"], "a") as log:
        log.write(run.id + "\\n")
    if options.get("block_alarm"):
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM})
    try:
        while True:
            time.sleep(0.02)
    except Exception:  # the timeout is not an Exception: this does not swallow it
        return {"never": (1.0, None, "1")}
'''

# A metric of its own per run (the outlet width + options["add"]), or a failure, by version.
VERSIONED = '''
def analyse(run, options):
    with open(options["log"], "a") as log:
        log.write(run.id + "\\n")
    if VERSION == 2:
        raise ValueError("version 2 is broken")
    return {"width_plus": (run.spec["silo"]["base_outlets"][0]["width"] + options.get("add", 0), None, "d")}
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
            "axes": {"W_root": "sqrt(W_half) + 1", "W_half": "W / 2"},
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


def metric_rows(d, metric):
    con = sqlite3.connect(d / "study.db")
    try:
        return dict(con.execute("SELECT run_id, value FROM metrics WHERE metric = ?", (metric,)).fetchall())
    finally:
        con.close()


def test_a_script_past_its_timeout_fails_its_runs_is_not_cached_and_the_report_goes_on(campaign):
    d = campaign
    (d / "analyses" / "slow.py").write_text(SLOW)
    log = str(d / "slow.log")
    spec = write_spec(d, [{"key": "slow", "script": "analyses/slow.py", "options": {"log": log}, "timeout": 0.5},
                          {"key": "stuck", "script": "analyses/slow.py", "options": {"log": log, "block_alarm": True},
                           "timeout": 0.3},
                          {"key": "heights", "script": "analyses/good.py",
                           "options": {"log": str(d / "calls.log"), "scale": 1.0}}])
    assert campaign_cmd("plan", spec, "--db", "study.db", cwd=d).returncode == 0
    for attempt in (1, 2):
        r = campaign_cmd("report", "--db", "study.db", "--out", "slow", "--no-figures", cwd=d)
        assert r.returncode == 0, r.stdout + r.stderr
        report = (d / "slow" / "report.md").read_text()
        slow = report.split("## Python analysis slow")[1].split("\n## ")[0]
        stuck = report.split("## Python analysis stuck")[1].split("\n## ")[0]
        assert "**Failed on 2 of 2 runs**" in slow and slow.count("ran longer than its timeout of 0.5 s") == 2, slow
        assert "time.sleep(0.02)" in slow, "where the script was stopped"
        assert "**Failed on 2 of 2 runs**" in stuck and stuck.count("did not answer within 1.3 s and was stopped") == 2
        assert "mean_height [d]" in report, "the other analysis of the same runs is there"
        # Not read from the cache: each report runs the scripts again (2 runs x 2 analyses).
        assert len(open(log).read().split()) == 4 * attempt
    study = granary.open(d / "study.db")
    assert "never" not in study.runs.columns
    # campaign show has the last failure of each.
    r = campaign_cmd("show", study.runs(W=3)[0].id, "--db", "study.db", "--json", cwd=d)
    failures = {f["analysis"]: f["error"] for f in json.loads(r.stdout)["analysis_failures"]}
    assert "ran longer than its timeout of 0.5 s" in failures["slow"]
    assert "did not answer within 1.3 s" in failures["stuck"]


def test_a_failure_is_cached_with_its_script_and_options_and_never_shown_as_a_value(campaign):
    d = campaign
    log = d / "versioned.log"
    script = d / "analyses" / "versioned.py"

    def plan(add):
        spec = write_spec(d, [{"key": "versioned", "script": "analyses/versioned.py",
                               "options": {"log": str(log), "add": add}}])
        assert campaign_cmd("plan", spec, "--db", "study.db", cwd=d).returncode == 0

    def report():
        r = campaign_cmd("report", "--db", "study.db", "--out", "versioned", "--no-figures", cwd=d)
        assert r.returncode == 0, r.stdout + r.stderr
        return (d / "versioned" / "report.md").read_text(), computed(r.stdout + r.stderr)

    def calls_so_far():
        return len(log.read_text().split()) if log.exists() else 0

    study = granary.open(d / "study.db")
    narrow, wide = study.runs(W=3)[0].id, study.runs(W=5)[0].id
    script.write_text("VERSION = 1\n" + VERSIONED)
    plan(0.5)
    text, _ = report()
    assert metric_rows(d, "width_plus") == {narrow: 3.5, wide: 5.5} and calls_so_far() == 2
    # Version 2 fails on both runs: no value is left anywhere (database, export, granary.open).
    script.write_text("VERSION = 2\n" + VERSIONED)
    text, _ = report()
    assert calls_so_far() == 4 and "**Failed on 2 of 2 runs**" in text and "ValueError: version 2 is broken" in text
    assert metric_rows(d, "width_plus") == {}
    r = campaign_cmd("export", "--db", "study.db", "--out", "versioned.csv", cwd=d)
    assert r.returncode == 0 and calls_so_far() == 4, "the export reads the cached failure"
    assert all(row.get("width_plus", "") == "" for row in csv.DictReader(open(d / "versioned.csv")))
    assert "width_plus" not in granary.open(d / "study.db").runs.columns
    r = campaign_cmd("show", wide, "--db", "study.db", "--json", cwd=d)
    assert [f["analysis"] for f in json.loads(r.stdout)["analysis_failures"]] == ["versioned"]
    # The same script and options again: the failure comes from the cache, still a failure.
    text, (from_cache, _) = report()
    assert calls_so_far() == 4 and from_cache > 0 and "ValueError: version 2 is broken" in text
    # Other options: computed again (and still failing).
    plan(1.0)
    text, _ = report()
    assert calls_so_far() == 6 and "ValueError: version 2 is broken" in text
    # The script mended: computed again, the values are back and the failure is gone.
    script.write_text("VERSION = 3\n" + VERSIONED)
    text, _ = report()
    assert calls_so_far() == 8 and "Failed on" not in text and "version 2 is broken" not in text
    assert metric_rows(d, "width_plus") == {narrow: 4.0, wide: 6.0}
    r = campaign_cmd("show", wide, "--db", "study.db", "--json", cwd=d)
    assert json.loads(r.stdout)["analysis_failures"] == []


def test_derived_axes_are_columns_and_filters_as_in_the_export(campaign):
    d = campaign
    study = granary.open(d / "study.db")
    r = campaign_cmd("export", "--db", "study.db", "--out", "axes.csv", cwd=d)
    assert r.returncode == 0, r.stdout + r.stderr
    rows = {row["run_id"]: row for row in csv.DictReader(open(d / "axes.csv"))}
    header = open(d / "axes.csv").readline().strip().split(",")
    assert header[5:8] == ["W", "W_half", "W_root"], "the sweep axis, then the derived axes by name"
    table = study.runs.set_index("run_id")
    for run_id, row in rows.items():
        assert table.loc[run_id, "W_half"] == float(row["W_half"]) == float(row["W"]) / 2
        assert table.loc[run_id, "W_root"] == pytest.approx(float(row["W_root"]), rel=1e-9)
        assert table.loc[run_id, "W_root"] == math.sqrt(float(row["W"]) / 2) + 1
    assert list(study.points.columns[3:6]) == ["W", "W_half", "W_root"]
    # Filters: a derived axis by its value, to the 6 digits the report prints, like --only.
    wide = study.runs(W=5)[0].id
    assert [r.id for r in study.runs(W_half=2.5)] == [wide]
    assert [r.id for r in study.runs("W_root=2.58114")] == [wide]
    assert [r.id for r in study.runs(W_root=[2.58114, 2.22474])] == [r.id for r in study.runs()]
    r = campaign_cmd("export", "--db", "study.db", "--out", "only.csv", "--only", "W_root=2.58114", cwd=d)
    assert r.returncode == 0 and [row["run_id"] for row in csv.DictReader(open(d / "only.csv"))] == [wide]
    with pytest.raises(granary.FilterError, match=r"W_root=7: no run has W_root = 7 \(its values: 2.22474, 2.58114\)"):
        study.runs(W_root=7)
    with pytest.raises(granary.FilterError, match="no run passes all of them"):
        study.runs(W_root=2.58114, W=3)


EXITS = '''
def analyse(run, options):
    events = run.events()
    return {"exits_seen": (float(len(events)), None, "bodies"),
            "mean_exit_time": (float(events["time"].mean()) if len(events) else 0.0, None, "sqrt(d/g)")}
'''


def test_campaign_compare_compares_a_python_analysis_between_the_engines(tmp_path):
    """compare runs the spec on both engines; the Python analysis' metrics are compared like
    the built-in ones (both values, the ratio, agreement)."""
    exe("granary-engine")
    if not os.path.exists(os.path.join(os.path.dirname(exe("campaign")), "granary-liggghts")) or \
            not os.path.exists("/usr/bin/liggghts"):
        pytest.skip("LIGGGHTS or granary-liggghts is not there")
    os.environ["GRANARY_CACHE_DIR"] = str(tmp_path / "beds")
    (tmp_path / "exits.py").write_text(EXITS)
    spec = {"name": "pycompare", "seed": 4, "replicas": 2,
            "base": {"bodies": {"count": 60}, "silo": {"width": 12, "base_outlets": [{"center": 0, "width": 5}]},
                     "bed": {"settle_ke_per_body": 1e-3, "max_settle_time": 6},
                     "discharge": {"mode": "reinject", "max_time": 3},
                     "output": {"frame_interval": 0, "checkpoint_interval": 0}},
            "report": {"python": [{"key": "exits", "script": "exits.py"}]}}
    (tmp_path / "spec.json").write_text(json.dumps(spec))
    r = campaign_cmd("compare", "spec.json", "--db", "study.db", "--jobs", "2", "--no-figures", "--json", cwd=tmp_path)
    assert r.returncode in (0, 1), r.stdout[-3000:] + r.stderr[-3000:]
    out = json.loads(r.stdout)
    assert out["runs_used"] == 4
    comparison = out["comparison"]
    assert {comparison["engine_a"], comparison["engine_b"]} == {"native", "liggghts"}
    assert "exits_seen" in comparison["metric_order"] and "mean_exit_time" in comparison["metric_order"]
    [point] = comparison["points"]
    exits = point["metrics"]["exits_seen"]
    # Each side: the mean over its two runs of what the script returned, read again here.
    study = granary.open(tmp_path / "study.db")
    for engine in ("native", "liggghts"):
        counts = [len(run.events()) for run in study.runs() if run.row["engine"] == engine]
        assert len(counts) == 2
        side = exits[engine]
        assert (side["mean"] if isinstance(side, dict) else side) == pytest.approx(sum(counts) / 2)
    assert exits["ratio"] is not None and exits["agree"] in (True, False, None)
    report = (tmp_path / "report" / "report.md").read_text()
    assert "## Engine comparison" in report and "exits_seen" in report.split("## Engine comparison")[1]

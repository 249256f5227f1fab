"""A campaign's database (docs/data.md), read-only: its spec, runs and points as DataFrames,
and its runs as Run objects, selected by the filters of `campaign --only` (docs/cli.md)."""

import json
import math
import os
import sqlite3

import numpy as np
import pandas as pd

from .errors import MissingFileError
from .expression import derived_axes
from .run import Run

from .axes import axis_short_names, short_axis  # noqa: F401 (short_axis: part of the API)


def _pointer_get(obj, pointer):
    """The value at a JSON Pointer, or KeyError."""
    if pointer == "":
        return obj
    for token in pointer.split("/")[1:]:
        token = token.replace("~1", "/").replace("~0", "~")
        if isinstance(obj, list):
            if not token.isdigit() or int(token) >= len(obj):
                raise KeyError(pointer)
            obj = obj[int(token)]
        elif isinstance(obj, dict) and token in obj:
            obj = obj[token]
        else:
            raise KeyError(pointer)
    return obj


def _has(obj, pointer):
    try:
        _pointer_get(obj, pointer)
        return True
    except KeyError:
        return False


def parameter_matches(params, pointer, text):
    """Does the value at `pointer` of a run's parameters equal VALUE (a JSON value, or the
    text of a string)? Numbers compare as numbers (9 == 9.0). As runner::parameter_matches."""
    try:
        actual = _pointer_get(params, pointer)
    except KeyError:
        return False
    try:
        value = json.loads(text)
        parsed = True
    except ValueError:
        parsed = False
    if parsed:
        number = (int, float)
        if isinstance(value, number) and not isinstance(value, bool) and isinstance(actual, number) \
                and not isinstance(actual, bool):
            return float(value) == float(actual)
        if value == actual and type(value) is type(actual):
            return True
    return isinstance(actual, str) and actual == text


def _format_number(v, significant=6):
    """A number as the report prints it (analysis::format_number)."""
    if not math.isfinite(v):
        return ""
    if v == math.floor(v) and abs(v) < 1e9:
        return "%.0f" % v
    return "%.*g" % (significant, v)


def _derived_matches(actual, text):
    """A derived axis' value equals VALUE: as numbers, or to the 6 significant digits the report
    prints (as the C++ --only does)."""
    try:
        want = json.loads(text)
    except ValueError:
        return False
    if isinstance(want, bool) or not isinstance(want, (int, float)) or not math.isfinite(actual):
        return False
    want = float(want)
    return actual == want or abs(actual - want) <= 1e-9 * max(abs(actual), abs(want)) or \
        _format_number(actual) == _format_number(want)


class FilterError(ValueError):
    """A filter that selects nothing; the message says what there is to choose from."""


def _listing(items, most=12):
    out = ", ".join(items[:most])
    return out + (f", ... ({len(items)} in all)" if len(items) > most else "")


class RunTable(pd.DataFrame):
    """campaign.runs: the runs as a DataFrame, and called with filters, the runs that pass
    them as Run objects (campaign.runs(width=11)). Anything derived from it is a plain
    DataFrame."""

    _metadata = ["_campaign"]

    @property
    def _constructor(self):
        return pd.DataFrame

    def __call__(self, *filters, state="done", **short):
        return self._campaign.select(*filters, state=state, **short)


class Campaign:
    """A campaign database opened read-only. `spec` (the campaign spec), `axes` (the sweep
    axes' JSON Pointers), `runs` and `points` (DataFrames), `run(id)`, and `runs(width=11)`
    (the runs that pass filters, as Run objects)."""

    def __init__(self, db):
        self.db = os.fspath(db)
        if not os.path.exists(self.db):
            raise MissingFileError(f"{self.db}: no such database (campaign plan creates it)")
        self._con = sqlite3.connect(f"file:{self.db}?mode=ro", uri=True)
        try:
            row = self._con.execute("SELECT name, spec, axes FROM campaign").fetchone()
        except sqlite3.DatabaseError as e:
            raise MissingFileError(f"{self.db}: not a Granary campaign database ({e})") from None
        if row is None:
            raise MissingFileError(f"{self.db}: has no campaign (campaign plan writes it)")
        self.name = row[0]
        self.spec = json.loads(row[1])
        self.axes = json.loads(row[2])
        # The derived axes of /axes, in the order the C++ side reads them (by name).
        block = self.spec.get("axes") if isinstance(self.spec, dict) else None
        self.derived = dict(derived_axes(dict(sorted(block.items())) if isinstance(block, dict) else None))
        self._runs = None

    def close(self):
        self._con.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        return f"<Campaign {self.name!r}: {len(self.runs)} runs, axes {', '.join(self.axes) or 'none'}>"

    def _run_dir(self, path):
        return path if os.path.isabs(path) else os.path.join(os.path.dirname(os.path.abspath(self.db)), path)

    @property
    def runs(self):
        """Every run that is not retired, one row each: run_id, point_id, replica, engine, state,
        end_reason, attempts, wall_s, run_dir, the sweep axes by their short names, the derived
        axes of the spec's /axes (as `campaign export` computes them), then every stored metric and its standard error (`q_count`, `q_count_se`, ...: the metrics
        `campaign report`, `export` or `compare` stored)."""
        if self._runs is None:
            runs = pd.read_sql_query(
                "SELECT run_id, point_id, replica, engine, state, end_reason, attempts, wall_s, run_dir, point, "
                "params FROM runs WHERE state != 'retired' ORDER BY seq", self._con)
            runs["run_dir"] = [self._run_dir(p) for p in runs["run_dir"]]
            points = [json.loads(p) for p in runs.pop("point")]
            self._params = {rid: json.loads(p) for rid, p in zip(runs["run_id"], runs.pop("params"))}
            first = next(iter(self._params.values()), {})
            self.axis_names = axis_short_names(self.axes, first)
            for axis in self.axes:
                runs[self.axis_names[axis]] = [p.get(axis, np.nan) for p in points]
            self._derived_values = {}
            for rid, p in zip(runs["run_id"], points):
                values = {}
                for axis in self.axes:
                    v = p.get(axis)
                    if v is None:
                        try:
                            v = _pointer_get(self._params[rid], axis)
                        except KeyError:
                            v = None
                    number = isinstance(v, (int, float)) and not isinstance(v, bool)
                    values[self.axis_names[axis]] = float(v) if number else np.nan
                for name, expression in self.derived.items():
                    values[name] = expression.evaluate(values)
                self._derived_values[rid] = values
            for name in self.derived:
                runs[name] = [self._derived_values[rid][name] for rid in runs["run_id"]]
            metrics = pd.read_sql_query("SELECT run_id, metric, value, se FROM metrics", self._con)
            if len(metrics):
                wide = metrics.pivot_table(index="run_id", columns="metric", values=["value", "se"],
                                           aggfunc="first", dropna=False)
                for metric in sorted(metrics["metric"].unique(), key=list(metrics["metric"]).index):
                    runs[metric] = runs["run_id"].map(wide[("value", metric)]) if ("value", metric) in wide else np.nan
                    runs[metric + "_se"] = runs["run_id"].map(wide[("se", metric)]) if ("se", metric) in wide else np.nan
            table = RunTable(runs)
            table._campaign = self
            self._runs = table
        return self._runs

    @property
    def points(self):
        """One row per sweep point and engine: point_id, engine, runs (finished ones), the axes,
        then per stored metric the mean over the point's finished runs, its standard error
        (`_se`: the spread of the runs, s / sqrt(n)) and `_n`. Analyses that pool differently
        (avalanches, Psi) have their own point metrics in `campaign export --level point`."""
        runs = self.runs
        done = runs[runs["state"] == "done"]
        axes = [self.axis_names[a] for a in self.axes] + list(self.derived)
        metric_cols = [c for c in runs.columns[9 + len(axes):] if not c.endswith("_se")]
        rows = []
        for (point_id, engine), group in runs.groupby(["point_id", "engine"], sort=False):
            g = done[(done["point_id"] == point_id) & (done["engine"] == engine)]
            row = {"point_id": point_id, "engine": engine, "runs": len(g)}
            for a in axes:
                row[a] = group[a].iloc[0]
            for m in metric_cols:
                v = g[m].dropna().to_numpy(dtype=float)
                row[m] = v.mean() if len(v) else np.nan
                row[m + "_se"] = v.std(ddof=1) / math.sqrt(len(v)) if len(v) > 1 else np.nan
                row[m + "_n"] = len(v)
            rows.append(row)
        return pd.DataFrame(rows)

    def run(self, run_id):
        """The run with this id (or a unique prefix of it)."""
        runs = self.runs
        hit = runs[runs["run_id"].str.startswith(run_id)]
        if len(hit) != 1:
            raise KeyError(f"{run_id!r}: {'no run id starts with it' if hit.empty else 'several run ids start with it'}"
                           f" ({_listing(list(runs['run_id']))})")
        row = hit.iloc[0]
        return Run(row["run_dir"], run_id=row["run_id"], row=row)

    def select(self, *filters, state="done", **short):
        """The runs that pass every filter, as Run objects in planning order. A filter is what
        `--only` takes: a run-id prefix, or "POINTER=VALUE" where POINTER is a JSON Pointer, a
        short name that ends exactly one sweep axis ("width=11") or a derived axis of the spec's
        /axes (D_eq=1.80278: equal to the 6 digits the report prints); keywords are short names
        (width=11; a list gives alternatives: width=[9, 11]). Values of one parameter are
        alternatives, different parameters must all hold, run-id prefixes are alternatives.
        state: only runs in this state ("done" by default; None for all but retired ones)."""
        texts = list(filters)
        for name, value in short.items():
            for v in (value if isinstance(value, (list, tuple)) else [value]):
                texts.append(f"{name}={v if isinstance(v, str) else json.dumps(v)}")
        runs = self.runs
        selected = self._filter(texts, runs)
        if state is not None:
            selected = selected[selected["state"] == state]
        return [Run(r.run_dir, run_id=r.run_id, row=runs.loc[i]) for i, r in selected.iterrows()]

    def _filter(self, texts, runs):
        ids = list(runs["run_id"])
        params = [self._params[r] for r in ids]
        axes = "axes: " + _listing(self.axes) if self.axes else "it has no sweep axes"
        prefixes, values, derived = [], {}, {}
        for f in texts:
            if not f:
                raise FilterError("an empty filter (give a run-id prefix or POINTER=VALUE)")
            if "=" not in f:
                if not any(r.startswith(f) for r in ids):
                    raise FilterError(f"{f}: no run id starts with \"{f}\" (a filter is a run-id prefix, or "
                                      f"POINTER=VALUE on a parameter; {axes})")
                prefixes.append(f)
                continue
            pointer, value = f.split("=", 1)
            by_name = {name: axis for axis, name in self.axis_names.items()}
            if pointer in self.derived and pointer not in by_name:
                # A derived axis is no parameter of a run: the runs whose value matches.
                shown = []
                for r in ids:
                    actual = self._derived_values[r][pointer]
                    if _format_number(actual) not in shown:
                        shown.append(_format_number(actual))
                    if _derived_matches(actual, value):
                        derived.setdefault(pointer, set()).add(r)
                if pointer not in derived:
                    raise FilterError(f"{f}: no run has {pointer} = {value} (its values: {_listing(shown)})")
                continue
            if pointer in by_name:
                pointer = by_name[pointer]
            elif not pointer.startswith("/"):
                found = [a for a in self.axes if a.endswith("/" + pointer)]
                if len(found) != 1:
                    raise FilterError(f"{f}: \"{pointer}\" " + ("ends no sweep axis" if not found else
                                      f"ends several sweep axes ({_listing(found)})") + f"; give the JSON Pointer ({axes})")
                pointer = found[0]
            if not any(_has(p, pointer) for p in params):
                raise FilterError(f"{f}: \"{pointer}\" is not a parameter of the runs ({axes})")
            if not any(parameter_matches(p, pointer, value) for p in params):
                seen = []
                for p in params:
                    if _has(p, pointer):
                        v = json.dumps(_pointer_get(p, pointer))
                        if v not in seen:
                            seen.append(v)
                raise FilterError(f"{f}: no run has {pointer} = {value} (its values: {_listing(seen)})")
            values.setdefault(pointer, []).append(value)

        def passes(run_id, p):
            if prefixes and not any(run_id.startswith(x) for x in prefixes):
                return False
            if not all(run_id in passing for passing in derived.values()):
                return False
            return all(any(parameter_matches(p, ptr, t) for t in ts) for ptr, ts in values.items())

        mask = [passes(r, p) for r, p in zip(ids, params)]
        if texts and not any(mask):
            raise FilterError(f"{_listing(texts)}: each filter selects runs, but no run passes all of them")
        return runs[mask]

"""The interpreter behind a campaign's Python analyses (docs/python.md): `campaign report`,
`export` and `compare` keep a pool of these and send each one request per run and script.

Protocol: one JSON object per line on stdin, one answer per line on the stdout the process
started with. A request is {"run": DIR, "key": KEY, "script": PATH, "source": TEXT, "options":
{...}, "timeout": SECONDS}; the answer {"ok": true, "metrics": {name: [value, se, unit]}} or
{"ok": false, "error": TEXT, "retry": true when the failure may not happen again (a timeout)};
{"quit": true} ends the process. Before the first request the worker answers {"ready": true}
once it has imported granary (NumPy, pandas). A script still running after `timeout` seconds is stopped by
an alarm raised inside it (the pass itself stops the interpreter a little later if the alarm
cannot interrupt it, e.g. inside a long C call). The script's own printing goes to a buffer (fd 1 and 2 point elsewhere while it runs),
so nothing it writes can be taken for an answer; its last lines are part of a failure.

The script defines `analyse(run, options)` (or `analyze`), `run` a granary.Run, returning
{name: (value, se, unit)}: name of [a-z0-9_], value a finite number, se a number or None (no
estimate), unit a string ("1" for a pure number).
"""

import io
import json
import math
import os
import re
import signal
import sys
import tempfile
import traceback

_NAME = re.compile(r"^[a-z0-9_]+$")
_TAIL_LINES = 8


class AnalysisFailure(Exception):
    pass


class AnalysisTimeout(BaseException):
    """Raised inside the script when its time is up (a BaseException: `except Exception` in a
    script does not swallow it)."""


def _alarm(signum, frame):
    raise AnalysisTimeout()


def _tail(text, lines=_TAIL_LINES):
    rows = [r for r in text.rstrip().split("\n") if r.strip()]
    return "\n".join(rows[-lines:])


def check_metrics(value, key):
    """The script's return value as {name: [value, se, unit]}, or AnalysisFailure saying what
    is wrong with it."""
    if not isinstance(value, dict):
        raise AnalysisFailure(f"analyse() returned {type(value).__name__}, not a dict {{name: (value, se, unit)}}")
    if not value:
        raise AnalysisFailure("analyse() returned no metrics (an empty dict)")
    out = {}
    for name, entry in value.items():
        if not isinstance(name, str) or not _NAME.match(name):
            raise AnalysisFailure(f"metric name {name!r} is not made of a-z, 0-9 and _")
        if not isinstance(entry, (tuple, list)) or len(entry) != 3:
            raise AnalysisFailure(f"metric {name}: {entry!r} is not (value, se, unit)")
        v, se, unit = entry
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise AnalysisFailure(f"metric {name}: value {v!r} is not a number") from None
        if not math.isfinite(v):
            raise AnalysisFailure(f"metric {name}: value is {v} (a metric that is not defined for a run: leave it out)")
        if se is None:
            se = None
        else:
            try:
                se = float(se)
            except (TypeError, ValueError):
                raise AnalysisFailure(f"metric {name}: se {se!r} is not a number or None") from None
            if math.isnan(se):
                se = None
            elif not math.isfinite(se) or se < 0:
                raise AnalysisFailure(f"metric {name}: se is {se}")
        if not isinstance(unit, str):
            raise AnalysisFailure(f"metric {name}: unit {unit!r} is not a string")
        out[name] = [v, se, unit]
    return out


class Worker:
    def __init__(self):
        self._code = {}  # (path, source) -> compiled code

    def function_of(self, path, source):
        code = self._code.get((path, source))
        if code is None:
            code = compile(source, path, "exec")
            self._code = {(path, source): code}
        namespace = {"__name__": "granary_analysis_script", "__file__": path}
        exec(code, namespace)
        fn = namespace.get("analyse") or namespace.get("analyze")
        if not callable(fn):
            raise AnalysisFailure(f"{path} defines no function analyse(run, options)")
        return fn

    def handle(self, request):
        from . import open_run
        path, key = request["script"], request.get("key", "?")
        captured = tempfile.TemporaryFile(mode="w+b")
        saved = os.dup(1), os.dup(2)
        saved_streams = sys.stdout, sys.stderr
        text = io.StringIO()
        try:
            os.dup2(captured.fileno(), 1)
            os.dup2(captured.fileno(), 2)
            sys.stdout = sys.stderr = text
            timeout = float(request.get("timeout") or 0)
            try:
                if timeout > 0:
                    signal.signal(signal.SIGALRM, _alarm)
                    signal.setitimer(signal.ITIMER_REAL, timeout)
                try:
                    fn = self.function_of(path, request["source"])
                    run = open_run(request["run"])
                    metrics = check_metrics(fn(run, dict(request.get("options") or {})), key)
                finally:
                    if timeout > 0:
                        signal.setitimer(signal.ITIMER_REAL, 0)
                return {"ok": True, "metrics": metrics}
            except AnalysisTimeout as e:
                frames = [f for f in traceback.extract_tb(e.__traceback__) if f.filename != __file__]
                where = "".join(traceback.format_list(frames[-2:])).rstrip()
                return {"ok": False, "retry": True, "output": self._output(captured, text),
                        "error": f"{path}: analyse() ran longer than its timeout of {timeout:g} s "
                                 f"(/report/python/.../timeout); stopped at:\n{_tail(where, 4)}"}
            except AnalysisFailure as e:
                return {"ok": False, "error": f"{path}: {e}", "output": self._output(captured, text)}
            except BaseException as e:  # noqa: B902 (a script's SystemExit is a failure too)
                tb = traceback.format_exception(type(e), e, e.__traceback__)
                return {"ok": False, "error": _tail("".join(tb)), "output": self._output(captured, text)}
        finally:
            sys.stdout, sys.stderr = saved_streams
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            captured.close()

    @staticmethod
    def _output(captured, text):
        captured.flush()
        captured.seek(0)
        raw = captured.read().decode(errors="replace")
        return _tail(text.getvalue() + raw, 4)


def main():
    # Answers go to the stdout the process started with; everything else written to fd 1 (a
    # script's print, a C library's message) goes to stderr.
    answers = os.fdopen(os.dup(1), "w", encoding="utf-8")
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    # Imported before the first request, and said: the pass starts a script's clock (its
    # timeout) only once the interpreter is ready.
    import granary  # noqa: F401
    answers.write(json.dumps({"ready": True}) + "\n")
    answers.flush()
    worker = Worker()
    for line in sys.stdin:
        if not line.strip():
            continue
        try:
            request = json.loads(line)
            if isinstance(request, dict) and request.get("quit"):
                break
            answer = worker.handle(request)
        except Exception as e:  # a request the worker cannot read: say so, keep serving
            answer = {"ok": False, "error": f"granary.worker: bad request ({e})"}
        answers.write(json.dumps(answer, allow_nan=False) + "\n")
        answers.flush()


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Avalanche sizes of unclogging runs (discharge/on_clog "unclog"), counted from a run
directory's events.csv and unclogs.csv as the avalanches analysis counts them: the exits
between the first attempts on consecutive clogs, from the opening; the stretch after the last
unclog only if the run ended in a clog; a clog whose attempts no exit followed ends the
avalanche before them. Prints <s> +- se, sd/<s> and time units per clog for each directory,
and for a remove_arch run with unclog/fallback "kick" how many clogs a fallback kick met.
The command behind docs/benchmarks.md's clog_window tables; `campaign report` gives the same
sizes for runs of a campaign.

    scripts/avalanche-sizes.py RUN_DIR [RUN_DIR ...]
"""
import csv
import json
import math
import sys
from pathlib import Path


def sizes_of(run: Path):
    exits = [float(r["time"]) for r in csv.DictReader(open(run / "events.csv"))]
    cuts, seen, kicked = [], set(), set()
    for r in csv.DictReader(open(run / "unclogs.csv")):
        if r["method"] == "kick":
            kicked.add(r["clog"])
        if r["clog"] not in seen:
            seen.add(r["clog"])
            cuts.append(float(r["time"]))
    summary = json.load(open(run / "summary.json"))
    ended_clogged = summary["end_reason"] in ("clogged", "max_clogs")
    if ended_clogged and cuts and not any(t > cuts[-1] for t in exits):
        cuts.pop()  # the protocol could not break the last clog
    bounds = [0.0] + cuts + [math.inf]
    sizes = [sum(lo <= t < hi for t in exits) for lo, hi in zip(bounds[:-1], bounds[1:])]
    if not ended_clogged:
        sizes.pop()  # cut short by max_time: not an avalanche
    return sizes, summary, len(kicked)


for arg in sys.argv[1:]:
    s, summary, kicked = sizes_of(Path(arg))
    n = len(s)
    mean = sum(s) / n
    sd = math.sqrt(sum((v - mean) ** 2 for v in s) / (n - 1)) if n > 1 else math.nan
    clogs = max(1, len(s))
    print(f"{arg}: end {summary['end_reason']}, {n} avalanches, <s> = {mean:.1f} +- {sd / math.sqrt(n):.1f}, "
          f"sd/<s> = {sd / mean:.2f}, {summary['t_end'] / clogs:.1f} time units per clog")
    unclog = summary.get("spec", {}).get("discharge", {}).get("unclog", {})
    if unclog.get("method") == "remove_arch" and unclog.get("fallback") == "kick":
        print(f"  {kicked} clogs met a fallback kick (remove_arch found no arch)")

#!/usr/bin/env python3
"""Mean of a maps figure's cells over a rectangle, per panel: the command behind the region
values docs/reproduction.md quotes from a report's maps (e.g. phi under the obstacle in
ch4-obstacle-maps-medium). Reads the figure's panel files report/data/figure-<name>-<k>.csv
(columns x, y, <value>, n_frames, as `campaign report` writes them) and prints, for each
panel k in the figure's order, the mean of the cells whose centres lie inside the rectangle.

    scripts/map-region-means.py REPORT_DIR FIGURE X_LO X_HI Y_LO Y_HI
    scripts/map-region-means.py runs/report fig-4.18 -4 4 8 14
"""
import csv
import math
import sys
from pathlib import Path


def main(argv):
    if len(argv) != 7:
        sys.exit(__doc__)
    report, figure = Path(argv[1]), argv[2]
    x_lo, x_hi, y_lo, y_hi = (float(a) for a in argv[3:7])
    # The panels' files end in their number; the walls' and obstacles' files beside them do not.
    panels = sorted((p for p in (report / "data").glob(f"figure-{figure}-*.csv") if p.stem.rsplit("-", 1)[1].isdigit()),
                    key=lambda p: int(p.stem.rsplit("-", 1)[1]))
    if not panels:
        sys.exit(f"{report / 'data'}: no figure-{figure}-K.csv (is {figure} a maps figure of this report?)")
    for path in panels:
        with path.open() as f:
            rows = list(csv.reader(f))
        value = rows[0][2]
        cells = [float(r[2]) for r in rows[1:]
                 if x_lo < float(r[0]) < x_hi and y_lo < float(r[1]) < y_hi and r[2] and not math.isnan(float(r[2]))]
        mean = sum(cells) / len(cells) if cells else float("nan")
        print(f"{path.name}: {value} mean {mean:.4g} over {len(cells)} cells")


if __name__ == "__main__":
    main(sys.argv)

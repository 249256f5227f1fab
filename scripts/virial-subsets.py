#!/usr/bin/env python3
"""How much a region's contact (virial) pressure moves with which contact frames are kept.

usage: virial-subsets.py RUN_DIR X_HALF Y_TOP T_FROM EVERY

Reads RUN_DIR/contacts.dump (text), sums f.r / (2 A) over the contacts whose contact point lies
in |x| < X_HALF, 0 < y < Y_TOP, for each contact frame from time T_FROM on, and prints the mean,
the frame-to-frame sd/mean, the means of the EVERY disjoint every-EVERY-th-frame subsets
relative to the mean of all, and their spread (docs/benchmarks.md, the full-size ch. 4 run).
"""
import sys

import numpy as np


def main():
    run, x_half, y_top, t_from, every = sys.argv[1], *map(float, sys.argv[2:5]), int(sys.argv[5])
    area = 2 * x_half * y_top
    times, pressure = [], []
    for block in open(f"{run}/contacts.dump").read().split("ITEM: TIME\n")[1:]:
        head, _, body = block.partition("fx fy\n")
        a = np.fromstring(body, sep=" ").reshape(-1, 10)  # body_i body_j xi yi xj yj cx cy fx fy
        b = a[(np.abs(a[:, 6]) < x_half) & (a[:, 7] > 0) & (a[:, 7] < y_top)]
        times.append(float(head.split("\n")[0]))
        pressure.append(np.sum(b[:, 8] * (b[:, 2] - b[:, 4]) + b[:, 9] * (b[:, 3] - b[:, 5])) / (2 * area))
    p = np.array(pressure)[np.array(times) >= t_from]
    subsets = np.array([p[k::every].mean() for k in range(every)]) / p.mean()
    print(f"frames {len(p)}  mean {p.mean():.4g}  sd/mean {p.std(ddof=1) / p.mean():.2f}")
    print("subset means / mean:", " ".join(f"{x:.3f}" for x in subsets), f" spread {subsets.std(ddof=1):.3f}")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""freud's density.RDF on the points `pillar-pipe bench gofr` wrote, timed in-process
(the compute call only, after import and load), for the same-run comparison with
pillar-pipe's g(r).

    python3 bench/freud_gofr.py DIR R_MAX BINS REPS

DIR holds x.npy, y.npy (positions in a periodic box [0, LX) x [0, LY)) and box.npy
([LX, LY]). Prints one JSON line: {"seconds": [...], "freud": version, "g_peak": ...}.
Needs `pip install freud-analysis` (3.4.0 was used for docs/performance.md).
"""
import json
import sys
import time

import numpy as np
import freud


def main():
    d, r_max, bins, reps = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    x, y = np.load(f"{d}/x.npy"), np.load(f"{d}/y.npy")
    lx, ly = np.load(f"{d}/box.npy")
    box = freud.box.Box(Lx=lx, Ly=ly, is2D=True)
    # freud's boxes are centred on the origin.
    pts = np.column_stack([x - lx / 2, y - ly / 2, np.zeros(len(x))]).astype(np.float32)
    pts = box.wrap(pts)
    seconds = []
    for _ in range(reps):
        rdf = freud.density.RDF(bins=bins, r_max=r_max)
        t = time.perf_counter()
        rdf.compute(system=(box, pts), reset=True)
        seconds.append(time.perf_counter() - t)
    print(json.dumps({"seconds": seconds, "freud": freud.__version__,
                      "g_peak": float(np.max(rdf.rdf))}))


if __name__ == "__main__":
    main()

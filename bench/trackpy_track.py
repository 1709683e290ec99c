#!/usr/bin/env python3
"""trackpy's whole tracking of a movie, as an experimentalist runs it: import, read the
frames, `tp.batch` (locate + refine on every frame) and `tp.link`, write the tracks
CSV. `pillar-pipe bench track` times this whole process beside `pillar-pipe track`
on the same frames with the same settings.

    python3 bench/trackpy_track.py FRAMES_DIR OUT.csv DIAMETER MINMASS SEPARATION \
        NOISE_SIZE SEARCH_RANGE MEMORY PROCESSES

PROCESSES is trackpy's `batch(processes=...)` (use the cores pillar-pipe used).
Prints one JSON line: {"trackpy": version, "numba": bool, "features": n,
"seconds_batch": s, "seconds_link": s}. Needs `pip install trackpy pillow`.
"""
import glob
import json
import os
import sys
import time


def main():
    (d, out, diameter, minmass, separation, noise_size, search_range, memory,
     processes) = sys.argv[1:10]
    import numpy as np
    import trackpy as tp
    from PIL import Image
    try:
        import numba  # noqa: F401
        have_numba = True
    except ImportError:
        have_numba = False
    tp.quiet()
    names = sorted(
        [p for p in glob.glob(os.path.join(d, "*")) if p.lower().endswith((".png", ".tif", ".tiff"))]
    )
    frames = [np.array(Image.open(p)) for p in names]
    t0 = time.perf_counter()
    f = tp.batch(frames, int(diameter), minmass=float(minmass), separation=float(separation),
                 noise_size=float(noise_size), processes=int(processes))
    t1 = time.perf_counter()
    t = tp.link(f, float(search_range), memory=int(memory))
    t2 = time.perf_counter()
    t.to_csv(out, index=False)
    print(json.dumps({"trackpy": tp.__version__, "numba": have_numba, "features": len(t),
                      "seconds_batch": t1 - t0, "seconds_link": t2 - t1}))


if __name__ == "__main__":
    main()

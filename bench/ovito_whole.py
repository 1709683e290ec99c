#!/usr/bin/env python3
"""OVITO's Atomic Strain as a whole process, as a user runs it: start Python, import
OVITO, load two frames (.npy files, what a script would have saved), compute, save
D2min. `pillar-pipe bench kinematics-whole` times this against the whole
`pillar-pipe kinematics` command, alternately; it writes the .npy files itself.

    python3 bench/ovito_whole.py DIR OUT.npy [CUTOFF]

DIR holds x0.npy y0.npy id0.npy x1.npy y1.npy id1.npy (frame 0 = reference).
Needs `pip install ovito` (3.17 was used for the figures in docs/performance.md).
"""
import sys

import numpy as np
from ovito.data import DataCollection
from ovito.modifiers import AtomicStrainModifier
from ovito.pipeline import Pipeline, StaticSource


def frame(d, k, lo, hi):
    dc = DataCollection()
    x, y = np.load(f"{d}/x{k}.npy"), np.load(f"{d}/y{k}.npy")
    cell = dc.create_cell([[hi[0] - lo[0], 0, 0], [0, hi[1] - lo[1], 0], [0, 0, 1]],
                          pbc=(False, False, False))
    dc.cell_[:, 3] = (lo[0], lo[1], -0.5)
    dc.cell_.is2D = True
    p = dc.create_particles(count=len(x))
    p.create_property("Position", data=np.column_stack([x, y, np.zeros(len(x))]))
    p.create_property("Particle Identifier", data=np.load(f"{d}/id{k}.npy"))
    return dc


def main():
    d, out = sys.argv[1], sys.argv[2]
    cutoff = float(sys.argv[3]) if len(sys.argv) > 3 else 1.25
    xs = [np.load(f"{d}/x{k}.npy") for k in (0, 1)]
    ys = [np.load(f"{d}/y{k}.npy") for k in (0, 1)]
    lo = (min(v.min() for v in xs) - 5, min(v.min() for v in ys) - 5)
    hi = (max(v.max() for v in xs) + 5, max(v.max() for v in ys) + 5)
    pipe = Pipeline(source=StaticSource(data=frame(d, 1, lo, hi)))
    m = AtomicStrainModifier(cutoff=cutoff, output_nonaffine_squared_displacements=True)
    m.reference = StaticSource(data=frame(d, 0, lo, hi))
    pipe.modifiers.append(m)
    data = pipe.compute()
    np.save(out, np.asarray(data.particles["Nonaffine Squared Displacement"]))


if __name__ == "__main__":
    main()

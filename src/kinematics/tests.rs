//! Closed-form checks of the kernel (issue 3, "Correctness").

use super::*;
use crate::synth::{bidisperse_packing, sheared_periodic_tracks, two_frame_tracks};
use crate::tracks::Tracks;

const RC: f64 = 1.25;

fn params(conv: Convention) -> KinematicsParams {
    KinematicsParams {
        rc: RC,
        convention: conv,
    }
}

fn run(t: &Tracks, conv: Convention) -> (Vec<ParticleKinematics>, PairCounts) {
    let fr = t.frame_ranges();
    let a = t.view(fr[0].0, fr[0].1.clone());
    let b = t.view(fr[1].0, fr[1].1.clone());
    frame_pair(&a, &b, 1.0, &params(conv)).unwrap()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + b.abs())
}

#[test]
fn pure_affine_map_is_recovered_exactly() {
    let p = bidisperse_packing(900, 1.0, 0.1, 1);
    let f = Mat2::new(1.03, 0.07, -0.02, 0.95);
    let t = two_frame_tracks(&p, f, 0.0, 0);
    let (ks, c) = run(&t, Convention::Paper);
    assert_eq!(c.paired, p.pos.len());
    let want = strain_from_j(&f, Convention::Paper);
    for k in &ks {
        assert!(k.valid, "{k:?}");
        // Every particle, edge ones included: an affine map is affine for any neighbourhood.
        assert!((k.j - f).frobenius2() < 1e-24, "{:?}", k.j);
        assert!(k.d2min < 1e-24, "{}", k.d2min);
        assert!(close(k.strain.eta_s, want.eta_s, 1e-12));
        assert!(close(k.strain.eta_m, want.eta_m, 1e-12));
    }
}

#[test]
fn simple_shear_closed_form() {
    let p = bidisperse_packing(400, 1.0, 0.1, 2);
    for gamma in [1e-4, 0.01, 0.1, 0.5] {
        let f = Mat2::new(1.0, gamma, 0.0, 1.0);
        let (ks, _) = run(&two_frame_tracks(&p, f, 0.0, 0), Convention::Paper);
        // η = ½[[0, γ], [γ, γ²]]: η^s = (γ/2)√(1 + γ²/4), η^m = γ²/4.
        let eta_s = 0.5 * gamma * (1.0 + 0.25 * gamma * gamma).sqrt();
        for k in &ks {
            assert!(
                close(k.strain.eta_s, eta_s, 1e-10),
                "{} vs {eta_s}",
                k.strain.eta_s
            );
            assert!(close(k.strain.eta_m, 0.25 * gamma * gamma, 1e-9));
            assert!(close(k.strain.eta_xy, 0.5 * gamma, 1e-10));
            assert!(close(k.j2, eta_s, 1e-10)); // Δt = 1
        }
        // OVITO's shear strain: √(η_xy² + (η_xx − η_yy)²/2) = √(γ²/4 + γ⁴/8).
        let (ko, _) = run(&two_frame_tracks(&p, f, 0.0, 0), Convention::Ovito);
        let ov = (0.25 * gamma * gamma + gamma.powi(4) / 8.0).sqrt();
        assert!(ko.iter().all(|k| close(k.strain.eta_s, ov, 1e-10)));
    }
}

#[test]
fn rigid_rotation_and_translation_have_no_strain() {
    let p = bidisperse_packing(400, 1.0, 0.1, 3);
    let f = Mat2::rotation(0.4);
    let mut t = two_frame_tracks(&p, f, 0.0, 0);
    for r in t.len() / 2..t.len() {
        t.x[r] += 3.7;
        t.y[r] -= 1.2;
    }
    let (ks, _) = run(&t, Convention::Paper);
    for k in &ks {
        assert!(k.strain.eta_s < 1e-12 && k.strain.eta_m.abs() < 1e-12);
        assert!(k.d2min < 1e-20);
    }
}

/// Perfect triangular lattice (spacing a): the 6 nearest neighbours are symmetric, so
/// displacing particle i by δ gives J_i = I, D²min_i = |δ|² (÷N_i) and for a neighbour
/// j of i the closed form |δ|² [Σ_{k≠i} (uᵀY⁻¹r_k)² + (1 − uᵀY⁻¹u)²] / N_j, u = r_i − r_j.
#[test]
fn one_displaced_particle_closed_form() {
    let p = bidisperse_packing(400, 1.0, 0.0, 4);
    let a = p.spacing;
    let mut t = two_frame_tracks(&p, Mat2::IDENTITY, 0.0, 0);
    let n = p.pos.len();
    let centre = Vec2::new(
        p.simbox.x_lo + 0.5 * p.simbox.lx,
        p.simbox.y_lo + 0.5 * p.simbox.ly,
    );
    let i = (0..n)
        .min_by(|&u, &v| {
            (p.pos[u] - centre)
                .norm2()
                .total_cmp(&(p.pos[v] - centre).norm2())
        })
        .unwrap();
    let delta = Vec2::new(0.03, -0.02);
    t.x[n + i] += delta.x;
    t.y[n + i] += delta.y;
    let (ks, _) = run(&t, Convention::Paper);
    let ki = ks[i];
    assert_eq!(ki.n_neighbors, 6);
    assert!((ki.j - Mat2::IDENTITY).frobenius2() < 1e-24);
    assert!(
        close(ki.d2min, delta.norm2(), 1e-12),
        "{} vs {}",
        ki.d2min,
        delta.norm2()
    );
    let (ko, _) = run(&t, Convention::Ovito);
    assert!(close(ko[i].d2min, 6.0 * delta.norm2(), 1e-12));
    // A neighbour j of i.
    let j = (0..n)
        .find(|&j| j != i && ((p.pos[j] - p.pos[i]).norm() - a).abs() < 1e-9)
        .unwrap();
    let rel: Vec<(usize, Vec2)> = (0..n)
        .filter(|&k| k != j && (p.pos[k] - p.pos[j]).norm() < RC)
        .map(|k| (k, p.pos[k] - p.pos[j]))
        .collect();
    let y = rel
        .iter()
        .fold(Mat2::ZERO, |m, &(_, r)| m + Mat2::outer(r, r));
    let yinv = y.inverse(1e-12).unwrap();
    let u = p.pos[i] - p.pos[j];
    let g = yinv * u; // Y⁻¹u (Y symmetric)
    let mut s = 0.0;
    for &(k, r) in &rel {
        s += if k == i {
            (1.0 - g.dot(r)).powi(2)
        } else {
            g.dot(r).powi(2)
        };
    }
    let want = delta.norm2() * s / rel.len() as f64;
    assert!(close(ks[j].d2min, want, 1e-10), "{} vs {want}", ks[j].d2min);
    assert!(ks[j].d2min > 0.0);
}

#[test]
fn invariant_under_rigid_motion_and_relabelling() {
    let p = bidisperse_packing(900, 1.0, 0.12, 5);
    let f = Mat2::new(1.0, 0.05, 0.0, 0.98);
    let t = two_frame_tracks(&p, f, 0.02, 9);
    let (base, _) = run(&t, Convention::Paper);
    // Rotate and translate both frames by the same rigid motion.
    let rot = Mat2::rotation(1.1);
    let mut u = t.clone();
    for r in 0..u.len() {
        let q = rot * Vec2::new(t.x[r], t.y[r]) + Vec2::new(-40.0, 17.0);
        u.x[r] = q.x;
        u.y[r] = q.y;
    }
    let (moved, _) = run(&u, Convention::Paper);
    // Reverse the particle ids (rows re-sorted as finalize would).
    let mut v = t.clone();
    let n = p.pos.len() as i64;
    for r in 0..v.len() {
        v.particle[r] = n - 1 - v.particle[r];
    }
    let mut perm: Vec<usize> = (0..v.len()).collect();
    perm.sort_by_key(|&r| (v.frame[r], v.particle[r]));
    v.permute(&perm);
    let (relab, _) = run(&v, Convention::Paper);
    for (k, b) in base.iter().enumerate() {
        let m = &moved[k];
        assert_eq!(b.n_neighbors, m.n_neighbors);
        assert!(close(b.d2min, m.d2min, 1e-8), "{} {}", b.d2min, m.d2min);
        assert!(close(b.strain.eta_s, m.strain.eta_s, 1e-8));
        assert!(close(b.strain.eta_m, m.strain.eta_m, 1e-8));
        let r = &relab[(n - 1 - b.particle) as usize];
        assert_eq!(r.particle, n - 1 - b.particle);
        // Relabelling reorders the neighbour sums: equal to round-off.
        assert!(close(b.d2min, r.d2min, 1e-12));
        assert!(close(b.strain.eta_s, r.strain.eta_s, 1e-12));
    }
}

#[test]
fn identical_for_any_thread_count() {
    let p = bidisperse_packing(5000, 1.0, 0.12, 6);
    let t = two_frame_tracks(&p, Mat2::new(1.0, 0.05, 0.0, 0.98), 0.02, 9);
    let go = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| run(&t, Convention::Paper))
    };
    let (a, _) = go(1);
    let (b, _) = go(2);
    let (c, _) = go(3);
    assert_eq!(a, b);
    assert_eq!(a, c);
}

/// Lees–Edwards: a lattice already sheared by γ0 (box offset γ0 L_y), sheared by γ more
/// and moved up so that rows cross the y boundary. Every particle, those whose
/// neighbours lie across the boundary included, has J = [[1, γ], [0, 1]], D²min = 0.
#[test]
fn lees_edwards_neighbours_and_unwrapping() {
    let p = bidisperse_packing(600, 1.0, 0.1, 7);
    let gamma = 0.04;
    let t = sheared_periodic_tracks(&p, 0.3, gamma, 0.37 * p.simbox.ly * 0.2);
    let (ks, c) = run(&t, Convention::Paper);
    assert_eq!(c.paired, p.pos.len());
    let want = Mat2::new(1.0, gamma, 0.0, 1.0);
    let mut near_edge = 0;
    for k in &ks {
        assert!(k.valid);
        assert!(
            (k.j - want).frobenius2() < 1e-20,
            "{:?} at {:?}",
            k.j,
            k.pos
        );
        assert!(k.d2min < 1e-20);
        near_edge += usize::from(k.pos.y < p.simbox.y_lo + RC);
    }
    assert!(near_edge > 10);
    // Same neighbour counts as the unsheared periodic lattice: no neighbour lost at the seam.
    let flat = sheared_periodic_tracks(&p, 0.0, 0.0, 0.0);
    let (kf, _) = run(&flat, Convention::Paper);
    let total: u32 = ks.iter().map(|k| k.n_neighbors).sum();
    let total_flat: u32 = kf.iter().map(|k| k.n_neighbors).sum();
    // Shearing the lattice by 0.3 changes who is within R_c, but both counts are bulk-like.
    assert!(
        ks.iter().all(|k| k.n_neighbors >= 4),
        "lost neighbours at the seam"
    );
    assert!(total > 0 && total_flat > 0);
}

#[test]
fn isolated_collinear_and_missing_particles_are_counted() {
    let mut t = Tracks::default();
    // frame 0: a lone particle (0), three on a line (1..3), one missing at t+Δt (4).
    let pts = [
        (0.0, 0.0),
        (10.0, 0.0),
        (11.0, 0.0),
        (12.0, 0.0),
        (30.0, 0.0),
    ];
    for f in 0..2i64 {
        for (id, &(x, y)) in pts.iter().enumerate() {
            if f == 1 && id == 4 {
                continue;
            }
            t.frame.push(f);
            t.particle.push(id as i64);
            t.x.push(x + 0.01 * f as f64);
            t.y.push(y);
            t.radius.push(0.5);
        }
    }
    t.frame.push(1);
    t.particle.push(5);
    t.x.push(50.0);
    t.y.push(0.0);
    t.radius.push(0.5);
    let (ks, c) = run(&t, Convention::Paper);
    assert_eq!(c.paired, 4);
    assert_eq!(c.missing_at_end, 1);
    assert_eq!(c.missing_at_start, 1);
    assert_eq!(c.invalid_few_neighbors, 3); // 0 (none), 1 and 3 (one each)
    assert_eq!(c.invalid_singular, 1); // 2: two neighbours on a line
    for k in &ks {
        assert!(!k.valid && k.status != Status::Ok);
        // Undetermined, not zero: NaN in every derived field.
        assert!(k.d2min.is_nan() && k.strain.eta_s.is_nan() && k.j.a12.is_nan() && k.j2.is_nan());
        assert!(close(k.velocity.x, 0.01, 1e-9));
    }
    let singular = ks.iter().filter(|k| k.status == Status::Singular).count();
    let few = ks
        .iter()
        .filter(|k| k.status == Status::TooFewNeighbours)
        .count();
    assert_eq!((few, singular), (3, 1));
}

/// The columns the `kinematics` command writes are the per-particle records, row for
/// row and bit for bit (NaN where undetermined), whatever the thread count and across
/// several row blocks.
#[test]
fn columns_equal_the_records_bit_for_bit_at_any_thread_count() {
    let p = bidisperse_packing(7000, 1.0, 0.12, 11);
    let src = two_frame_tracks(&p, Mat2::new(1.0, 0.04, 0.01, 0.97), 0.03, 5);
    // The same rows plus, in each frame, a lone particle far away (too few neighbours).
    let mut t = Tracks::default();
    for (f, r) in src.frame_ranges() {
        for i in r {
            t.frame.push(f);
            t.particle.push(src.particle[i]);
            t.x.push(src.x[i]);
            t.y.push(src.y[i]);
            t.radius.push(src.radius[i]);
        }
        t.frame.push(f);
        t.particle.push(1_000_000);
        t.x.push(1e4);
        t.y.push(1e4);
        t.radius.push(0.5);
    }
    let fr = t.frame_ranges();
    let a = t.view(fr[0].0, fr[0].1.clone());
    let b = t.view(fr[1].0, fr[1].1.clone());
    let (ks, counts) = frame_pair(&a, &b, 0.5, &params(Convention::Paper)).unwrap();
    assert!(ks.len() > 3 * 2048, "several row blocks");
    assert_eq!(counts.invalid_few_neighbors, 1);
    // Each column named in the table, read from the record's own field.
    let field = |name: &str, k: &ParticleKinematics| -> f64 {
        match name {
            "x" => k.pos.x,
            "y" => k.pos.y,
            "j11" => k.j.a11,
            "j12" => k.j.a12,
            "j21" => k.j.a21,
            "j22" => k.j.a22,
            "eta_xx" => k.strain.eta_xx,
            "eta_xy" => k.strain.eta_xy,
            "eta_yy" => k.strain.eta_yy,
            "eta_m" => k.strain.eta_m,
            "eta_s" => k.strain.eta_s,
            "j2" => k.j2,
            "d2min" => k.d2min,
            "vx" => k.velocity.x,
            "vy" => k.velocity.y,
            "speed" => k.velocity.norm(),
            other => panic!("unknown column {other}"),
        }
    };
    for threads in [1, 2, 3] {
        let (c, cc) = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| frame_pair_columns(&a, &b, 0.5, &params(Convention::Paper)))
            .unwrap();
        assert_eq!(cc, counts);
        assert_eq!(c.len(), ks.len());
        for (r, k) in ks.iter().enumerate() {
            assert_eq!(
                (
                    c.particle[r],
                    c.species[r],
                    c.n_neighbors[r] as u32,
                    c.valid[r],
                    c.status[r]
                ),
                (k.particle, k.species, k.n_neighbors, k.valid, k.status),
                "row {r}"
            );
            for (col, name) in F64_COLUMNS.iter().enumerate() {
                assert_eq!(
                    c.f64s[col][r].to_bits(),
                    field(name, k).to_bits(),
                    "row {r} column {name}, {threads} threads"
                );
            }
        }
    }
}

/// A large pair whose rows are in no spatial order has its fits computed in cell
/// order; every row is bit for bit what the row-order search gives, in an open box
/// and across a Lees–Edwards seam. Pairs in lattice order keep the row-order search.
#[test]
fn fits_in_cell_order_are_the_row_order_fits_bit_for_bit() {
    let p = bidisperse_packing(40_000, 1.0, 0.1, 11);
    let open = two_frame_tracks(&p, Mat2::new(1.01, 0.03, -0.01, 0.99), 0.02, 3);
    let sheared = sheared_periodic_tracks(&p, 0.3, 0.04, 0.37 * p.simbox.ly * 0.2);
    for (t, seam) in [(open, false), (sheared, true)] {
        let setup_of = |t: &Tracks| {
            let fr = t.frame_ranges();
            let a = t.view(fr[0].0, fr[0].1.clone());
            let b = t.view(fr[1].0, fr[1].1.clone());
            PairSetup::new(&a, &b, &params(Convention::Paper)).unwrap()
        };
        assert!(setup_of(&t).fits.is_none(), "lattice order: row order");
        let mut s = crate::synth::relabelled(&t);
        if !seam {
            // A few isolated particles at t (too few neighbours: the undetermined rows).
            for r in 0..s.len() {
                if s.frame[r] == 0 && s.particle[r] % 4999 == 7 {
                    s.x[r] += 1e6 * (1.0 + s.particle[r] as f64);
                }
            }
        }
        let setup = setup_of(&s);
        assert!(setup.fits.is_some(), "no spatial order: cell order");
        assert_eq!(setup.seam.is_some(), seam);
        assert!(setup.len() >= CELL_ORDER_MIN_ROWS);
        let fr = s.frame_ranges();
        let a = s.view(fr[0].0, fr[0].1.clone());
        assert!(setup.cells.is_none(), "the search's arrays are freed");
        // The row-order search, on its own cell list.
        let cells = CellList::new(&setup.pos0, RC, Cutoff::Strict, a.simbox).unwrap();
        let disp_sorted: Vec<Vec2> = cells
            .cell_order()
            .iter()
            .map(|&j| setup.disp[j as usize])
            .collect();
        let mut buf = Vec::new();
        let mut undetermined = 0;
        for n in 0..setup.len() {
            let got = setup.particle(n, &a, &mut buf, 1.0, Convention::Paper);
            let f = fit(
                (n, setup.pos0[n], setup.disp[n]),
                (&setup.pos0, Index::Rows),
                &disp_sorted,
                &cells,
                setup.seam,
                &mut buf,
                Convention::Paper,
            );
            let mut want = row(f, setup.pos0[n], setup.disp[n], 1.0, Convention::Paper);
            let (i, _) = setup.pairs[n];
            want.particle = a.particle[i];
            want.species = a.species.map_or(UNKNOWN_SPECIES, |s| s[i]);
            // Debug prints each float's shortest round-trip form: equal text, equal bits.
            assert_eq!(format!("{got:?}"), format!("{want:?}"), "row {n}");
            undetermined += usize::from(!got.valid);
        }
        assert!(undetermined < setup.len() / 100);
        assert_eq!(
            undetermined > 0,
            !seam,
            "the undetermined rows are compared too"
        );
    }
}

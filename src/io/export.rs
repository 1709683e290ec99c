//! Snapshots for the viewers users already have: extended XYZ (OVITO, ASE, VMD) and
//! LAMMPS text dumps (OVITO, LAMMPS itself), one frame per snapshot, every per-particle
//! column as a property.
//!
//! - **extxyz**: a count line, then a comment line of `key=value` pairs — `Lattice` (the
//!   three cell vectors row by row; a = (L_x, 0, 0), b = (xy, L_y, 0) for a Lees–Edwards
//!   box with offset xy, c = (0, 0, 1) for a 2D system), `Origin`, `pbc`, `Properties`
//!   (`name:type:columns`, `pos:R:3` with z = 0 as ASE requires), `Time`, `frame` — and
//!   one line per particle. A frame without a periodic box has no `Lattice` and
//!   `pbc="F F F"`.
//! - **LAMMPS dump**: `ITEM: TIMESTEP` (the frame index), `ITEM: NUMBER OF ATOMS`,
//!   `ITEM: BOX BOUNDS` (`xy xz yz` and the bounding-box form LAMMPS writes for a tilted
//!   box: xlo_bound = xlo + min(0, xy), xhi_bound = xhi + max(0, xy)), `pp` or `ff` per
//!   axis, and `ITEM: ATOMS id type x y z radius …` (type 1 small, 2 large, as the
//!   ingest reads them back).
//!
//! Numbers are written with Rust's shortest round-trip formatting, so a file read back
//! gives every position and property bit for bit; a particle without kinematics has
//! `NaN` there (as Python, OVITO and LAMMPS parse it).

use std::fmt::Write as _;
use std::io::Write;

/// The box of one frame (length unit): lower corner, sides, Lees–Edwards offset, and
/// whether each axis is periodic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    pub lo: (f64, f64),
    pub l: (f64, f64),
    pub xy: f64,
    pub periodic: (bool, bool),
}

/// One frame to write: ids, positions, radii, species (0 small, 1 large, or none), the
/// velocity (or none) and named float properties, each as long as `id`.
pub struct Snapshot<'a> {
    pub frame: i64,
    pub time: Option<f64>,
    pub cell: Option<Cell>,
    pub id: &'a [i64],
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub radius: &'a [f64],
    pub species: Option<&'a [i32]>,
    pub velocity: Option<(&'a [f64], &'a [f64])>,
    pub props: &'a [(String, Vec<f64>)],
}

/// The formats `export` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Format {
    /// Extended XYZ (OVITO, ASE).
    Extxyz,
    /// LAMMPS text dump (OVITO, LAMMPS).
    LammpsDump,
}

/// The bounding box of the positions (open frames), padded by the largest radius.
fn bounds(s: &Snapshot) -> Cell {
    let rmax = s.radius.iter().copied().fold(0.0, f64::max);
    let fold = |v: &[f64]| {
        v.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            })
    };
    let ((x0, x1), (y0, y1)) = (fold(s.x), fold(s.y));
    let (x0, x1, y0, y1) = if s.x.is_empty() {
        (0.0, 1.0, 0.0, 1.0)
    } else {
        (x0 - rmax, x1 + rmax, y0 - rmax, y1 + rmax)
    };
    Cell {
        lo: (x0, y0),
        l: (x1 - x0, y1 - y0),
        xy: 0.0,
        periodic: (false, false),
    }
}

/// One snapshot in extended XYZ.
pub fn write_extxyz(w: &mut impl Write, s: &Snapshot) -> std::io::Result<()> {
    let n = s.id.len();
    let mut head = String::new();
    let cell = s.cell.filter(|c| c.periodic.0 || c.periodic.1);
    if let Some(c) = cell {
        let _ = write!(
            head,
            "Lattice=\"{} 0 0 {} {} 0 0 0 1\" Origin=\"{} {} 0\" ",
            c.l.0, c.xy, c.l.1, c.lo.0, c.lo.1
        );
    }
    let (px, py) = cell.map_or((false, false), |c| c.periodic);
    let tf = |b: bool| if b { "T" } else { "F" };
    let _ = write!(head, "pbc=\"{} {} F\" ", tf(px), tf(py));
    head.push_str("Properties=id:I:1");
    if s.species.is_some() {
        // `type`, not `species`: OVITO maps either to Particle Type, but ASE reads a
        // `species` column as element symbols and fails on numbers.
        head.push_str(":type:I:1");
    }
    head.push_str(":pos:R:3:radius:R:1");
    if s.velocity.is_some() {
        head.push_str(":velo:R:3");
    }
    for (name, _) in s.props {
        let _ = write!(head, ":{name}:R:1");
    }
    if let Some(t) = s.time {
        let _ = write!(head, " Time={t}");
    }
    let _ = write!(head, " frame={}", s.frame);
    writeln!(w, "{n}\n{head}")?;
    let mut line = String::new();
    for i in 0..n {
        line.clear();
        let _ = write!(line, "{}", s.id[i]);
        if let Some(sp) = s.species {
            // 1 small, 2 large: OVITO's type ids, as in the LAMMPS dump.
            let _ = write!(line, " {}", if sp[i] == 1 { 2 } else { 1 });
        }
        let _ = write!(line, " {} {} 0 {}", s.x[i], s.y[i], s.radius[i]);
        if let Some((vx, vy)) = s.velocity {
            let _ = write!(line, " {} {} 0", vx[i], vy[i]);
        }
        for (_, v) in s.props {
            let _ = write!(line, " {}", v[i]);
        }
        writeln!(w, "{line}")?;
    }
    Ok(())
}

/// One snapshot as a LAMMPS text dump.
pub fn write_lammps_dump(w: &mut impl Write, s: &Snapshot) -> std::io::Result<()> {
    let n = s.id.len();
    let c = s.cell.unwrap_or_else(|| bounds(s));
    let pf = |b: bool| if b { "pp" } else { "ff" };
    let (xlo, ylo) = c.lo;
    let (xhi, yhi) = (xlo + c.l.0, ylo + c.l.1);
    writeln!(w, "ITEM: TIMESTEP\n{}\nITEM: NUMBER OF ATOMS\n{n}", s.frame)?;
    if c.xy != 0.0 {
        writeln!(
            w,
            "ITEM: BOX BOUNDS xy xz yz {} {} ff\n{} {} {}\n{ylo} {yhi} 0\n-0.5 0.5 0",
            pf(c.periodic.0),
            pf(c.periodic.1),
            xlo + c.xy.min(0.0),
            xhi + c.xy.max(0.0),
            c.xy
        )?;
    } else {
        writeln!(
            w,
            "ITEM: BOX BOUNDS {} {} ff\n{xlo} {xhi}\n{ylo} {yhi}\n-0.5 0.5",
            pf(c.periodic.0),
            pf(c.periodic.1)
        )?;
    }
    let mut head = String::from("ITEM: ATOMS id type x y z radius");
    if s.velocity.is_some() {
        head.push_str(" vx vy vz");
    }
    for (name, _) in s.props {
        head.push(' ');
        head.push_str(name);
    }
    writeln!(w, "{head}")?;
    let mut line = String::new();
    for i in 0..n {
        line.clear();
        // type 1 small, 2 large (the ingest's convention); 1 when unknown.
        let ty = s.species.map_or(1, |sp| if sp[i] == 1 { 2 } else { 1 });
        let _ = write!(
            line,
            "{} {ty} {} {} 0 {}",
            s.id[i], s.x[i], s.y[i], s.radius[i]
        );
        if let Some((vx, vy)) = s.velocity {
            let _ = write!(line, " {} {} 0", vx[i], vy[i]);
        }
        for (_, v) in s.props {
            let _ = write!(line, " {}", v[i]);
        }
        writeln!(w, "{line}")?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn snap<'a>(props: &'a [(String, Vec<f64>)], cell: Option<Cell>) -> Snapshot<'a> {
        Snapshot {
            frame: 3,
            time: Some(0.5),
            cell,
            id: &[7, 9],
            x: &[0.1, 2.5],
            y: &[1.0, -0.25],
            radius: &[0.5, 0.7],
            species: Some(&[0, 1]),
            velocity: Some((&[1e-3, f64::NAN], &[0.0, 2.0])),
            props,
        }
    }

    #[test]
    fn extxyz_has_the_lattice_properties_and_exact_numbers() {
        let props = vec![("d2min".to_string(), vec![0.125, 1.0 / 3.0])];
        let cell = Cell {
            lo: (0.0, 0.0),
            l: (10.0, 12.0),
            xy: 1.5,
            periodic: (true, true),
        };
        let mut out = Vec::new();
        write_extxyz(&mut out, &snap(&props, Some(cell))).unwrap();
        let text = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "2");
        assert!(
            lines[1].contains("Lattice=\"10 0 0 1.5 12 0 0 0 1\""),
            "{}",
            lines[1]
        );
        assert!(lines[1].contains("pbc=\"T T F\""));
        assert!(
            lines[1].contains("Properties=id:I:1:type:I:1:pos:R:3:radius:R:1:velo:R:3:d2min:R:1")
        );
        assert!(lines[1].contains("Time=0.5") && lines[1].contains("frame=3"));
        let f: Vec<&str> = lines[3].split(' ').collect();
        assert_eq!(f[0], "9");
        assert_eq!(f[1], "2", "a large grain is type 2, as in the dump");
        assert_eq!(f[2].parse::<f64>().unwrap(), 2.5);
        assert!(f[6].parse::<f64>().unwrap().is_nan());
        assert_eq!(f[9].parse::<f64>().unwrap(), 1.0 / 3.0);
        // Open: no lattice.
        let mut out = Vec::new();
        write_extxyz(&mut out, &snap(&props, None)).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(!text.contains("Lattice") && text.contains("pbc=\"F F F\""));
    }

    #[test]
    fn lammps_dump_writes_the_tilted_bounding_box() {
        let cell = Cell {
            lo: (0.0, 0.0),
            l: (10.0, 12.0),
            xy: -1.5,
            periodic: (true, true),
        };
        let mut out = Vec::new();
        write_lammps_dump(&mut out, &snap(&[], Some(cell))).unwrap();
        let text = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[4], "ITEM: BOX BOUNDS xy xz yz pp pp ff");
        assert_eq!(lines[5], "-1.5 10 -1.5");
        assert_eq!(lines[8], "ITEM: ATOMS id type x y z radius vx vy vz");
        assert_eq!(lines[10], "9 2 2.5 -0.25 0 0.7 NaN 2 0");
    }
}

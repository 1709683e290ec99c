//! Trajectories of a sheared-disk run: frames in the primary cell with one
//! Lees–Edwards box each, flushed as part files at checkpoints.

use crate::dem::shear::ShearSim;
use crate::error::{Error, Result};
use crate::io::table::write_table;
use crate::stages::simulate::tables::part_path;
use crate::tracks::{FrameBox, Tracks, TracksMeta};
use std::path::Path;

pub(crate) fn frame_box(frame: i64, l: f64, xy: f64) -> FrameBox {
    let mut b = FrameBox::from_simbox(frame, &crate::geom::SimBox::periodic(l, l));
    b.xy = xy;
    b
}

/// Write the buffered frames as part `k` (none if empty) and clear the rows (the meta
/// with every frame's box stays: it becomes the final sidecar).
pub(crate) fn flush_tracks(t: &mut Tracks, dir: &Path, k: u64) -> Result<()> {
    if t.frame.is_empty() {
        return Ok(());
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut df = crate::io::tracks_io::tracks_dataframe(t)?;
    write_table(&mut df, &part_path(dir, "tracks", k))?;
    let meta = std::mem::take(&mut t.meta);
    *t = empty_tracks();
    t.meta = meta;
    Ok(())
}

pub(crate) fn empty_tracks() -> Tracks {
    Tracks {
        frame: vec![],
        particle: vec![],
        x: vec![],
        y: vec![],
        radius: vec![],
        time: Some(vec![]),
        species: Some(vec![]),
        theta: Some(vec![]),
        meta: TracksMeta::default(),
    }
}

pub(crate) fn push_frame(t: &mut Tracks, sim: &ShearSim, frame: i64) {
    let g = &sim.g;
    let mut order: Vec<usize> = (0..g.len()).collect();
    order.sort_by_key(|&i| g.id[i]);
    for i in order {
        let (x, y) = sim.wrapped(i);
        t.frame.push(frame);
        t.particle.push(g.id[i]);
        t.x.push(x);
        t.y.push(y);
        t.radius.push(g.radius[i]);
        t.time.as_mut().expect("time").push(sim.time);
        t.species.as_mut().expect("species").push(g.species[i]);
        t.theta.as_mut().expect("theta").push(g.theta[i]);
    }
    t.meta
        .boxes
        .push(frame_box(frame, sim.l, sim.gamma * sim.l));
}

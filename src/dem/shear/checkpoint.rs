//! Exact binary checkpoints of a sheared-disk run (same codec as the pillar's).

use crate::dem::base::codec::{Dec, Enc, check_state, dec_grains, dec_list, enc_grains, enc_list};
use crate::dem::shear::{
    ANGLE_BINS, Collisions, DurationHistogram, Predicted, ShearParams, ShearSim,
};

const MAGIC: &[u8; 8] = b"PPSHEAR1";

impl ShearSim {
    /// The dynamical state bit for bit, plus the caller's `extra` bytes.
    pub fn save(&self, extra: &[u8]) -> Vec<u8> {
        let mut e = Enc::default();
        e.0.extend_from_slice(MAGIC);
        e.bytes(
            serde_json::to_string(&self.p)
                .expect("params serialise")
                .as_bytes(),
        );
        enc_grains(&mut e, &self.g);
        enc_list(&mut e, &self.list);
        e.f64(self.list.offset_ref);
        e.f64(self.l);
        e.f64(self.time);
        e.u64(self.step);
        for v in [&self.fx, &self.fy, &self.tq] {
            e.f64s(v);
        }
        // The virial is derived from the state (`ShearSim::virial`); its place in the
        // format is kept, zeroed.
        e.f64s(&[0.0; 4]);
        e.f64s(&[0.0; 4]);
        e.u64(0);
        e.u64(self.coll.begun);
        e.u64(self.coll.ended);
        e.f64(self.coll.duration_sum);
        e.i64s(
            &self
                .coll
                .angle_making
                .iter()
                .map(|&v| v as i64)
                .collect::<Vec<_>>(),
        );
        e.i64s(
            &self
                .coll
                .angle_breaking
                .iter()
                .map(|&v| v as i64)
                .collect::<Vec<_>>(),
        );
        e.u64(self.rotate as u64);
        e.f64(self.gamma);
        e.bytes(extra);
        // Added after the format's first version, so at the end: the duration cohort.
        e.f64(self.coll.window_start);
        for h in &self.coll.cohort_ended {
            e.i64s(&h.count.iter().map(|&v| v as i64).collect::<Vec<_>>());
            e.f64s(&h.sum);
        }
        e.u64(self.coll.angle_undefined);
        e.0
    }

    pub fn load(b: &[u8]) -> Result<(ShearSim, Vec<u8>), String> {
        if b.len() < 8 || &b[..8] != MAGIC {
            return Err("not a sheared-disk checkpoint (bad magic)".into());
        }
        let mut d = Dec::after(b, MAGIC.len());
        let p: ShearParams =
            serde_json::from_slice(&d.bytes()?).map_err(|e| format!("parameters: {e}"))?;
        let g = dec_grains(&mut d)?;
        let mut list = dec_list(&mut d)?;
        list.cut = list.reach(&g.radius);
        list.offset_ref = d.f64()?;
        let (l, time, step) = (d.f64()?, d.f64()?, d.u64()?);
        let (fx, fy, tq) = (d.f64s()?, d.f64s()?, d.f64s()?);
        // Derived from the state (see `save`): read past.
        for _ in 0..2 {
            let at = d.pos();
            if d.f64s()?.len() != 4 {
                return Err(format!("virial at byte {at}: needs 4 components"));
            }
        }
        d.u64()?;
        let (begun, ended, duration_sum) = (d.u64()?, d.u64()?, d.f64()?);
        let to_u = |v: Vec<i64>| v.into_iter().map(|x| x as u64).collect::<Vec<u64>>();
        let at = d.pos();
        let (angle_making, angle_breaking) = (to_u(d.i64s()?), to_u(d.i64s()?));
        let lens = (angle_making.len(), angle_breaking.len());
        if lens == (50, 50) {
            // Before the collision angle of Eq. 27 the histograms held 50 bins of the
            // direction of r_ij: those counts cannot be continued as ϑ.
            return Err(format!(
                "collision-angle histograms at byte {at}: 50 bins each, not {ANGLE_BINS}: the \
                 checkpoint was written by an earlier version, which binned the direction of \
                 r_ij rather than the collision angle ϑ of vagberg-sheared-disks Eq. 27; this \
                 run cannot be continued with the same statistics — start it again without \
                 --resume"
            ));
        }
        if lens != (ANGLE_BINS, ANGLE_BINS) {
            return Err(format!(
                "collision-angle histograms at byte {at}: {} and {} bins, need {ANGLE_BINS} each",
                lens.0, lens.1
            ));
        }
        let mut coll = Collisions {
            begun,
            ended,
            duration_sum,
            angle_making,
            angle_breaking,
            ..Default::default()
        };
        let rotate = d.u64()? != 0;
        let gamma = d.f64()?;
        let extra = d.bytes()?;
        // A checkpoint of an earlier version ends here: its run had no cohort yet.
        if !d.done() {
            coll.window_start = d.f64()?;
            for h in coll.cohort_ended.iter_mut() {
                let at = d.pos();
                let (count, sum) = (to_u(d.i64s()?), d.f64s()?);
                if count.len() != DurationHistogram::BINS || sum.len() != DurationHistogram::BINS {
                    return Err(format!(
                        "duration histogram at byte {at}: needs {} bins",
                        DurationHistogram::BINS
                    ));
                }
                *h = DurationHistogram { count, sum };
            }
        }
        // Added with the collision angle of Eq. 27.
        if !d.done() {
            coll.angle_undefined = d.u64()?;
        }
        if !d.done() {
            return Err(d.trailing());
        }
        let n = g.len();
        if [g.id.len(), g.vx.len(), g.omega.len(), fx.len(), tq.len()]
            .iter()
            .any(|&k| k != n)
        {
            return Err("inconsistent array lengths".into());
        }
        check_state(&g, &list)?;
        p.validate().map_err(|e| format!("parameters: {e}"))?;
        if p.n != n {
            return Err(format!(
                "parameters name {} disks, the state holds {n}",
                p.n
            ));
        }
        // The Lees–Edwards box the positions live in.
        if !(l.is_finite() && l > 0.0) {
            return Err(format!("box side {l} must be > 0 and finite"));
        }
        let sim = ShearSim {
            p,
            g,
            l,
            list,
            time,
            step,
            gamma,
            fx,
            fy,
            tq,
            coll,
            rotate,
            resort_every: crate::dem::shear::order::RESORT_EVERY,
            pred: Predicted::default(),
            slots: Default::default(),
            kernel: Default::default(),
            packed: Default::default(),
            packed_now: Default::default(),
            threads: 0,
            #[cfg(target_arch = "x86_64")]
            par: Default::default(),
        };
        Ok((sim, extra))
    }
}

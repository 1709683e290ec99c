//! The pillar's checkpoint (see [`crate::dem::base::codec`]): its whole dynamical
//! state, so a resumed run continues with the very numbers an uninterrupted one would
//! have had.

use crate::dem::base::codec::{Dec, Enc, check_state, dec_grains, dec_list, enc_grains, enc_list};
use crate::dem::pillar::params::PillarParams;
use crate::dem::pillar::{Interval, PillarSim};

const MAGIC: &[u8; 8] = b"PPCKPT01";

impl PillarSim {
    /// The whole dynamical state, bit-exact. `extra` is the caller's own state (output
    /// bookkeeping), stored alongside.
    pub fn save(&self, extra: &[u8]) -> Vec<u8> {
        let mut e = Enc::default();
        e.0.extend_from_slice(MAGIC);
        e.bytes(
            serde_json::to_string(&self.params)
                .expect("params serialise")
                .as_bytes(),
        );
        enc_grains(&mut e, &self.grains);
        enc_list(&mut e, &self.list);
        e.f64(self.bottom_y);
        e.f64(self.top_y0);
        e.f64s(&self.top_shear);
        e.f64s(&self.bottom_shear);
        e.u64(self.step);
        for v in [&self.fx, &self.fy, &self.tq, &self.sub_fx, &self.sub_fy] {
            e.f64s(v);
        }
        e.f64(self.top_force);
        e.f64(self.bottom_force);
        e.f64(self.bar_shear_force);
        let iv = &self.interval;
        e.u64(iv.steps);
        for v in [
            iv.top_force,
            iv.bottom_force,
            iv.substrate_power,
            iv.substrate_power_rot,
        ] {
            e.f64(v);
        }
        e.bytes(extra);
        // Last: the step of the last list build (u64::MAX: none), which the skin's
        // adaptation reads; a checkpoint of an earlier version ends before it.
        e.u64(self.scratch.last_build.unwrap_or(u64::MAX));
        e.0
    }

    /// Inverse of [`PillarSim::save`]: the state and the caller's extra bytes.
    pub fn load(b: &[u8]) -> Result<(PillarSim, Vec<u8>), String> {
        if b.len() < 8 || &b[..8] != MAGIC {
            return Err("not a pillar-pipe checkpoint (bad magic)".into());
        }
        let mut d = Dec::after(b, MAGIC.len());
        let params: PillarParams =
            serde_json::from_slice(&d.bytes()?).map_err(|e| format!("parameters: {e}"))?;
        let g = dec_grains(&mut d)?;
        let mut list = dec_list(&mut d)?;
        list.cut = list.reach(&g.radius);
        let (bottom_y, top_y0) = (d.f64()?, d.f64()?);
        let (top_shear, bottom_shear, step) = (d.f64s()?, d.f64s()?, d.u64()?);
        let (fx, fy, tq, sub_fx, sub_fy) = (d.f64s()?, d.f64s()?, d.f64s()?, d.f64s()?, d.f64s()?);
        let (top_force, bottom_force, bar_shear_force) = (d.f64()?, d.f64()?, d.f64()?);
        let interval = Interval {
            steps: d.u64()?,
            top_force: d.f64()?,
            bottom_force: d.f64()?,
            substrate_power: d.f64()?,
            substrate_power_rot: d.f64()?,
        };
        let extra = d.bytes()?;
        let last_build = if d.done() {
            None
        } else {
            Some(d.u64()?).filter(|&v| v != u64::MAX)
        };
        if !d.done() {
            return Err(d.trailing());
        }
        let n = g.len();
        let lens = [
            g.id.len(),
            g.species.len(),
            g.vx.len(),
            g.omega.len(),
            top_shear.len(),
            fx.len(),
            sub_fy.len(),
        ];
        if lens.iter().any(|&l| l != n) || bottom_shear.len() != n {
            return Err("inconsistent array lengths".into());
        }
        check_state(&g, &list)?;
        params.validate().map_err(|e| format!("parameters: {e}"))?;
        let sim = PillarSim {
            params,
            grains: g,
            list,
            bottom_y,
            top_y0,
            top_shear,
            bottom_shear,
            step,
            fx,
            fy,
            tq,
            sub_fx,
            sub_fy,
            top_force,
            bottom_force,
            bar_shear_force,
            interval,
            record: None,
            scratch: crate::dem::pillar::Scratch {
                skip_frozen: true,
                last_build,
                ..Default::default()
            },
        };
        Ok((sim, extra))
    }
}

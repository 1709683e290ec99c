//! Strain measures of a local affine transform J (Li et al., Eqs. 15–17).

use super::Convention;
use crate::geom::Mat2;

/// Lagrangian strain η = (JᵀJ − I)/2 (Eq. 15) and its invariants; dimensionless.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LocalStrain {
    pub eta_xx: f64,
    pub eta_xy: f64,
    pub eta_yy: f64,
    /// η^m = Tr η / 2 (Eq. 16): the volumetric part.
    pub eta_m: f64,
    /// η^s = √(Tr((η − η^m I)²)/2) (Eq. 17): the deviatoric (shear) part. With the
    /// OVITO convention, OVITO's 2D shear strain √(η_xy² + (η_xx − η_yy)²/2).
    pub eta_s: f64,
}

/// Strain of J. For the paper, η − η^m I = [[a, c], [c, −a]] with a = (η_xx − η_yy)/2,
/// c = η_xy, so η^s = √(a² + c²).
pub fn strain_from_j(j: &Mat2, conv: Convention) -> LocalStrain {
    let c = j.transpose() * *j;
    let eta_xx = 0.5 * (c.a11 - 1.0);
    let eta_yy = 0.5 * (c.a22 - 1.0);
    let eta_xy = 0.5 * c.a12;
    let eta_m = 0.5 * (eta_xx + eta_yy);
    let dxy = eta_xx - eta_yy;
    let eta_s = match conv {
        Convention::Paper => (0.25 * dxy * dxy + eta_xy * eta_xy).sqrt(),
        Convention::Ovito => (eta_xy * eta_xy + 0.5 * dxy * dxy).sqrt(),
    };
    LocalStrain {
        eta_xx,
        eta_xy,
        eta_yy,
        eta_m,
        eta_s,
    }
}

//! The navigation system: the receiver's perturbation state from trim, as the core expects
//! it ([`ibvs_core::nav::NavSample`]). Perfect (truth) in this slice.
//!
//! Invariant: angles and speed are perturbations from the trim the gains were designed at;
//! positions are relative to the CG's position in the tanker frame at the start of the run.

use ibvs_core::nav::{LatNav, LonNav, NavSample};
use nalgebra::Vector3;

use super::{Tanker, point_in_tanker_m};
use crate::linearize::{N_DESIGN, design_coordinates};
use crate::receiver::{ReceiverState, Trim};

/// Perfect navigation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerfectNav {
    trim_xi: [f64; N_DESIGN],
    start_cg_tanker_m: Vector3<f64>,
}

impl PerfectNav {
    /// Navigation referenced to `trim`, positions from `start_cg_tanker_m`.
    pub fn new(trim: &Trim, start_cg_tanker_m: Vector3<f64>) -> Self {
        Self {
            trim_xi: design_coordinates(&trim.state),
            start_cg_tanker_m,
        }
    }

    /// The sample for state `x` at time `t_s`.
    pub fn sample(&self, tanker: &Tanker, x: &ReceiverState, t_s: f64) -> NavSample {
        let xi = design_coordinates(x);
        let d: Vec<f32> = xi
            .iter()
            .zip(self.trim_xi)
            .map(|(v, t)| (v - t) as f32)
            .collect();
        let pos = point_in_tanker_m(tanker, x, &Vector3::zeros(), t_s) - self.start_cg_tanker_m;
        NavSample {
            lon: LonNav {
                x_fwd_m: pos.x as f32,
                h_up_m: -pos.z as f32,
                theta_rad: d[0],
                v_mps: d[1],
                alpha_rad: d[2],
                q_radps: d[3],
            },
            lat: LatNav {
                y_right_m: pos.y as f32,
                psi_rad: d[5],
                phi_rad: d[6],
                beta_rad: d[7],
                p_radps: d[8],
                r_radps: d[9],
            },
        }
    }
}

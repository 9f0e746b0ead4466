//! What the hose's tests share: the calm air of the default flight condition, the steady
//! trail in it, a link-length check and a frozen gust field (test builds only).
//!
//! Place in the data flow: the tests of `steady`, `dynamics` and the module itself drive the
//! public `HoseDrogue` with these inputs. Invariant: deterministic (seeded) inputs only.

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{HoseDrogue, HoseParams};

/// Tanker (= calm-air) speed, m/s (docs/models.md, "Flight condition and frames").
pub(super) const V_MPS: f64 = 120.0;
/// The `paper-*` presets' physics step, s.
pub(super) const DT_S: f64 = 0.01;
/// The refuelling presets' physics step, s.
pub(super) const PRESET_STEP_S: f64 = 0.02;
/// Nominal drogue position of the authors' simulation, tanker frame, m
/// (docs/models.md, "Flight condition and frames").
pub(super) const NOMINAL_M: [f64; 3] = [-14.35, 0.0, 5.12];

pub(super) fn calm(_: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(-V_MPS, 0.0, 0.0)
}

pub(super) fn calm_trail(params: HoseParams) -> HoseDrogue {
    HoseDrogue::steady_trail(params, &calm).expect("calm trail settles")
}

pub(super) fn max_link_error(h: &HoseDrogue) -> f64 {
    let l = h.params().hose_length_m / h.params().link_count as f64;
    h.node_positions_tanker_m()
        .windows(2)
        .map(|w| ((w[1] - w[0]).norm() / l - 1.0).abs())
        .fold(0.0, f64::max)
}

/// Frozen turbulence convected past the hose (Taylor's hypothesis): random-phase Fourier
/// modes, wavelengths 4..600 m, about `sigma` m/s rms per axis.
pub(super) struct Gusts {
    modes: Vec<(usize, f64, f64, f64)>, // axis, wavenumber rad/m, phase rad, amplitude m/s
}

impl Gusts {
    pub(super) fn new(seed: u64, sigma: f64) -> Self {
        const MODES_PER_AXIS: usize = 12;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let amp = sigma * (2.0 / MODES_PER_AXIS as f64).sqrt();
        let modes = (0..3)
            .flat_map(|axis| (0..MODES_PER_AXIS).map(move |i| (axis, i)))
            .map(|(axis, i)| {
                let wavelength = 600.0 * (4.0_f64 / 600.0).powf(i as f64 / 11.0);
                let phase = rng.random::<f64>() * std::f64::consts::TAU;
                (axis, std::f64::consts::TAU / wavelength, phase, amp)
            })
            .collect();
        Self { modes }
    }

    pub(super) fn air(&self, t: f64, p: &Vector3<f64>) -> Vector3<f64> {
        let mut v = Vector3::new(-V_MPS, 0.0, 0.0);
        let s = p.x + V_MPS * t; // distance along the frozen field
        for &(axis, k, phase, amp) in &self.modes {
            v[axis] += amp * (k * s + 0.3 * k * p.y + phase).sin();
        }
        v
    }
}

//! One controller step on a plausible input: the check the flight-computer binary runs, on
//! the board (under QEMU) and on the host alike.
//!
//! Place in the data flow: this stands in for the real firmware's control task. It builds
//! the controller from the default configuration, feeds it one [`ControllerInput`] with the
//! drogue in view, valid navigation and an `Engage` request, and checks the answer: the
//! controller must have entered [`Mode::PreContact`] (the default configuration flies the
//! refuelling procedure) and every command must be finite.
//!
//! Invariants: nothing here allocates or panics; every failure is a named [`OneStepError`].

use core::fmt;

use ibvs_core::controller::{ControllerInput, ControllerOutput, StatusFlags};
use ibvs_core::measurement::CameraMeasurement;
use ibvs_core::nav::NavSample;
use ibvs_core::{ConfigError, Controller, ControllerConfig, Mode, ModeRequest};

/// Depth of the drogue plane at the paper's start (drogue 6 m ahead of the probe tip), m.
pub const START_DEPTH_M: f32 = 6.0;
/// Normalised image x of the drogue at the paper's start (2 m right at 6 m, trim pitch
/// ignored), dimensionless.
pub const START_IMAGE_X: f32 = 2.0 / 6.0;
/// Normalised image y of the drogue at the paper's start (2 m up at 6 m: y is down),
/// dimensionless.
pub const START_IMAGE_Y: f32 = -2.0 / 6.0;

/// The input of the first step of a docking: first camera frame with the drogue tracked near
/// the paper's start, the receiver at trim (zero perturbations), no contact, `Engage`.
pub fn engage_input() -> ControllerInput {
    ControllerInput {
        measurement: CameraMeasurement {
            seq: 1,
            tracked: true,
            image_x: START_IMAGE_X,
            image_y: START_IMAGE_Y,
            depth_m: START_DEPTH_M,
            probe_tip: None,
        },
        nav: NavSample::default(),
        probe_contact: false,
        autopilot_ready: true,
        request: ModeRequest::Engage,
    }
}

/// Why the one-step check failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OneStepError {
    /// The default configuration was rejected.
    Config(ConfigError),
    /// The engage request did not lead to the pre-contact station (the default
    /// configuration's refuelling procedure).
    NotEngaged {
        /// The mode after the step.
        mode: Mode,
        /// The step's status bits (e.g. [`StatusFlags::ENGAGE_REFUSED`]).
        status: StatusFlags,
    },
    /// A command was NaN or infinite (the core's invariant is broken).
    NonFiniteCommand([f32; 4]),
}

impl fmt::Display for OneStepError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Config(e) => write!(f, "{e}"),
            Self::NotEngaged { mode, status } => write!(
                f,
                "engage did not enter pre-contact: mode {mode:?}, status {:#06x}",
                status.0
            ),
            Self::NonFiniteCommand([a, b, c, d]) => write!(
                f,
                "non-finite command [{}, {}, {}, {}]",
                Micro(*a),
                Micro(*b),
                Micro(*c),
                Micro(*d)
            ),
        }
    }
}

/// An `f32` printed with six decimals through integer formatting only (`-0.009574`,
/// `NaN`, `inf`): `core::fmt`'s float formatting is about 20 KiB of flash, a third of the
/// firmware's budget, and the logs need no more than this.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Micro(pub f32);

impl fmt::Display for Micro {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v.is_nan() {
            return f.write_str("NaN");
        }
        if v.is_infinite() {
            return f.write_str(if v > 0.0 { "inf" } else { "-inf" });
        }
        // Whole part and millionths (rounded), in u32 (`as` saturates: 4294967295 for
        // anything larger, never a command).
        let a = if v < 0.0 { -v } else { v };
        let mut whole = a as u32;
        let mut micro = ((a - whole as f32) * 1e6 + 0.5) as u32;
        if micro >= 1_000_000 {
            whole = whole.saturating_add(1);
            micro -= 1_000_000;
        }
        let sign = if v.is_sign_negative() { "-" } else { "" };
        write!(f, "{sign}{whole}.{micro:06}")
    }
}

/// Builds `Controller::new(ControllerConfig::default())`, runs one step on
/// [`engage_input`] and checks the result.
pub fn run() -> Result<ControllerOutput, OneStepError> {
    let mut controller =
        Controller::new(ControllerConfig::default()).map_err(OneStepError::Config)?;
    let out = controller.step(&engage_input());
    if out.mode != Mode::PreContact {
        return Err(OneStepError::NotEngaged {
            mode: out.mode,
            status: out.status,
        });
    }
    let command = out.command.as_array();
    if !command.iter().all(|c| c.is_finite())
        || out.status.contains(StatusFlags::NON_FINITE_COMMAND)
    {
        return Err(OneStepError::NonFiniteCommand(command));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_step_enters_pre_contact_with_finite_commands() {
        let out = run();
        assert!(out.is_ok(), "{out:?}");
    }

    #[test]
    fn micro_prints_six_decimals_without_float_formatting() {
        let cases = [
            (-0.009573651_f32, "-0.009574"),
            (0.16390319, "0.163903"),
            (0.0, "0.000000"),
            (-0.0, "-0.000000"),
            (12.5, "12.500000"),
            (-1.25e-7, "-0.000000"),
            (0.9999996, "1.000000"),
            (f32::NAN, "NaN"),
            (f32::NEG_INFINITY, "-inf"),
        ];
        for (v, want) in cases {
            assert_eq!(Micro(v).to_string(), want, "{v}");
        }
    }

    #[test]
    fn engage_is_refused_without_the_drogue() {
        let mut c = Controller::new(ControllerConfig::default()).expect("default config");
        let mut input = engage_input();
        input.measurement.tracked = false;
        let out = c.step(&input);
        assert_eq!(out.mode, Mode::Standby);
        assert!(out.status.contains(StatusFlags::ENGAGE_REFUSED));
    }
}

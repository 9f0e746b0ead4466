//! Outer loop: from the validated image feature to a desired camera velocity.
//!
//! Two laws, selectable in [`crate::config::ControllerConfig::law`]:
//! - [`ibvs`]: the paper's eq. (16), (18) and the closing-speed law of docs/paper.md, item 2,
//!   acting on the image error directly;
//! - [`pbvs`]: the position-based baseline: the image point and depth are turned into a 3-D
//!   drogue position through the *believed* camera mount and the navigation attitude, and a
//!   Cartesian law acts on it (paper Sec. IV, experiment 2).
//!
//! Both return the desired velocity of the camera relative to the drogue in `re` axes
//! (x right, y down, z forward) and the target estimate the mode logic uses.
//!
//! Invariant: for a validated feature (finite, depth > 0) and validated gains the output is
//! finite, `|x| <= max_lateral_mps`, `|y| <= max_vertical_mps` and
//! `min_closing_mps <= z <= max_closing_mps`.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::frames::{TargetEstimate, VelocityRe};
use crate::kinematics::{self, CameraMount};
use crate::measurement::ImageFeature;
use crate::nav::NavSample;
use crate::num::{clamp_sym, max_to, min_to};

/// Gains of the IBVS law (paper Table 1 as defaults, in normalised image units).
///
/// The image error `e` is dimensionless (`x_c / z_c`), so `k1 e_x` is a speed: k1 and k2 are
/// m/s per unit of normalised error. At depth `z`, `k1 / z` is the equivalent Cartesian
/// gain in 1/s on the lateral offset (`e_x z`). k3 is 1/s on depth; k4, k5 are m/s per unit
/// of normalised error, taken off the closing speed while the image error is large.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IbvsGains {
    /// Lateral gain k1, m/s per unit normalised error.
    pub k1_mps: f32,
    /// Vertical gain k2, m/s per unit normalised error.
    pub k2_mps: f32,
    /// Closing gain k3 on depth, 1/s.
    pub k3_per_s: f32,
    /// Closing-speed reduction k4 for lateral image error, m/s per unit normalised error.
    pub k4_mps: f32,
    /// Closing-speed reduction k5 for vertical image error, m/s per unit normalised error.
    pub k5_mps: f32,
    /// Image convergence point `(x_o, y_o)` of eq. (2), normalised; the origin in the paper.
    pub convergence_point: [f32; 2],
    /// Cap on the Cartesian gains `k1 / z` and `k2 / z`, 1/s (ours, not the paper's): near the
    /// drogue the IBVS gain grows as 1/z past the inner loops' bandwidth; the cap keeps the
    /// outer loop slower than the inner one. Infinity gives the paper's law.
    pub max_cartesian_gain_per_s: f32,
}

/// Gains of the PBVS baseline, Cartesian: the same structure as IBVS with the image error
/// replaced by the reconstructed position offset.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PbvsGains {
    /// Lateral gain on the rightward offset, 1/s.
    pub k_lat_per_s: f32,
    /// Vertical gain on the downward offset, 1/s.
    pub k_vert_per_s: f32,
    /// Closing gain on depth, 1/s.
    pub k_close_per_s: f32,
    /// Closing-speed reduction per metre of lateral offset, 1/s.
    pub k_slow_lat_per_s: f32,
    /// Closing-speed reduction per metre of vertical offset, 1/s.
    pub k_slow_vert_per_s: f32,
}

/// Limits shared by both laws.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VelocityLimits {
    /// Minimum closing speed `a` (paper eq. (22), read as in docs/paper.md, items 2 and 6), m/s.
    /// Also the closing speed of the blind terminal phase; must lie in the coupling band.
    pub min_closing_mps: f32,
    /// Maximum closing speed, m/s.
    pub max_closing_mps: f32,
    /// Maximum lateral speed command, m/s.
    pub max_lateral_mps: f32,
    /// Maximum vertical speed command, m/s.
    pub max_vertical_mps: f32,
    /// Largest change of the desired velocity per second, each axis, m/s^2: the commands
    /// the inner loops track are slewed toward the law's output (and the mode's), so that
    /// engaging, entering the blind phase or breaking away never steps the inner loops.
    pub max_accel_mps2: f32,
}

/// What the outer loop produces in one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OuterOutput {
    /// Desired camera velocity relative to the drogue, `re` axes.
    pub v_des: VelocityRe,
    /// Where the law believes the drogue is.
    pub target: TargetEstimate,
}

fn closing_speed(raw_mps: f32, lim: &VelocityLimits) -> f32 {
    // max(raw, a) then the upper limit; a <= max is a validated config invariant.
    min_to(max_to(raw_mps, lim.min_closing_mps), lim.max_closing_mps)
}

/// Moves `from` toward `to` by at most `max_step` (not NaN) on each axis.
#[inline]
pub fn slew(from: &VelocityRe, to: &VelocityRe, max_step: f32) -> VelocityRe {
    let step = |a: f32, b: f32| a + clamp_sym(b - a, max_step);
    VelocityRe {
        x_right_mps: step(from.x_right_mps, to.x_right_mps),
        y_down_mps: step(from.y_down_mps, to.y_down_mps),
        z_fwd_mps: step(from.z_fwd_mps, to.z_fwd_mps),
    }
}

/// Moves `from` toward `to` by at most `max_step[i]` (not NaN) on axis `i` (right, down,
/// forward).
#[inline]
pub fn slew_axes(from: &VelocityRe, to: &VelocityRe, max_step: [f32; 3]) -> VelocityRe {
    let step = |a: f32, b: f32, m: f32| a + clamp_sym(b - a, m);
    VelocityRe {
        x_right_mps: step(from.x_right_mps, to.x_right_mps, max_step[0]),
        y_down_mps: step(from.y_down_mps, to.y_down_mps, max_step[1]),
        z_fwd_mps: step(from.z_fwd_mps, to.z_fwd_mps, max_step[2]),
    }
}

/// IBVS law: `v_x = min(k1, g z) e_x`, `v_y = min(k2, g z) e_y` (`g`: the Cartesian-gain cap),
/// `v_z = min(max(k3 z - k4 |e_x| - k5 |e_y|, a), v_max)`, lateral and vertical saturated.
/// Limits are not NaN (a validated configuration's are not; `min`/`max` without calls).
#[inline]
pub fn ibvs(f: &ImageFeature, g: &IbvsGains, lim: &VelocityLimits) -> OuterOutput {
    let e_x = f.image_x - g.convergence_point[0];
    let e_y = f.image_y - g.convergence_point[1];
    let z = f.depth_m;
    let cap = g.max_cartesian_gain_per_s * z;
    let raw_close = g.k3_per_s * z - g.k4_mps * libm::fabsf(e_x) - g.k5_mps * libm::fabsf(e_y);
    OuterOutput {
        v_des: VelocityRe {
            x_right_mps: clamp_sym(min_to(g.k1_mps, cap) * e_x, lim.max_lateral_mps),
            y_down_mps: clamp_sym(min_to(g.k2_mps, cap) * e_y, lim.max_vertical_mps),
            z_fwd_mps: closing_speed(raw_close, lim),
        },
        target: TargetEstimate {
            right_m: f.image_x * z,
            down_m: f.image_y * z,
            depth_m: z,
        },
    }
}

/// What PBVS believes about the airframe geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PbvsGeometry {
    /// Believed camera mount.
    pub camera: CameraMount,
    /// Probe tip relative to the CG, body axes, m.
    pub probe_tip_body_m: [f32; 3],
    /// Trim pitch the navigation perturbations are relative to, rad.
    pub trim_pitch_rad: f32,
}

/// Drogue centre relative to the probe tip in tanker axes, reconstructed from the image point,
/// the depth, the believed mount and the navigation attitude.
pub fn pbvs_drogue_from_probe_tanker_m(
    f: &ImageFeature,
    nav: &NavSample,
    geo: &PbvsGeometry,
) -> Vector3<f32> {
    let drogue_cam = Vector3::new(f.image_x * f.depth_m, f.image_y * f.depth_m, f.depth_m);
    let cam = Vector3::from(geo.camera.position_body_m);
    let probe = Vector3::from(geo.probe_tip_body_m);
    let drogue_from_probe_body =
        cam - probe + kinematics::body_from_camera(geo.camera.pitch_down_rad) * drogue_cam;
    let t_from_b = kinematics::tanker_from_body(
        nav.lat.phi_rad,
        geo.trim_pitch_rad + nav.lon.theta_rad,
        nav.lat.psi_rad,
    );
    t_from_b * drogue_from_probe_body
}

/// PBVS law on the reconstructed offset `r` (tanker axes): `v_right = k_lat r_y`,
/// `v_down = k_vert r_z`, `v_fwd = min(max(k_close r_x - k_slow_lat |r_y| - k_slow_vert |r_z|, a), v_max)`.
///
/// Out of line: the baseline law (and its trigonometry) stays out of the IBVS step's code.
#[inline(never)]
pub fn pbvs(
    f: &ImageFeature,
    nav: &NavSample,
    geo: &PbvsGeometry,
    g: &PbvsGains,
    lim: &VelocityLimits,
) -> OuterOutput {
    let r = pbvs_drogue_from_probe_tanker_m(f, nav, geo);
    let raw_close = g.k_close_per_s * r.x
        - g.k_slow_lat_per_s * libm::fabsf(r.y)
        - g.k_slow_vert_per_s * libm::fabsf(r.z);
    OuterOutput {
        v_des: VelocityRe {
            x_right_mps: clamp_sym(g.k_lat_per_s * r.y, lim.max_lateral_mps),
            y_down_mps: clamp_sym(g.k_vert_per_s * r.z, lim.max_vertical_mps),
            z_fwd_mps: closing_speed(raw_close, lim),
        },
        target: TargetEstimate {
            right_m: r.y,
            down_m: r.z,
            depth_m: r.x,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::ControllerConfig;

    fn feature(x: f32, y: f32, z: f32) -> ImageFeature {
        ImageFeature {
            image_x: x,
            image_y: y,
            depth_m: z,
        }
    }

    #[test]
    fn ibvs_signs_drive_toward_the_drogue() {
        let c = ControllerConfig::paper();
        // Drogue right of and above the boresight: move right, move up (negative down), close.
        let o = ibvs(&feature(0.2, -0.1, 5.0), &c.ibvs, &c.velocity_limits);
        assert!(o.v_des.x_right_mps > 0.0);
        assert!(o.v_des.y_down_mps < 0.0);
        assert!(o.v_des.z_fwd_mps >= c.velocity_limits.min_closing_mps);
        assert_eq!(
            o.target,
            TargetEstimate {
                right_m: 1.0,
                down_m: -0.5,
                depth_m: 5.0
            }
        );
    }

    #[test]
    fn ibvs_closing_speed_is_floored_slowed_by_error_and_capped() {
        let c = ControllerConfig::paper();
        let (g, lim) = (&c.ibvs, &c.velocity_limits);
        // Far and centred: k3 z above the cap.
        assert_eq!(
            ibvs(&feature(0.0, 0.0, 40.0), g, lim).v_des.z_fwd_mps,
            lim.max_closing_mps
        );
        // Centred at mid range: exactly k3 z.
        let z = (lim.min_closing_mps + lim.max_closing_mps) / 2.0 / g.k3_per_s;
        let v = ibvs(&feature(0.0, 0.0, z), g, lim).v_des.z_fwd_mps;
        assert!((v - g.k3_per_s * z).abs() < 1e-5);
        // The same depth with image error closes more slowly.
        let slower = ibvs(&feature(0.05, 0.05, z), g, lim).v_des.z_fwd_mps;
        assert!(slower < v);
        // Near: floored at a.
        assert_eq!(
            ibvs(&feature(0.0, 0.0, 0.1), g, lim).v_des.z_fwd_mps,
            lim.min_closing_mps
        );
    }

    #[test]
    fn ibvs_gain_cap_limits_k_over_z_near_the_drogue() {
        let c = ControllerConfig::paper();
        let (g, lim) = (&c.ibvs, &c.velocity_limits);
        let cap = g.max_cartesian_gain_per_s;
        // Far: the paper's k1 e_x. Near: cap z e_x, i.e. cap times the lateral offset.
        let far_z = 2.0 * g.k1_mps / cap;
        assert_eq!(
            ibvs(&feature(0.1, 0.0, far_z), g, lim).v_des.x_right_mps,
            g.k1_mps * 0.1
        );
        let near = ibvs(&feature(0.1, 0.1, 0.5), g, lim).v_des;
        assert!((near.x_right_mps - cap * 0.5 * 0.1).abs() < 1e-6);
        assert!((near.y_down_mps - cap * 0.5 * 0.1).abs() < 1e-6);
        let paper = IbvsGains {
            max_cartesian_gain_per_s: f32::INFINITY,
            ..*g
        };
        assert_eq!(
            ibvs(&feature(0.1, 0.1, 0.5), &paper, lim).v_des.y_down_mps,
            g.k2_mps * 0.1
        );
    }

    #[test]
    fn slew_limits_each_axis() {
        let from = VelocityRe {
            x_right_mps: 0.0,
            y_down_mps: 1.0,
            z_fwd_mps: 0.5,
        };
        let to = VelocityRe {
            x_right_mps: 1.0,
            y_down_mps: -1.0,
            z_fwd_mps: 0.51,
        };
        let v = slew(&from, &to, 0.1);
        assert_eq!((v.x_right_mps, v.y_down_mps), (0.1, 0.9));
        assert!((v.z_fwd_mps - 0.51).abs() < 1e-7);
    }

    #[test]
    fn slew_axes_limits_each_axis_by_its_own_step() {
        // Right by at most 0.1, down by at most 0.2, forward by at most 0.05: the first two
        // are limited (up and down), the third reaches its target.
        let from = VelocityRe {
            x_right_mps: 0.0,
            y_down_mps: 1.0,
            z_fwd_mps: 0.5,
        };
        let to = VelocityRe {
            x_right_mps: 1.0,
            y_down_mps: -1.0,
            z_fwd_mps: 0.53,
        };
        let v = slew_axes(&from, &to, [0.1, 0.2, 0.05]);
        assert_eq!((v.x_right_mps, v.y_down_mps), (0.1, 0.8));
        assert!((v.z_fwd_mps - 0.53).abs() < 1e-7, "{v:?}");
        // Swapped steps: each axis uses its own.
        let v = slew_axes(&from, &to, [0.05, 0.1, 0.2]);
        assert_eq!((v.x_right_mps, v.y_down_mps), (0.05, 0.9));
        assert!((v.z_fwd_mps - 0.53).abs() < 1e-7, "{v:?}");
    }

    #[test]
    fn pbvs_reconstructs_the_offset_at_trim() {
        let c = ControllerConfig::paper();
        let geo = c.pbvs_geometry();
        // Camera at the probe tip, level boresight at trim: offset = image point * depth.
        let r =
            pbvs_drogue_from_probe_tanker_m(&feature(0.25, -0.5, 4.0), &NavSample::default(), &geo);
        assert!((r - Vector3::new(4.0, 1.0, -2.0)).norm() < 1e-5, "{r:?}");
    }

    #[test]
    fn ibvs_is_the_documented_law_term_by_term() {
        // docs/conventions.md, "Outer loop (IBVS)": v_x = k1 e_x, v_y = k2 e_y,
        // v_z = min(max(k3 z - k4 |e_x| - k5 |e_y|, a), v_max); Table 1: k1 = 1, k2 = 2,
        // k3 = 0.3, k4 = 3, k5 = 1. At 5 m the gain cap (0.7 z = 3.5) is above k1 and k2.
        let c = ControllerConfig::paper();
        let o = ibvs(&feature(0.1, -0.2, 5.0), &c.ibvs, &c.velocity_limits);
        assert!((o.v_des.x_right_mps - 0.1).abs() < 1e-6, "{o:?}");
        assert!((o.v_des.y_down_mps + 0.4).abs() < 1e-6, "{o:?}");
        // 0.3 * 5 - 3 * 0.1 - 1 * 0.2 = 1.0 m/s, inside [0.8, 2.0].
        assert!((o.v_des.z_fwd_mps - 1.0).abs() < 1e-6, "{o:?}");
    }

    #[test]
    fn ibvs_drives_the_drogue_onto_a_non_zero_convergence_point() {
        // Eq. (2): e = p - p_o. With the convergence point at (0.1, -0.05) the law is at rest
        // when the drogue is seen there, and a drogue on the boresight is 0.1 left of and
        // 0.05 below the point: the camera moves left and down (so that the drogue moves
        // right and up in the image), closing slower by k4 0.1 + k5 0.05.
        let c = ControllerConfig::paper();
        let g = IbvsGains {
            convergence_point: [0.1, -0.05],
            ..c.ibvs
        };
        let lim = &c.velocity_limits;
        let at_point = ibvs(&feature(0.1, -0.05, 5.0), &g, lim);
        assert_eq!(at_point.v_des.x_right_mps, 0.0);
        assert_eq!(at_point.v_des.y_down_mps, 0.0);
        assert!(
            (at_point.v_des.z_fwd_mps - 1.5).abs() < 1e-6,
            "{at_point:?}"
        );
        let centred = ibvs(&feature(0.0, 0.0, 5.0), &g, lim);
        assert!(
            (centred.v_des.x_right_mps + 0.1).abs() < 1e-6,
            "{centred:?}"
        );
        assert!((centred.v_des.y_down_mps - 0.1).abs() < 1e-6, "{centred:?}");
        assert!((centred.v_des.z_fwd_mps - 1.15).abs() < 1e-6, "{centred:?}");
        // The target estimate is where the drogue is, not the error: the point does not move it.
        assert_eq!(
            centred.target,
            TargetEstimate {
                right_m: 0.0,
                down_m: 0.0,
                depth_m: 5.0
            }
        );
    }

    #[test]
    fn pbvs_is_the_documented_law_term_by_term() {
        // docs/conventions.md, "Outer loop (PBVS baseline)": v_right = 0.4 r_y,
        // v_down = 0.4 r_z, v_fwd = min(max(0.3 r_x - 0.5 |r_y| - 0.5 |r_z|, a), v_max).
        // The paper's camera at the tip, at trim: r = (z, e_x z, e_y z) = (5, 0.5, -0.25).
        let c = ControllerConfig::paper();
        let o = pbvs(
            &feature(0.1, -0.05, 5.0),
            &NavSample::default(),
            &c.pbvs_geometry(),
            &c.pbvs,
            &c.velocity_limits,
        );
        assert!((o.v_des.x_right_mps - 0.2).abs() < 1e-5, "{o:?}");
        assert!((o.v_des.y_down_mps + 0.1).abs() < 1e-5, "{o:?}");
        // 1.5 - 0.25 - 0.125 = 1.125 m/s, inside [0.8, 2.0].
        assert!((o.v_des.z_fwd_mps - 1.125).abs() < 1e-5, "{o:?}");
        let t = o.target;
        assert!((t.right_m - 0.5).abs() < 1e-5, "{t:?}");
        assert!((t.down_m + 0.25).abs() < 1e-5, "{t:?}");
        assert!((t.depth_m - 5.0).abs() < 1e-5, "{t:?}");
        // Drogue left of and below the tip: the command is left and down. Far off the axis the
        // closing speed is floored at a; far ahead and centred it is capped.
        let lim = &c.velocity_limits;
        let o = pbvs(
            &feature(-0.1, 0.05, 5.0),
            &NavSample::default(),
            &c.pbvs_geometry(),
            &c.pbvs,
            lim,
        );
        assert!((o.v_des.x_right_mps + 0.2).abs() < 1e-5, "{o:?}");
        assert!((o.v_des.y_down_mps - 0.1).abs() < 1e-5, "{o:?}");
        assert!((o.v_des.z_fwd_mps - 1.125).abs() < 1e-5, "{o:?}");
        let off_axis = pbvs(
            &feature(0.5, 0.0, 4.0),
            &NavSample::default(),
            &c.pbvs_geometry(),
            &c.pbvs,
            lim,
        );
        assert_eq!(
            off_axis.v_des.z_fwd_mps, lim.min_closing_mps,
            "1.2 - 1.0 < a"
        );
        let far = pbvs(
            &feature(0.0, 0.0, 10.0),
            &NavSample::default(),
            &c.pbvs_geometry(),
            &c.pbvs,
            lim,
        );
        assert_eq!(far.v_des.z_fwd_mps, lim.max_closing_mps, "3.0 > v_max");
    }

    #[test]
    fn pbvs_turns_the_camera_point_by_the_navigation_attitude() {
        // The paper's camera at the tip; the drogue on the boresight at 5 m. Nose 0.1 rad up
        // from trim: the boresight points 0.1 rad above the horizon, so the drogue is above
        // the tip (down negative). Heading 0.1 rad right: it is right of the tip.
        let c = ControllerConfig::paper();
        let geo = c.pbvs_geometry();
        let (z, a) = (5.0_f32, 0.1_f32);
        let mut nav = NavSample::default();
        nav.lon.theta_rad = a;
        let r = pbvs_drogue_from_probe_tanker_m(&feature(0.0, 0.0, z), &nav, &geo);
        let want = Vector3::new(z * libm::cosf(a), 0.0, -z * libm::sinf(a));
        assert!((r - want).norm() < 1e-4, "{r:?} vs {want:?}");
        let mut nav = NavSample::default();
        nav.lat.psi_rad = a;
        let r = pbvs_drogue_from_probe_tanker_m(&feature(0.0, 0.0, z), &nav, &geo);
        let want = Vector3::new(z * libm::cosf(a), z * libm::sinf(a), 0.0);
        assert!((r - want).norm() < 1e-4, "{r:?} vs {want:?}");
        // Banked 0.1 rad right (right wing down), with a boresight along the body x axis (trim
        // pitch zero, so the bank turns about the boresight): a point seen 0.2 right of the
        // boresight lies right and below, (z, 0.2 z cos a, 0.2 z sin a).
        let along_x = PbvsGeometry {
            camera: CameraMount {
                pitch_down_rad: 0.0,
                ..geo.camera
            },
            trim_pitch_rad: 0.0,
            ..geo
        };
        let mut nav = NavSample::default();
        nav.lat.phi_rad = a;
        let r = pbvs_drogue_from_probe_tanker_m(&feature(0.2, 0.0, z), &nav, &along_x);
        let want = Vector3::new(z, 0.2 * z * libm::cosf(a), 0.2 * z * libm::sinf(a));
        assert!((r - want).norm() < 1e-4, "{r:?} vs {want:?}");
    }

    #[test]
    fn pbvs_is_biased_by_a_mount_error() {
        let mut c = ControllerConfig::paper();
        c.camera.position_body_m[2] += -0.5; // believed 0.5 m higher than it is
        let r = pbvs_drogue_from_probe_tanker_m(
            &feature(0.0, 0.0, 4.0),
            &NavSample::default(),
            &c.pbvs_geometry(),
        );
        assert!(
            (r.z - (-0.5 * libm::cosf(c.pbvs_geometry().trim_pitch_rad))).abs() < 1e-5,
            "{r:?}"
        );
    }
}

//! The configuration's validation rules on their boundaries (`ibvs_core::config`, `RULES`):
//! "finite, >= 0" accepts zero and rejects the smallest negative; the convergence point must
//! lie strictly inside the field of view; the actuator limits must be finite with
//! `min < max` strictly, each rule reported with its own field and requirement.

use ibvs_core::ControllerConfig;
use ibvs_core::config::{ConfigError, ConfigProblem};

/// The field, problem and requirement of the rejection of the default configuration with
/// `edit` applied (`None`: accepted).
fn rejection(
    edit: impl FnOnce(&mut ControllerConfig),
) -> Option<(&'static str, ConfigProblem, &'static str)> {
    let mut c = ControllerConfig::default();
    edit(&mut c);
    c.validate().err().map(
        |ConfigError {
             field,
             problem,
             requirement,
         }| (field, problem, requirement),
    )
}

/// The largest negative `f32` (the negative subnormal nearest zero).
const TINY_NEGATIVE: f32 = -f32::from_bits(1);

#[test]
fn a_non_negative_field_accepts_zero_and_rejects_the_smallest_negative() {
    type Edit = fn(&mut ControllerConfig, f32);
    let fields: [(&str, Edit); 4] = [
        ("ibvs.k4_mps", |c, v| c.ibvs.k4_mps = v),
        ("pbvs.k_slow_vert_per_s", |c, v| {
            c.pbvs.k_slow_vert_per_s = v
        }),
        ("modes.breakaway_throttle_cut", |c, v| {
            c.modes.breakaway_throttle_cut = v
        }),
        ("estimator.offset_noise_per_m", |c, v| {
            c.estimator.offset_noise_per_m = v
        }),
    ];
    for (name, set) in fields {
        assert_eq!(rejection(|c| set(c, 0.0)), None, "{name} = 0");
        assert_eq!(rejection(|c| set(c, -0.0)), None, "{name} = -0");
        assert_eq!(
            rejection(|c| set(c, TINY_NEGATIVE)),
            Some((name, ConfigProblem::Negative, "finite, >= 0")),
            "{name} < 0"
        );
    }
}

#[test]
fn the_convergence_point_must_lie_strictly_inside_the_field_of_view() {
    let m = ControllerConfig::default().measurement;
    let rejected = Some((
        "ibvs.convergence_point",
        ConfigProblem::Inconsistent,
        "in_view(ibvs.convergence_point, measurement)",
    ));
    let next_down = |x: f32| f32::from_bits(x.to_bits() - 1);
    for (point, want) in [
        ([0.0, 0.0], None),
        ([next_down(m.half_fov_x), 0.0], None),
        ([0.0, -next_down(m.half_fov_y)], None),
        ([m.half_fov_x, 0.0], rejected),
        ([-m.half_fov_x, 0.0], rejected),
        ([0.0, m.half_fov_y], rejected),
        ([0.0, -m.half_fov_y], rejected),
        // Inside one axis, outside the other: rejected whichever.
        ([0.1, 2.0 * m.half_fov_y], rejected),
        ([2.0 * m.half_fov_x, 0.1], rejected),
        ([f32::NAN, 0.0], rejected),
        ([0.0, f32::INFINITY], rejected),
    ] {
        assert_eq!(
            rejection(|c| c.ibvs.convergence_point = point),
            want,
            "{point:?}"
        );
    }
}

#[test]
fn actuator_limits_must_be_finite_and_strictly_ordered() {
    let unordered = Some((
        "actuators.min",
        ConfigProblem::Inconsistent,
        "ordered(actuators)",
    ));
    // Equal limits, crossed limits, an infinite upper or lower limit: the ordering rule (not
    // the trim rule after it) names the problem.
    assert_eq!(
        rejection(|c| c.actuators.min[2] = c.actuators.max[2]),
        unordered,
        "min == max"
    );
    assert_eq!(
        rejection(|c| {
            c.actuators.min[0] = 0.5;
            c.actuators.max[0] = -0.5;
        }),
        unordered,
        "min > max"
    );
    assert_eq!(
        rejection(|c| c.actuators.max[3] = f32::INFINITY),
        unordered,
        "max infinite"
    );
    assert_eq!(
        rejection(|c| c.actuators.min[1] = f32::NEG_INFINITY),
        unordered,
        "min infinite"
    );
}

#[test]
fn the_gross_mass_factor_is_accepted_within_its_bounds_and_refused_outside_or_not_finite() {
    use ibvs_core::config::{MAX_MASS_FACTOR, MIN_MASS_FACTOR};
    let rule = "(MIN_MASS_FACTOR..=MAX_MASS_FACTOR).contains(mass_factor)";
    for ok in [MIN_MASS_FACTOR, 0.85, 1.0, 1.25, MAX_MASS_FACTOR] {
        assert_eq!(rejection(|c| c.mass_factor = ok), None, "{ok}");
    }
    for bad in [
        MIN_MASS_FACTOR.next_down(),
        MAX_MASS_FACTOR.next_up(),
        0.0,
        -1.0,
        // A mass in kilograms or pounds where the factor belongs.
        9295.0,
        f32::NAN,
        f32::INFINITY,
    ] {
        assert_eq!(
            rejection(|c| c.mass_factor = bad),
            Some(("mass_factor", ConfigProblem::Inconsistent, rule)),
            "{bad}"
        );
    }
}

//! Camera measurement: the raw frame from the drogue tracker and its validation.
//!
//! Place in the data flow: first stage of a step. A [`CameraMeasurement`] either becomes an
//! [`ImageFeature`] (image error and depth the outer loop may use) or a named
//! [`MeasurementError`] that the controller counts and answers (hold, then break away;
//! `docs/conventions.md`, "Input validation").
//!
//! Invariant: an [`ImageFeature`] is finite, its depth is in `(0, max_depth_m]` and its image
//! point is inside the configured field of view.

use serde::{Deserialize, Serialize};

/// One frame from the drogue tracker, as it arrives (nothing here is trusted yet).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CameraMeasurement {
    /// Frame counter from the camera, incremented once per captured frame (wraps).
    pub seq: u32,
    /// The tracker's own lock flag: false when it did not find the drogue in this frame.
    pub tracked: bool,
    /// Drogue centre, normalised image x (`x_c / z_c`, right positive), dimensionless.
    pub image_x: f32,
    /// Drogue centre, normalised image y (`y_c / z_c`, down positive), dimensionless.
    pub image_y: f32,
    /// Depth of the drogue plane along the camera boresight, m.
    pub depth_m: f32,
    /// The probe tip's marker in the same frame, normalised image `(x, y)`, when the camera
    /// sees it (a camera set back from the tip; `None` for one at the tip). It is the
    /// refuelling procedure's convergence point: servoing the drogue's image to the tip's
    /// own image makes the miss at contact independent of the camera's mount calibration.
    pub probe_tip: Option<[f32; 2]>,
}

/// Why a frame was not used. Each variant has its own counter in
/// [`crate::controller::Counters`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MeasurementError {
    /// The tracker reported no lock.
    NotTracked,
    /// Image point or depth is NaN or infinite.
    NonFinite,
    /// Depth is zero or negative.
    DepthNotPositive,
    /// Depth exceeds [`MeasurementLimits::max_depth_m`].
    DepthTooLarge,
    /// The image point lies outside the camera's field of view.
    OutsideFieldOfView,
    /// Same sequence number as the last frame: no new frame arrived this step.
    Repeated,
    /// Sequence number older than the last frame's (late or reordered frame).
    OutOfOrder,
    /// A new frame (the sequence number advanced) whose image point and depth are, bit for
    /// bit, those of the last valid frame: a stuck tracker or a frozen image pipeline. A
    /// real tracker's centroids carry noise and the receiver is never still to the last bit,
    /// so an identical frame is not a measurement.
    Frozen,
}

impl core::fmt::Display for MeasurementError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::NotTracked => "the tracker reported no lock",
            Self::NonFinite => "image point or depth not finite",
            Self::DepthNotPositive => "depth zero or negative",
            Self::DepthTooLarge => "depth beyond the largest credible",
            Self::OutsideFieldOfView => "image point outside the field of view",
            Self::Repeated => "no new frame (same sequence number)",
            Self::OutOfOrder => "frame older than the last one",
            Self::Frozen => "frame identical to the last valid one (frozen tracker)",
        })
    }
}

impl core::error::Error for MeasurementError {}

/// Plausibility limits for a frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MeasurementLimits {
    /// Largest credible depth, m. The docking approach starts within about 10 m.
    pub max_depth_m: f32,
    /// Half field of view, horizontal, as the normalised image coordinate of the edge
    /// (`tan` of the half angle): 320 px / 500 px for the default 640x480, f = 500 px camera.
    pub half_fov_x: f32,
    /// Half field of view, vertical, as a normalised coordinate: 240 px / 500 px.
    pub half_fov_y: f32,
    /// New frames in a row that may repeat the last valid frame's image point and depth bit
    /// for bit; the next such frame is rejected as [`MeasurementError::Frozen`] (and so are
    /// all that follow until the content changes). Default 5 (0.1 s at 50 Hz): with a
    /// tracker's noise of a fraction of a pixel, six identical frames in a row do not happen
    /// while the tracker works.
    pub frozen_frame_limit: u16,
}

impl Default for MeasurementLimits {
    fn default() -> Self {
        Self {
            max_depth_m: 50.0,
            half_fov_x: 0.64,
            half_fov_y: 0.48,
            frozen_frame_limit: 5,
        }
    }
}

/// Validated [`MeasurementLimits`] as the bit patterns of their limits, for the step's check
/// (see [`crate::nav::EnvelopeBits`] for why bits compare as the values do).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LimitBits {
    max_depth: u32,
    half_fov_x: u32,
    half_fov_y: u32,
}

impl LimitBits {
    /// The limits; `None` unless every one is positive and finite.
    pub fn new(limits: &MeasurementLimits) -> Option<Self> {
        let bits = |v: f32| (v > 0.0 && v.is_finite()).then_some(v.to_bits());
        Some(Self {
            max_depth: bits(limits.max_depth_m)?,
            half_fov_x: bits(limits.half_fov_x)?,
            half_fov_y: bits(limits.half_fov_y)?,
        })
    }
}

/// A validated image feature: image error (paper eq. (2)) and depth.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageFeature {
    /// Drogue centre, normalised image x.
    pub image_x: f32,
    /// Drogue centre, normalised image y.
    pub image_y: f32,
    /// Depth of the drogue plane, m.
    pub depth_m: f32,
}

/// Tracks the frame sequence: detects repeated and reordered frames and counts dropped ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SequenceTracker {
    last_seq: Option<u32>,
}

/// What [`SequenceTracker::observe`] learnt from one sequence number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SequenceCheck {
    /// A new frame; `dropped` frames were skipped since the previous one.
    New {
        /// Frames the camera numbered but that never arrived.
        dropped: u32,
    },
    /// Not a new frame.
    Rejected(MeasurementError),
}

impl SequenceTracker {
    /// Classifies `seq` against the last new frame and remembers it if it is new.
    ///
    /// Wrapping is handled: a forward step of less than 2^31 is new, anything else is late.
    pub fn observe(&mut self, seq: u32) -> SequenceCheck {
        let Some(last) = self.last_seq else {
            self.last_seq = Some(seq);
            return SequenceCheck::New { dropped: 0 };
        };
        let step = seq.wrapping_sub(last);
        if step == 0 {
            SequenceCheck::Rejected(MeasurementError::Repeated)
        } else if step >= 1 << 31 {
            SequenceCheck::Rejected(MeasurementError::OutOfOrder)
        } else {
            self.last_seq = Some(seq);
            SequenceCheck::New { dropped: step - 1 }
        }
    }

    /// Forgets the last frame (used when the controller is reset to standby).
    pub fn reset(&mut self) {
        self.last_seq = None;
    }
}

/// Detects a frozen measurement ([`MeasurementError::Frozen`]): remembers the bits of the
/// last valid frame's image point and depth and how many new frames in a row repeated them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FreezeDetector {
    /// Bits of the last valid frame's image x, image y and depth (meaningful when `primed`).
    last: [u32; 3],
    /// A valid frame has been seen since construction or the last reset.
    primed: bool,
    /// New frames in a row that repeated `last`.
    repeats: u16,
}

impl FreezeDetector {
    /// Passes `f` unless it is the `limit + 1`-th (or a later) new frame in a row to repeat
    /// the last valid feature bit for bit. Every frame is compared, a rejected one too, so a
    /// frozen stream stays rejected until its content changes.
    ///
    /// Bounded: three XORs and a compare (no `memcmp`: the step stays free of library loops).
    #[inline]
    pub fn observe(
        &mut self,
        f: ImageFeature,
        limit: u16,
    ) -> Result<ImageFeature, MeasurementError> {
        let bits = [
            f.image_x.to_bits(),
            f.image_y.to_bits(),
            f.depth_m.to_bits(),
        ];
        let same = (bits[0] ^ self.last[0]) | (bits[1] ^ self.last[1]) | (bits[2] ^ self.last[2]);
        if self.primed && same == 0 {
            self.repeats = self.repeats.saturating_add(1);
            if self.repeats > limit {
                return Err(MeasurementError::Frozen);
            }
        } else {
            self.last = bits;
            self.primed = true;
            self.repeats = 0;
        }
        Ok(f)
    }

    /// Forgets the last frame (used when the controller is reset to standby).
    pub fn reset(&mut self) {
        *self = Self::default();
    }
}

impl CameraMeasurement {
    /// [`CameraMeasurement::validate`] against limits that are positive and finite, with the
    /// same answer for every frame, comparing bit patterns. A frame inside the (finite)
    /// limits is finite, so a good frame passes with one test per value; which error a bad
    /// one has is worked out only then.
    #[inline]
    pub fn check(&self, limits: &LimitBits) -> Result<ImageFeature, MeasurementError> {
        use crate::num::abs_bits;
        let depth = self.depth_m.to_bits();
        // Positive depth: neither the sign bit set nor all bits zero (+0).
        if self.tracked
            && abs_bits(self.image_x) <= limits.half_fov_x
            && abs_bits(self.image_y) <= limits.half_fov_y
            && depth as i32 > 0
            && depth <= limits.max_depth
        {
            Ok(ImageFeature {
                image_x: self.image_x,
                image_y: self.image_y,
                depth_m: self.depth_m,
            })
        } else {
            Err(self.rejection(limits))
        }
    }

    /// Why a frame that failed [`CameraMeasurement::check`] fails, in
    /// [`CameraMeasurement::validate`]'s order. Out of line: the common path keeps nothing
    /// for it.
    #[cold]
    #[inline(never)]
    fn rejection(&self, limits: &LimitBits) -> MeasurementError {
        use crate::num::{INF_BITS, abs_bits};
        let (x, y, depth) = (
            abs_bits(self.image_x),
            abs_bits(self.image_y),
            self.depth_m.to_bits(),
        );
        if !self.tracked {
            MeasurementError::NotTracked
        } else if x >= INF_BITS || y >= INF_BITS || depth & 0x7FFF_FFFF >= INF_BITS {
            MeasurementError::NonFinite
        } else if depth as i32 <= 0 {
            // Finite: zero and negative depths (sign bit set, or all bits zero).
            MeasurementError::DepthNotPositive
        } else if depth > limits.max_depth {
            MeasurementError::DepthTooLarge
        } else {
            MeasurementError::OutsideFieldOfView
        }
    }

    /// Checks the frame's content (not its sequence) against `limits`.
    pub fn validate(&self, limits: &MeasurementLimits) -> Result<ImageFeature, MeasurementError> {
        if !self.tracked {
            return Err(MeasurementError::NotTracked);
        }
        if !(self.image_x.is_finite() && self.image_y.is_finite() && self.depth_m.is_finite()) {
            return Err(MeasurementError::NonFinite);
        }
        if self.depth_m <= 0.0 {
            return Err(MeasurementError::DepthNotPositive);
        }
        if self.depth_m > limits.max_depth_m {
            return Err(MeasurementError::DepthTooLarge);
        }
        if libm::fabsf(self.image_x) > limits.half_fov_x
            || libm::fabsf(self.image_y) > limits.half_fov_y
        {
            return Err(MeasurementError::OutsideFieldOfView);
        }
        Ok(ImageFeature {
            image_x: self.image_x,
            image_y: self.image_y,
            depth_m: self.depth_m,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn good() -> CameraMeasurement {
        CameraMeasurement {
            seq: 1,
            tracked: true,
            image_x: 0.3,
            image_y: -0.3,
            depth_m: 6.0,
            probe_tip: None,
        }
    }

    #[test]
    fn accepts_a_plausible_frame() {
        let f = good().validate(&MeasurementLimits::default()).unwrap();
        assert_eq!((f.image_x, f.image_y, f.depth_m), (0.3, -0.3, 6.0));
    }

    #[test]
    fn names_each_bad_content() {
        let lim = MeasurementLimits::default();
        let cases = [
            (
                CameraMeasurement {
                    tracked: false,
                    ..good()
                },
                MeasurementError::NotTracked,
            ),
            (
                CameraMeasurement {
                    image_x: f32::NAN,
                    ..good()
                },
                MeasurementError::NonFinite,
            ),
            (
                CameraMeasurement {
                    depth_m: f32::INFINITY,
                    ..good()
                },
                MeasurementError::NonFinite,
            ),
            (
                CameraMeasurement {
                    depth_m: 0.0,
                    ..good()
                },
                MeasurementError::DepthNotPositive,
            ),
            (
                CameraMeasurement {
                    depth_m: -1.0,
                    ..good()
                },
                MeasurementError::DepthNotPositive,
            ),
            (
                CameraMeasurement {
                    depth_m: 51.0,
                    ..good()
                },
                MeasurementError::DepthTooLarge,
            ),
            (
                CameraMeasurement {
                    image_x: 0.65,
                    ..good()
                },
                MeasurementError::OutsideFieldOfView,
            ),
            (
                CameraMeasurement {
                    image_y: -0.49,
                    ..good()
                },
                MeasurementError::OutsideFieldOfView,
            ),
        ];
        for (m, want) in cases {
            assert_eq!(m.validate(&lim), Err(want), "{m:?}");
        }
    }

    #[test]
    fn the_bit_check_answers_as_validate() {
        let lim = MeasurementLimits::default();
        let bits = LimitBits::new(&lim).expect("valid limits");
        let values = [
            0.0,
            -0.0,
            0.3,
            -0.3,
            0.64,
            -0.64,
            f32::from_bits(0.64_f32.to_bits() + 1),
            0.48,
            -0.480001,
            6.0,
            -6.0,
            50.0,
            50.000004,
            1e-42,
            -1e-42,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        for (i, &x) in values.iter().enumerate() {
            for &y in &values {
                for &depth_m in &values {
                    let m = CameraMeasurement {
                        seq: 0,
                        tracked: i % 7 != 3,
                        image_x: x,
                        image_y: y,
                        depth_m,
                        probe_tip: None,
                    };
                    assert_eq!(m.check(&bits), m.validate(&lim), "{m:?}");
                }
            }
        }
    }

    #[test]
    fn sequence_counts_drops_and_rejects_repeats_and_late_frames() {
        let mut s = SequenceTracker::default();
        assert_eq!(s.observe(10), SequenceCheck::New { dropped: 0 });
        assert_eq!(
            s.observe(10),
            SequenceCheck::Rejected(MeasurementError::Repeated)
        );
        assert_eq!(s.observe(13), SequenceCheck::New { dropped: 2 });
        assert_eq!(
            s.observe(12),
            SequenceCheck::Rejected(MeasurementError::OutOfOrder)
        );
        assert_eq!(s.observe(14), SequenceCheck::New { dropped: 0 });
    }

    fn feature_bits(x: u32, y: u32, depth: u32) -> ImageFeature {
        ImageFeature {
            image_x: f32::from_bits(x),
            image_y: f32::from_bits(y),
            depth_m: f32::from_bits(depth),
        }
    }

    #[test]
    fn a_frame_that_changed_in_any_two_fields_by_the_same_bits_is_not_frozen() {
        // With a limit of 0 the first repeat is rejected. Frames that differ from the last in
        // two fields by the same bit pattern are new content (a comparison that let the two
        // differences cancel would call them frozen).
        let base = (0.1_f32.to_bits(), (-0.2_f32).to_bits(), 5.0_f32.to_bits());
        let m = 0x0000_0100;
        for changed in [
            feature_bits(base.0 ^ m, base.1 ^ m, base.2),
            feature_bits(base.0 ^ m, base.1, base.2 ^ m),
            feature_bits(base.0, base.1 ^ m, base.2 ^ m),
        ] {
            let mut d = FreezeDetector::default();
            let first = feature_bits(base.0, base.1, base.2);
            assert!(d.observe(first, 0).is_ok());
            assert!(d.observe(changed, 0).is_ok(), "{changed:?}");
            // And the same frame again is a repeat.
            assert_eq!(d.observe(changed, 0), Err(MeasurementError::Frozen));
        }
    }

    #[test]
    fn a_reset_freeze_detector_takes_the_same_frame_as_new() {
        let f = feature_bits(0.1_f32.to_bits(), 0.2_f32.to_bits(), 3.0_f32.to_bits());
        let mut d = FreezeDetector::default();
        assert!(d.observe(f, 0).is_ok());
        assert_eq!(d.observe(f, 0), Err(MeasurementError::Frozen));
        d.reset();
        assert!(d.observe(f, 0).is_ok(), "forgotten by the reset");
        assert_eq!(d.observe(f, 0), Err(MeasurementError::Frozen));
    }

    #[test]
    fn every_measurement_error_has_its_own_message() {
        extern crate std;
        use std::string::ToString;
        let all = [
            MeasurementError::NotTracked,
            MeasurementError::NonFinite,
            MeasurementError::DepthNotPositive,
            MeasurementError::DepthTooLarge,
            MeasurementError::OutsideFieldOfView,
            MeasurementError::Repeated,
            MeasurementError::OutOfOrder,
            MeasurementError::Frozen,
        ];
        let texts: std::vec::Vec<_> = all.iter().map(|e| e.to_string()).collect();
        for (i, t) in texts.iter().enumerate() {
            assert!(!t.is_empty(), "{:?}", all[i]);
            assert!(
                texts.iter().filter(|u| *u == t).count() == 1,
                "{:?}: {t} not unique",
                all[i]
            );
        }
    }

    #[test]
    fn sequence_wraps() {
        let mut s = SequenceTracker::default();
        s.observe(u32::MAX);
        assert_eq!(s.observe(0), SequenceCheck::New { dropped: 0 });
        assert_eq!(
            s.observe(u32::MAX),
            SequenceCheck::Rejected(MeasurementError::OutOfOrder)
        );
    }
}

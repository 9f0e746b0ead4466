//! Wire messages between the flight computer and its peer (simulator or avionics bus).
//!
//! Each message is serialised with `postcard` and framed with COBS, so a frame is a run of
//! non-zero bytes ended by one `0x00`: a receiver that loses sync resynchronises at the next
//! zero. [`Uplink`] goes to the controller, [`Downlink`] comes from it.
//!
//! Invariant: every message fits in [`MAX_FRAME_LEN`] bytes (tested); decoding never panics
//! and names what went wrong ([`WireError`]).

use serde::{Deserialize, Serialize};

use crate::controller::{ControllerInput, ControllerOutput, Counters};

/// Protocol version carried in every message; bumped on any layout change.
pub const PROTOCOL_VERSION: u8 = 1;

/// Largest encoded frame, bytes, including the COBS overhead and the terminating zero.
pub const MAX_FRAME_LEN: usize = 160;

/// Message to the controller: one step's input.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Uplink {
    /// [`PROTOCOL_VERSION`] of the sender.
    pub version: u8,
    /// The step's input.
    pub input: ControllerInput,
}

/// Message from the controller: one step's output and the running counters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Downlink {
    /// [`PROTOCOL_VERSION`] of the sender.
    pub version: u8,
    /// The step's output.
    pub output: ControllerOutput,
    /// Counters after the step.
    pub counters: Counters,
}

/// Why a frame could not be encoded or decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WireError {
    /// The output buffer is too small for the frame.
    BufferTooSmall,
    /// The frame is not valid COBS or does not deserialise into the message.
    Malformed,
    /// The frame decoded but carries another protocol version.
    VersionMismatch,
}

/// Encodes `msg` as one COBS frame into `buf`; returns the used part (ending in `0x00`).
pub fn encode<'a, T: Serialize>(msg: &T, buf: &'a mut [u8]) -> Result<&'a mut [u8], WireError> {
    postcard::to_slice_cobs(msg, buf).map_err(|_| WireError::BufferTooSmall)
}

/// Decodes one COBS frame in place and checks its protocol version.
fn decode<'de, T: Deserialize<'de>>(
    frame: &'de mut [u8],
    version: fn(&T) -> u8,
) -> Result<T, WireError> {
    let m: T = postcard::from_bytes_cobs(frame).map_err(|_| WireError::Malformed)?;
    if version(&m) == PROTOCOL_VERSION {
        Ok(m)
    } else {
        Err(WireError::VersionMismatch)
    }
}

/// Decodes one COBS uplink frame (with or without its terminating zero) in place.
pub fn decode_uplink(frame: &mut [u8]) -> Result<Uplink, WireError> {
    decode(frame, |m: &Uplink| m.version)
}

/// Decodes one COBS downlink frame in place.
pub fn decode_downlink(frame: &mut [u8]) -> Result<Downlink, WireError> {
    decode(frame, |m: &Downlink| m.version)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::controller::StatusFlags;
    use crate::measurement::{CameraMeasurement, MeasurementError};
    use crate::mode::{BreakawayReason, Mode, ModeRequest};

    fn uplink() -> Uplink {
        let mut input = ControllerInput {
            measurement: CameraMeasurement {
                seq: u32::MAX,
                tracked: true,
                image_x: -0.3,
                image_y: 0.2,
                depth_m: 6.5,
            },
            probe_contact: true,
            request: ModeRequest::Engage,
            ..Default::default()
        };
        input.nav.lon.v_mps = f32::NAN; // must survive the trip bit for bit
        input.nav.lat.r_radps = -1e-30;
        Uplink {
            version: PROTOCOL_VERSION,
            input,
        }
    }

    fn downlink() -> Downlink {
        let counters = Counters {
            steps: u32::MAX,
            frames_dropped: 77_777,
            ..Default::default()
        };
        let output = ControllerOutput {
            mode: Mode::Breakaway,
            breakaway_reason: Some(BreakawayReason::PassedDroguePlane),
            status: StatusFlags(u16::MAX),
            measurement_error: Some(MeasurementError::OutOfOrder),
            step: u32::MAX,
            ..Default::default()
        };
        Downlink {
            version: PROTOCOL_VERSION,
            output,
            counters: Counters {
                not_tracked: u32::MAX,
                ..counters
            },
        }
    }

    #[test]
    fn uplink_round_trips() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let m = uplink();
        let frame = encode(&m, &mut buf).unwrap();
        assert_eq!(frame.last(), Some(&0));
        assert!(!frame[..frame.len() - 1].contains(&0));
        let back = decode_uplink(frame).unwrap();
        assert!(back.input.nav.lon.v_mps.is_nan());
        assert_eq!(back.input.measurement, m.input.measurement);
        assert_eq!(back.input.request, ModeRequest::Engage);
    }

    #[test]
    fn largest_downlink_fits_and_round_trips() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let m = downlink();
        let frame = encode(&m, &mut buf).unwrap();
        assert!(frame.len() <= MAX_FRAME_LEN);
        assert_eq!(decode_downlink(frame).unwrap(), m);
    }

    #[test]
    fn names_bad_frames() {
        let mut small = [0u8; 8];
        assert_eq!(
            encode(&downlink(), &mut small).unwrap_err(),
            WireError::BufferTooSmall
        );
        let mut junk = [0x05, 0x01, 0x00];
        assert_eq!(decode_uplink(&mut junk), Err(WireError::Malformed));
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode(
            &Uplink {
                version: 9,
                ..uplink()
            },
            &mut buf,
        )
        .unwrap();
        assert_eq!(decode_uplink(frame), Err(WireError::VersionMismatch));
    }
}

//! What the link costs on the MCU: one measurement frame decoded, one command frame encoded,
//! the CRC alone, and one controller step, each read from a [`CostCounter`].
//!
//! Place in the data flow: none; the `qemu` board runs this when its semihosting command line
//! says `bench` and prints the result (instructions, exact under `-icount shift=0`). The
//! frames are those of an approach: the 20th step after an engage near the paper's start,
//! with a perturbed navigation sample (every field non-zero, as in flight). Decoding cost
//! depends on the content: each zero byte of the payload is a COBS block boundary, dearer
//! than a data byte, so the same frame with the navigation at exactly zero (48 zero bytes) is
//! measured too.
//!
//! Invariant: the figures are of this module's own work only (the counter is read right
//! before and after each measured call; one count of each pair is the read itself).

use core::hint::black_box;

use ibvs_core::nav::NavSample;
use ibvs_core::wire::{
    CRC32C, Downlink, FrameDecoder, LinkCounters, MAX_FRAME_LEN, Uplink, encode_downlink,
    encode_uplink,
};
use ibvs_core::{Controller, ControllerConfig, ModeRequest};

use crate::app::CostCounter;
use crate::one_step::engage_input;

/// Costs in the counter's unit, and the frame sizes, bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CodecCosts {
    /// Measurement frame on the wire, bytes.
    pub measurement_frame_len: usize,
    /// Command frame on the wire, bytes.
    pub command_frame_len: usize,
    /// Decoding the measurement frame: every byte through [`FrameDecoder::feed`] (COBS, CRC,
    /// header check) and the postcard deserialisation.
    pub decode_measurement: u32,
    /// The same with the navigation sample at exactly zero (48 zero payload bytes).
    pub decode_measurement_zero_nav: u32,
    /// The CRC-32C over the measurement frame's payload alone (part of the decode).
    pub crc_measurement: u32,
    /// Encoding the command frame: postcard, CRC, COBS.
    pub encode_command: u32,
    /// The controller step that produced it.
    pub step: u32,
}

/// A plausible navigation sample near trim (every state non-zero).
fn perturbed_nav() -> NavSample {
    NavSample::from_array([
        0.3, -0.2, 0.012, 0.4, 0.008, 0.003, 0.5, 0.004, -0.01, 0.002, 0.003, -0.002,
    ])
}

/// Decodes `frame` through a fresh decoder; the cost.
fn decode_cost<C: CostCounter>(frame: &[u8]) -> u32 {
    let mut decoder = FrameDecoder::new();
    let mut decoded = None;
    let t0 = C::now();
    for &b in black_box(frame) {
        if let Some(r) = decoder.feed(b) {
            decoded = Some(r.and_then(|p| p.uplink()));
        }
    }
    let cost = C::now().wrapping_sub(t0);
    black_box(decoded);
    cost
}

/// Measures the costs once (the figures are deterministic under QEMU).
pub fn measure<C: CostCounter>() -> CodecCosts {
    let mut controller = match Controller::new(ControllerConfig::default()) {
        Ok(c) => c,
        Err(_) => return CodecCosts::default(),
    };
    let mut input = engage_input();
    input.nav = perturbed_nav();
    let mut step = 0;
    let mut output = controller.step(&input);
    input.request = ModeRequest::None;
    for _ in 0..19 {
        input.measurement.seq += 1;
        let t0 = C::now();
        output = controller.step(black_box(&input));
        step = C::now().wrapping_sub(t0);
    }
    let up = Uplink {
        seq: input.measurement.seq,
        input,
    };
    let down = Downlink {
        seq: up.seq,
        echo_seq: Some(up.seq),
        output,
        counters: *controller.counters(),
        link: LinkCounters {
            frames_ok: up.seq,
            ..LinkCounters::default()
        },
        ..Downlink::default()
    };

    let mut up_buf = [0u8; MAX_FRAME_LEN];
    let up_len = encode_uplink(&up, &mut up_buf).map_or(0, <[u8]>::len);
    let decode_measurement = decode_cost::<C>(&up_buf[..up_len]);

    let mut zero_nav = up;
    zero_nav.input.nav = NavSample::default();
    let mut zero_buf = [0u8; MAX_FRAME_LEN];
    let zero_len = encode_uplink(&zero_nav, &mut zero_buf).map_or(0, <[u8]>::len);
    let decode_measurement_zero_nav = decode_cost::<C>(&zero_buf[..zero_len]);

    // The CRC over a payload of the same length (frame minus COBS code and zero).
    let payload = [0x5Au8; MAX_FRAME_LEN];
    let t0 = C::now();
    black_box(CRC32C.checksum(black_box(&payload[..up_len.saturating_sub(2)])));
    let crc_measurement = C::now().wrapping_sub(t0);

    let mut down_buf = [0u8; MAX_FRAME_LEN];
    let t0 = C::now();
    let down_len = encode_downlink(black_box(&down), &mut down_buf).map_or(0, <[u8]>::len);
    let encode_command = C::now().wrapping_sub(t0);

    CodecCosts {
        measurement_frame_len: up_len,
        command_frame_len: down_len,
        decode_measurement,
        decode_measurement_zero_nav,
        crc_measurement,
        encode_command,
        step,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::NoCounter;

    #[test]
    fn measures_real_frames() {
        let c = measure::<NoCounter>();
        assert!((73..=81).contains(&c.measurement_frame_len), "{c:?}");
        assert!((93..=251).contains(&c.command_frame_len), "{c:?}");
        assert_eq!(c.decode_measurement, 0); // no counter on the host
    }
}

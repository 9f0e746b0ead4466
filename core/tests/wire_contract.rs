//! The link's contract as `core/src/wire.rs` documents it, checked from the outside: the
//! largest body a frame carries follows from the frame's limit and its fixed parts; the
//! command frame's status bits are eight distinct bits that `LinkStatus::contains` tests as a
//! set; the reset causes that hold the flight computer in standby are the unplanned ones;
//! every frame error has its own message; every encoder returns one whole frame; the
//! decoder's idle state and the kinds each side reads.

use ibvs_core::ControllerConfig;
use ibvs_core::wire::{
    CRC_LEN, Downlink, FlightComputerMessage, FrameDecoder, FrameKind, HEADER_LEN, LinkStatus,
    MAX_BODY_LEN, MAX_FRAME_LEN, MAX_PAYLOAD_LEN, ResetCause, Telemetry, Uplink, WireError,
    decode_flight_computer_message, decode_peer_message, encode_config_read, encode_config_write,
    encode_downlink, encode_message, encode_telemetry, encode_telemetry_request, encode_uplink,
};

/// The layout: a frame of at most `MAX_FRAME_LEN` bytes ends in its zero, and COBS adds one
/// code byte per started block of 254 payload bytes; the payload is the header, the body and
/// the CRC.
#[test]
fn the_largest_body_fills_the_largest_frame() {
    assert_eq!(
        MAX_PAYLOAD_LEN + MAX_PAYLOAD_LEN.div_ceil(254) + 1,
        MAX_FRAME_LEN,
        "the payload, its code bytes and the zero fill the frame"
    );
    assert_eq!(MAX_BODY_LEN, MAX_PAYLOAD_LEN - HEADER_LEN - CRC_LEN);
    assert_eq!(MAX_BODY_LEN, 694, "the module doc's figure");
}

/// A body of exactly `MAX_BODY_LEN` bytes encodes (bytes without zeros, so the frame is its
/// longest: one code byte per block) within `MAX_FRAME_LEN`, and one byte more is refused as
/// too large, not written past the limit.
#[test]
fn a_body_of_the_largest_size_is_encoded_and_one_byte_more_is_too_large() {
    // postcard writes a byte sequence as its length (a 2-byte varint here) and the bytes.
    let body = vec![0x5Au8; MAX_BODY_LEN - 2];
    let mut out = [0u8; 2 * MAX_FRAME_LEN];
    let frame = encode_message(FrameKind::ConfigWrite, &body, &mut out).expect("fits");
    assert!(frame.len() <= MAX_FRAME_LEN, "{} bytes", frame.len());
    assert_eq!(frame.last(), Some(&0));
    // The peer's decoder takes it whole (a configuration write whose body is no
    // configuration: malformed, which means it passed COBS, length and CRC).
    assert_eq!(decode_peer_message(frame), Err(WireError::Malformed));

    let body = vec![0x5Au8; MAX_BODY_LEN - 1];
    assert_eq!(
        encode_message(FrameKind::ConfigWrite, &body, &mut out),
        Err(WireError::TooLarge)
    );
}

/// `MAX_FRAME_LEN` bytes of output suffice for any frame (the encoders' docs): a message too
/// large for every frame is `TooLarge` there, never `BufferTooSmall`, and a buffer too short
/// for a message that would fit a frame is `BufferTooSmall`.
#[test]
fn too_large_is_the_message_and_too_small_is_the_buffer() {
    let mut out = [0u8; MAX_FRAME_LEN];
    for len in [MAX_BODY_LEN, MAX_BODY_LEN + 10, 700, 2000] {
        let body = vec![0x5Au8; len];
        assert_eq!(
            encode_message(FrameKind::ConfigWrite, &body, &mut out),
            Err(WireError::TooLarge),
            "{len} bytes"
        );
    }
    let body = vec![0x5Au8; 300];
    assert_eq!(
        encode_message(FrameKind::ConfigWrite, &body, &mut [0u8; 200]),
        Err(WireError::BufferTooSmall)
    );
}

const BITS: [u8; 8] = [
    LinkStatus::BOOT,
    LinkStatus::RETRANSMIT,
    LinkStatus::FREE_RUNNING,
    LinkStatus::INPUT_HELD,
    LinkStatus::STALE,
    LinkStatus::PANIC,
    LinkStatus::PREVIOUS_PANIC,
    LinkStatus::STORED_CONFIG,
];

/// The status byte's eight flags are its eight bits, bit 0 first in the order the module
/// lists them, so any set of them travels in one byte and reads back apart.
#[test]
fn the_status_flags_are_the_eight_bits_in_order() {
    for (i, bit) in BITS.into_iter().enumerate() {
        assert_eq!(bit, 1 << i, "flag {i}");
    }
}

/// `contains` is true exactly when every bit of the mask is set.
#[test]
fn contains_asks_for_every_bit_of_the_mask() {
    let status = LinkStatus(LinkStatus::BOOT | LinkStatus::STALE);
    assert!(status.contains(LinkStatus::BOOT));
    assert!(status.contains(LinkStatus::STALE));
    assert!(status.contains(LinkStatus::BOOT | LinkStatus::STALE));
    assert!(!status.contains(LinkStatus::PANIC));
    assert!(!status.contains(LinkStatus::BOOT | LinkStatus::PANIC));
    assert!(status.contains(0), "the empty mask");
    assert!(!LinkStatus(0).contains(LinkStatus::STORED_CONFIG));
}

/// An operator's deliberate start (power-on, the reset pin, a software reset) engages as
/// asked; every other cause, one the board could not tell included, waits for the peer's
/// acknowledgement.
#[test]
fn only_an_unplanned_reset_needs_an_acknowledgement() {
    for cause in [ResetCause::PowerOn, ResetCause::Pin, ResetCause::Software] {
        assert!(!cause.needs_acknowledgement(), "{cause:?}");
    }
    for cause in [
        ResetCause::Unknown,
        ResetCause::BrownOut,
        ResetCause::IndependentWatchdog,
        ResetCause::WindowWatchdog,
        ResetCause::LowPower,
    ] {
        assert!(cause.needs_acknowledgement(), "{cause:?}");
    }
}

/// Each rejection reads as its own message, so a log line says which check failed.
#[test]
fn every_frame_error_has_its_own_message() {
    let errors = [
        WireError::BufferTooSmall,
        WireError::TooLarge,
        WireError::Cobs,
        WireError::Oversize,
        WireError::TooShort,
        WireError::Crc,
        WireError::VersionMismatch,
        WireError::WrongKind,
        WireError::Malformed,
    ];
    let messages: Vec<String> = errors.iter().map(ToString::to_string).collect();
    for (e, m) in errors.iter().zip(&messages) {
        assert!(m.len() > 8, "{e:?}: {m:?}");
        assert_eq!(
            messages.iter().filter(|n| *n == m).count(),
            1,
            "{e:?}: {m:?}"
        );
    }
    assert!(messages[5].contains("CRC"));
    assert!(messages[2].contains("COBS"));
}

/// Every encoder hands back exactly one frame: its bytes free of zeros but the last, so the
/// receiver's next frame starts right after it. Frames of one COBS block (requests, a
/// measurement, telemetry) are their payload, the code byte and the zero; a configuration
/// write is longer than a block.
#[test]
fn every_encoder_returns_one_frame_ending_in_its_only_zero() {
    let mut out = [0xEEu8; MAX_FRAME_LEN];
    let one_frame = |frame: &[u8], what: &str| {
        assert_eq!(frame.last(), Some(&0), "{what}");
        assert_eq!(frame.iter().filter(|&&b| b == 0).count(), 1, "{what}");
    };
    let frame = encode_config_read(&mut out).expect("read");
    one_frame(frame, "configuration read");
    // version, kind, no body, CRC: 6 bytes of payload, one code byte, the zero.
    assert_eq!(frame.len(), HEADER_LEN + CRC_LEN + 2);
    let frame = encode_telemetry_request(&mut out).expect("request");
    one_frame(frame, "telemetry request");
    assert_eq!(frame.len(), HEADER_LEN + CRC_LEN + 2);
    one_frame(
        encode_uplink(&Uplink::default(), &mut out).expect("uplink"),
        "measurement",
    );
    one_frame(
        encode_telemetry(&Telemetry::default(), &mut out).expect("telemetry"),
        "telemetry",
    );
    let frame = encode_config_write(&ControllerConfig::default(), &mut out).expect("write");
    one_frame(frame, "configuration write");
    assert!(
        frame.len() > 256,
        "more than one block: {} bytes",
        frame.len()
    );
}

/// A configuration read or a telemetry request carries nothing: `Payload::empty` takes an
/// empty body and names any other malformed.
#[test]
fn an_empty_body_is_nothing_else() {
    let mut out = [0u8; MAX_FRAME_LEN];
    let mut decoder = FrameDecoder::new();
    let frame = encode_config_read(&mut out).expect("read").to_vec();
    let payload = decoder
        .feed_slice(&frame)
        .1
        .expect("a frame")
        .expect("valid");
    assert_eq!(payload.empty(), Ok(()));
    let frame = encode_message(FrameKind::ConfigRead, &7u8, &mut out)
        .expect("body")
        .to_vec();
    let payload = decoder
        .feed_slice(&frame)
        .1
        .expect("a frame")
        .expect("valid");
    assert_eq!(payload.empty(), Err(WireError::Malformed));
}

/// The peer reads a command frame as the command it is.
#[test]
fn the_peer_reads_a_command_frame() {
    let mut out = [0u8; MAX_FRAME_LEN];
    let down = Downlink {
        seq: 7,
        echo_seq: Some(6),
        config_id: 0xC0FF_EE00,
        ..Downlink::default()
    };
    let frame = encode_downlink(&down, &mut out).expect("command");
    assert_eq!(
        decode_flight_computer_message(frame),
        Ok(FlightComputerMessage::Command(down))
    );
}

/// The decoder is idle only between frames: not once a frame's first byte came, nor while
/// it skips the rest of a rejected one, and again after each frame's zero.
#[test]
fn the_decoder_is_idle_only_between_frames() {
    let mut d = FrameDecoder::new();
    assert!(d.is_idle());
    assert!(d.feed(0x03).is_none());
    assert!(!d.is_idle(), "inside a frame");
    assert!(d.feed(0).is_some(), "a frame ended");
    assert!(d.is_idle());
    // Past the buffer: rejected, the rest skipped up to the zero.
    let garbage = [0x42u8; MAX_FRAME_LEN + 3];
    assert_eq!(d.feed_slice(&garbage).0, garbage.len());
    assert!(!d.is_idle(), "skipping a rejected frame");
    assert_eq!(
        d.feed(0).map(|r| r.map(|_| ())),
        Some(Err(WireError::Oversize))
    );
    assert!(d.is_idle());
}

/// The decoder takes a payload of exactly `MAX_PAYLOAD_LEN` bytes and refuses one byte more
/// as oversize, for a frame of short blocks (zeros in its payload, decoded a block a step)
/// as for one of full blocks (no zeros, decoded byte by byte).
#[test]
fn the_decoder_takes_the_largest_payload_and_not_one_byte_more() {
    let frame_of = |payload: &[u8]| {
        let mut frame = cobs::encode_vec(payload);
        frame.push(0);
        frame
    };
    for zero_every in [Some(100), None] {
        for extra in [0, 1] {
            // A body that is no configuration, with a good CRC: malformed, or oversize.
            let mut payload = vec![
                ibvs_core::wire::PROTOCOL_VERSION,
                FrameKind::ConfigWrite.byte(),
            ];
            payload.extend((0..MAX_BODY_LEN + extra).map(|i| match zero_every {
                Some(k) if i % k == 0 => 0,
                _ => 0x5A,
            }));
            payload.extend(ibvs_core::wire::crc32c(&payload).to_le_bytes());
            let frame = frame_of(&payload);
            let want = if extra == 0 {
                WireError::Malformed
            } else {
                WireError::Oversize
            };
            assert_eq!(
                decode_peer_message(&frame),
                Err(want),
                "{} payload bytes, zeros every {zero_every:?}",
                payload.len()
            );
        }
    }
}

//! Criterion benchmark of the link codec on the host: one measurement frame and one command
//! frame, each encoded (postcard, CRC-32C, COBS) and decoded (byte by byte through the
//! streaming [`FrameDecoder`], then postcard).
//!
//! The frames are those of an approach step (every navigation state non-zero, as in flight),
//! the same content the firmware's `bench` measures on the MCU (`firmware/src/bench.rs`).
//!
//! Run with `cargo bench -p ibvs-core --bench codec`. Host numbers: a relative measure;
//! the MCU's are in `docs/benchmarks.md`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use ibvs_core::measurement::CameraMeasurement;
use ibvs_core::nav::NavSample;
use ibvs_core::wire::{
    Downlink, FrameDecoder, MAX_FRAME_LEN, Uplink, encode_downlink, encode_uplink,
};
use ibvs_core::{Controller, ControllerConfig, ControllerInput, ModeRequest};

/// A measurement frame of an approach and the command frame answering it.
fn messages() -> (Uplink, Downlink) {
    let mut controller = Controller::new(ControllerConfig::default()).expect("default config");
    let input = ControllerInput {
        measurement: CameraMeasurement {
            seq: 20,
            tracked: true,
            image_x: 0.31,
            image_y: -0.29,
            depth_m: 5.6,
            probe_tip: None,
        },
        nav: NavSample::from_array([
            0.3, -0.2, 0.012, 0.4, 0.008, 0.003, 0.5, 0.004, -0.01, 0.002, 0.003, -0.002,
        ]),
        probe_contact: false,
        autopilot_ready: true,
        request: ModeRequest::Engage,
    };
    let output = controller.step(&input);
    let up = Uplink { seq: 20, input };
    let down = Downlink {
        seq: 20,
        echo_seq: Some(20),
        output,
        config_id: 0x1234_5678,
        ..Downlink::default()
    };
    (up, down)
}

fn benches(c: &mut Criterion) {
    let (up, down) = messages();
    let mut up_buf = [0u8; MAX_FRAME_LEN];
    let up_frame = encode_uplink(&up, &mut up_buf).expect("fits").to_vec();
    let mut down_buf = [0u8; MAX_FRAME_LEN];
    let down_frame = encode_downlink(&down, &mut down_buf)
        .expect("fits")
        .to_vec();

    let mut group = c.benchmark_group("codec");
    let mut buf = [0u8; MAX_FRAME_LEN];
    group.bench_function("encode_measurement_frame", |b| {
        b.iter(|| encode_uplink(black_box(&up), &mut buf).map(<[u8]>::len))
    });
    group.bench_function("decode_measurement_frame", |b| {
        b.iter(|| {
            let mut d = FrameDecoder::new();
            let mut out = None;
            for &byte in black_box(&up_frame) {
                if let Some(r) = d.feed(byte) {
                    out = Some(r.and_then(|p| p.uplink()));
                }
            }
            out
        })
    });
    group.bench_function("encode_command_frame", |b| {
        b.iter(|| encode_downlink(black_box(&down), &mut buf).map(<[u8]>::len))
    });
    group.bench_function("decode_command_frame", |b| {
        b.iter(|| {
            let mut d = FrameDecoder::new();
            let mut out = None;
            for &byte in black_box(&down_frame) {
                if let Some(r) = d.feed(byte) {
                    out = Some(r.and_then(|p| p.downlink()));
                }
            }
            out
        })
    });
    group.finish();
}

criterion_group!(codec, benches);
criterion_main!(codec);

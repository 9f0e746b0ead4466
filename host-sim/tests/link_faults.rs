//! Fault injection through the real serial link: the firmware runs in QEMU and the host
//! corrupts, drops, delays and duplicates measurement frames and sends garbage.
//!
//! What must hold over a faulty link:
//! - the firmware recovers framing after every fault (the next good frame is answered);
//! - it counts each error: its reported [`LinkCounters`] equal those of a replay of every
//!   byte the host sent through the core's own decoder (an exact model, since both ends
//!   share `ibvs_core::wire`), and the expected numbers written out by hand;
//! - it never emits a non-finite or out-of-limit command;
//! - it breaks away when the link is lost long enough: in the free-running schedule (the
//!   flight one) the link goes stale after 100 ms and the core breaks away after its hold
//!   limit (0.5 s), open loop. (In lockstep the firmware has no clock of its own; the
//!   host's lockstep timeout is what fails, and the step returns the held output.)
//!
//! Needs `qemu-system-arm` and the firmware ELF (built on demand, see `tests/pil.rs`).
//! Lockstep tests fly the ideal scenario (deterministic); the free-running test depends on
//! wall-clock pacing and checks only what holds with wide margins.

use std::time::{Duration, Instant};

use host_sim::pil::{
    Fault, FaultPlan, FirmwareSchedule, PilError, PilFlightComputer, PilLink, PilOptions,
    firmware_elf,
};
use host_sim::sim::{Run, Scenario, run};
use ibvs_core::controller::{ControllerInput, ControllerOutput, StatusFlags};
use ibvs_core::measurement::{CameraMeasurement, SequenceTracker};
use ibvs_core::nav::NavSample;
use ibvs_core::wire::{
    Downlink, FrameDecoder, LinkCounters, LinkStatus, MAX_FRAME_LEN, PeerMessage, Uplink,
    encode_downlink,
};
use ibvs_core::{BreakawayReason, Controller, ControllerConfig, Mode, ModeRequest};

/// What the firmware must have counted, from every byte the host sent.
fn replay(sent: &[u8]) -> LinkCounters {
    let mut d = FrameDecoder::new();
    let mut seq = SequenceTracker::default();
    let mut c = LinkCounters::default();
    for &b in sent {
        if let Some(r) = d.feed(b) {
            match r.and_then(|p| p.peer_message()) {
                Ok(PeerMessage::Measurement(u)) => {
                    c.count_sequence(seq.observe(u.seq));
                }
                // A telemetry request (the host's, at the end) is taken, not counted.
                Ok(_) => {}
                Err(e) => c.count(e),
            }
        }
    }
    c
}

/// The receive-side counters of `c` (those the replay can predict).
fn receive_side(c: &LinkCounters) -> [u32; 8] {
    [
        c.frames_ok,
        c.corrupt,
        c.oversize,
        c.malformed,
        c.wrong_version,
        c.seq_gap,
        c.seq_repeat,
        c.seq_old,
    ]
}

fn assert_commands_safe(outputs: impl IntoIterator<Item = ControllerOutput>) {
    let lim = ControllerConfig::default().actuators;
    for (k, o) in outputs.into_iter().enumerate() {
        for (i, c) in o.command.as_array().iter().enumerate() {
            assert!(
                c.is_finite() && (lim.min[i]..=lim.max[i]).contains(c),
                "frame {k}: command {i} = {c}"
            );
        }
    }
}

/// Pseudo-random bytes (xorshift), zeros included.
fn garbage(n: usize, mut x: u64) -> Vec<u8> {
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 29) as u8 & 0x3F // many zeros: 1 in 64
        })
        .collect()
}

fn pil_run(opts: PilOptions) -> (Run, PilFlightComputer) {
    let elf = firmware_elf().expect("firmware ELF");
    let mut pil = PilFlightComputer::spawn_with(&elf, opts).expect("QEMU with the firmware");
    let r = run(&Scenario::ideal(), &mut pil).expect("PIL run");
    (r, pil)
}

/// Lockstep, no retransmission: every fault kind at chosen steps. Lost frames cost one step
/// each (the held output is flown), are counted on both sides, and the docking still
/// succeeds.
#[test]
fn lockstep_counts_every_fault_recovers_framing_and_still_docks() {
    let mut tail_garbage = garbage(64, 0x9E37_79B9_7F4A_7C15);
    *tail_garbage.last_mut().expect("non-empty") = 0x17; // runs into the frame: frame lost
    let mut flushed_garbage = garbage(64, 0x0123_4567_89AB_CDEF);
    flushed_garbage.push(0); // ends in a zero: the frame after it survives
    let mut oversize = vec![0x55; MAX_FRAME_LEN + 80];
    oversize.push(0);
    let mut wrong_kind = vec![0u8];
    let mut buf = [0u8; MAX_FRAME_LEN];
    wrong_kind.extend_from_slice(encode_downlink(&Downlink::default(), &mut buf).expect("fits"));

    let faults = FaultPlan::new()
        .at(
            20,
            Fault::CorruptByte {
                index: 10,
                mask: 0x20,
            },
        )
        .at(
            40,
            Fault::CorruptByte {
                index: 0,
                mask: 0x01,
            },
        ) // the COBS code byte
        .at(60, Fault::Drop)
        .at(80, Fault::GarbageBefore(tail_garbage))
        .at(100, Fault::GarbageBefore(flushed_garbage))
        .at(120, Fault::GarbageBefore(oversize))
        .at(140, Fault::GarbageBefore(wrong_kind))
        .at(160, Fault::Duplicate)
        .at(180, Fault::Delay(Duration::from_millis(150)))
        .at(200, Fault::Drop)
        .at(201, Fault::Drop)
        .at(202, Fault::Drop);
    let lost = 7; // frames 20, 40, 60, 80, 200, 201, 202
    let opts = PilOptions {
        // Generous, so that a slow machine does not add a timeout of its own.
        step_timeout: Duration::from_secs(1),
        retries: 0,
        faults,
        ..PilOptions::default()
    };
    let (r, mut pil) = pil_run(opts);
    // The counters as they are now (the lockstep firmware sends them on request).
    let telemetry = pil.refresh_telemetry().expect("telemetry");
    let stats = pil.stats();
    eprintln!("{:?}\n{stats:#?}", r.summary);

    // Exactly what the bytes on the wire imply, and by hand.
    let fw = telemetry.link;
    assert_eq!(
        receive_side(&fw),
        receive_side(&replay(pil.link().sent_bytes()))
    );
    let steps = r.samples.len() as u32;
    assert_eq!(fw.frames_ok, steps - lost);
    assert_eq!((fw.seq_gap, fw.seq_repeat, fw.seq_old), (lost, 1, 0));
    assert_eq!((fw.oversize, fw.wrong_version, fw.malformed), (1, 1, 0));
    assert!(
        fw.corrupt >= 3,
        "two corrupted frames and the garbage: {}",
        fw.corrupt
    );
    assert_eq!(fw.rx_errors + fw.tx_errors + fw.tx_dropped, 0);
    assert_eq!(fw.deadline_overruns, 0, "every answer within the deadline");
    // The controller saw the camera frames of the lost steps missing.
    assert_eq!(telemetry.counters.frames_dropped, lost);
    assert_eq!(telemetry.counters.steps, steps - lost);
    assert_eq!(stats.firmware_counters, telemetry.counters);
    // The host: one timeout and one held output per lost frame; the duplicate's answer
    // arrived unasked.
    let h = stats.host;
    assert_eq!(
        (h.timeouts, h.failed_steps),
        (u64::from(lost), u64::from(lost))
    );
    assert_eq!(h.unexpected_frames, 1);
    assert_eq!(h.rx.rejected_frames(), 0);

    assert_commands_safe(pil.history().iter().map(|d| d.output));
    assert_commands_safe(r.samples.iter().map(|s| s.output));
    assert!(r.summary.docked, "{:?}", r.summary);
}

/// Lockstep with one retransmission: a corrupted or dropped frame is sent again after the
/// timeout, the firmware steps once per frame, and the run is bit-identical to the
/// in-process one. A frame delayed within the timeout changes nothing.
#[test]
fn lockstep_retransmission_makes_lost_frames_harmless() {
    let faults = FaultPlan::new()
        .at(
            30,
            Fault::CorruptByte {
                index: 33,
                mask: 0x81,
            },
        )
        .at(60, Fault::Drop)
        .at(90, Fault::Delay(Duration::from_millis(100)));
    let opts = PilOptions {
        step_timeout: Duration::from_millis(500),
        retries: 1,
        faults,
        ..PilOptions::default()
    };
    let (got, mut pil) = pil_run(opts);
    let mut controller = Controller::new(ControllerConfig::default()).expect("config");
    let reference = run(&Scenario::ideal(), &mut controller).expect("in-process run");
    pil.refresh_telemetry().expect("telemetry");
    let stats = pil.stats();
    assert_eq!(got.samples.len(), reference.samples.len());
    for (k, (a, b)) in got.samples.iter().zip(&reference.samples).enumerate() {
        assert_eq!(a.output, b.output, "step {k}");
    }
    let fw = stats.firmware_link;
    assert_eq!(
        receive_side(&fw),
        receive_side(&replay(pil.link().sent_bytes()))
    );
    assert_eq!((fw.corrupt, fw.seq_gap, fw.seq_repeat), (1, 0, 0));
    let h = stats.host;
    assert_eq!((h.retransmissions, h.timeouts, h.failed_steps), (2, 2, 0));
}

/// A steady approach input: the drogue tracked near the paper's start, navigation at trim.
fn approach_input(cam_seq: u32, request: ModeRequest) -> ControllerInput {
    ControllerInput {
        measurement: CameraMeasurement {
            seq: cam_seq,
            tracked: true,
            image_x: 0.1,
            image_y: -0.05,
            // A slowly closing drogue: every frame's content differs, as a working
            // tracker's does (the core rejects a frozen one).
            depth_m: 6.0 - 0.001 * (cam_seq % 1000) as f32,
            probe_tip: None,
        },
        nav: NavSample::default(),
        probe_contact: false,
        autopilot_ready: true,
        request,
    }
}

/// Free-running (the flight schedule): a frame a period of the firmware's clock, then
/// silence, then frames again. The firmware keeps sending a command frame every period; after the
/// link timeout it marks the link stale (navigation invalid), and after the core's hold
/// limit it breaks away (`MeasurementLost`) open loop: trim surfaces, throttle cut.
#[test]
fn free_running_breaks_away_when_the_link_is_lost_and_reports_it() {
    let elf = firmware_elf().expect("firmware ELF");
    let opts = PilOptions {
        schedule: FirmwareSchedule::FreeRunning,
        ..PilOptions::default()
    };
    let mut link = PilLink::spawn(&elf, &opts).expect("QEMU with the firmware");
    assert!(
        link.boot_frame()
            .link_status
            .contains(LinkStatus::FREE_RUNNING)
    );
    let mut frames: Vec<Downlink> = Vec::new();
    let mut seq = 0u32;
    // The test follows the firmware's own clock, not the host's: a measurement frame goes
    // up for each command frame that comes down (one per period of emulated time), and a
    // phase lasts a number of periods. A loaded host slows the emulation, not the test's
    // verdict; the wall-clock cap only ends a phase whose frames stopped coming.
    let cap = Duration::from_secs(30);
    let mut send_periods = |link: &mut PilLink, frames: &mut Vec<Downlink>, periods: usize| {
        let (goal, end) = (frames.len() + periods, Instant::now() + cap);
        while frames.len() < goal && Instant::now() < end {
            seq += 1;
            let request = if seq == 1 {
                ModeRequest::Engage
            } else {
                ModeRequest::None
            };
            link.send_measurement(&Uplink {
                seq,
                input: approach_input(seq, request),
            })
            .expect("send");
            frames.extend(link.recv(Duration::from_secs(1)).expect("receive"));
        }
    };

    // 1. One second of frames (50 periods): engaged (the refuelling procedure: at the
    //    pre-contact station), link fresh.
    send_periods(&mut link, &mut frames, 50);
    assert!(frames.len() >= 50, "only {} command frames", frames.len());
    let a = *frames.last().expect("command frames");
    assert_eq!(a.output.mode, Mode::PreContact, "{a:?}");
    assert!(!a.link_status.contains(LinkStatus::STALE));
    // Telemetry came by itself (counters change every period: one every 10 periods).
    let t = *link.telemetry().expect("telemetry while flying");
    assert_eq!(t.link.timeouts, 0);
    assert!(t.counters.steps > 20, "recent: {t:?}");
    let engaged_at = frames.len();

    // 2. Silence for 1.5 s (75 periods): command frames keep coming; stale after 100 ms;
    //    breakaway after the core's 0.5 s hold; open loop since the navigation is invalid.
    let end = Instant::now() + cap;
    while frames.len() < engaged_at + 75 && Instant::now() < end {
        frames.extend(link.recv(Duration::from_secs(1)).expect("receive"));
    }
    let silent = &frames[engaged_at..];
    assert!(
        silent.len() >= 75,
        "only {} command frames in {cap:?} of silence",
        silent.len()
    );
    let b = *frames.last().expect("frames");
    assert!(
        b.link_status
            .contains(LinkStatus::STALE | LinkStatus::INPUT_HELD)
    );
    assert_eq!(b.output.mode, Mode::Breakaway);
    assert_eq!(
        b.output.breakaway_reason,
        Some(BreakawayReason::MeasurementLost)
    );
    assert!(b.output.status.contains(StatusFlags::OPEN_LOOP));
    let cfg = ControllerConfig::default();
    let trim = ibvs_core::config::trim_command();
    let c = b.output.command.as_array();
    assert_eq!([c[0], c[2], c[3]], [trim[0], trim[2], trim[3]]);
    assert!((c[1] - (trim[1] - cfg.modes.breakaway_throttle_cut)).abs() < 1e-6);
    let t = link
        .request_telemetry(Duration::from_secs(1))
        .expect("telemetry");
    assert_eq!(t.link.timeouts, 1);
    assert!(t.link.stale_steps >= 20 && t.link.held_steps > t.link.stale_steps);
    // The stale steps ran on repeated camera frames and invalid navigation, all counted.
    assert!(t.counters.repeated >= t.link.held_steps - 1);
    assert!(t.counters.nav_non_finite >= t.link.stale_steps);

    // 3. The link comes back: fresh again, still in the latched breakaway.
    send_periods(&mut link, &mut frames, 15);
    let c = *frames.last().expect("frames");
    assert!(!c.link_status.contains(LinkStatus::STALE), "{c:?}");
    let t = link
        .request_telemetry(Duration::from_secs(1))
        .expect("telemetry");
    assert_eq!((c.output.mode, t.link.timeouts), (Mode::Breakaway, 1));
    assert_eq!(t.link.rejected_frames(), 0);

    assert_commands_safe(frames.iter().map(|d| d.output));
    // One command frame per period, numbered without gaps, each queued within the control
    // task's deadline after its tick, none refused by the transmit queue.
    assert_eq!(link.host_counters().rx.seq_gap, 0);
    assert_eq!((t.link.deadline_overruns, t.link.tx_dropped), (0, 0));
    let log = link.shutdown();
    assert!(log.contains("link stale"), "{log}");
}

/// The fault path: a panic (here a deliberate one, `panic-test` on the firmware's semihosting
/// command line) sends a command frame with the trim commands and `LinkStatus::PANIC`, logs
/// the recorded reason and ends QEMU with status 1.
#[test]
fn a_panic_leaves_trim_commands_and_records_why() {
    let elf = firmware_elf().expect("firmware ELF");
    let opts = PilOptions {
        firmware_args: vec!["panic-test".into()],
        ..PilOptions::default()
    };
    match PilLink::spawn(&elf, &opts) {
        Err(PilError::FirmwarePanicked { output, tail, .. }) => {
            assert_eq!(output.command.as_array(), ibvs_core::config::trim_command());
            assert!(
                tail.contains("FAULT (safe frame sent): panic-test requested"),
                "{tail}"
            );
            assert!(tail.contains("qemu.rs:"), "{tail}");
        }
        other => panic!("expected the panic frame, got {other:?}"),
    }
}

/// The HardFault path when the stack itself is gone: `stack-overflow-test` recurses until
/// the stack runs into the unmapped memory below RAM (flip-link's layout). The handler's
/// trampoline moves the stack pointer back into RAM first, so the safe frame still comes
/// out and the reason is recorded (without it QEMU reports a lockup and no frame is sent).
#[test]
fn a_stack_overflow_still_sends_the_safe_frame() {
    let elf = firmware_elf().expect("firmware ELF");
    let opts = PilOptions {
        firmware_args: vec!["stack-overflow-test".into()],
        ..PilOptions::default()
    };
    match PilLink::spawn(&elf, &opts) {
        Err(PilError::FirmwarePanicked { output, tail, .. }) => {
            assert_eq!(output.command.as_array(), ibvs_core::config::trim_command());
            assert!(
                tail.contains("FAULT (safe frame sent): HardFault: stack pointer outside RAM"),
                "{tail}"
            );
        }
        other => panic!("expected the panic frame, got {other:?}"),
    }
}

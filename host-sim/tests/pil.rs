//! Processor-in-the-loop docking: the firmware in QEMU's emulated STM32F405 flies the
//! simulated receiver over its serial link, and must fly it exactly as the controller does
//! in-process.
//!
//! Needs `qemu-system-arm` and the firmware ELF ([`firmware_elf`]: `IBVS_FIRMWARE_ELF`, as
//! `scripts/test-all.sh` sets it, or the default build path; it is not built here). The processor-in-the-loop acceptance check: same outcome,
//! miss within 2 cm, same mode sequence. Since the Cortex-M4F and the host both compute the
//! core's `f32` arithmetic in IEEE single precision without fused or flushed operations, the
//! outputs are in fact identical bit for bit, and that is checked too.

use autopilot_link::session::{MAX_BURST_LEN, Session, SessionConfig};
use autopilot_link::{quaternion_zyx, wrap_pi};
use host_sim::montecarlo::{self, CampaignComputer, RunOutcome, RunRecord};
use host_sim::pil::{PilFlightComputer, firmware_elf};
use host_sim::scenario::PRESETS;
use host_sim::scenario::ScenarioFile;
use host_sim::sim::{AutopilotStep, FlightComputer, Outcome, Run, Scenario, run};
use ibvs_core::attitude::{Command, InnerLoop};
use ibvs_core::wire::{ClockSource, CostUnit, LinkStatus, ResetCause, config_id};
use ibvs_core::{Controller, ControllerConfig, ControllerInput, Mode, OuterLaw, Procedure};
use serde_json::{Value, json};

/// The mode sequence of a run (consecutive repeats removed).
fn modes(r: &Run) -> Vec<Mode> {
    let mut m: Vec<Mode> = r.samples.iter().map(|s| s.output.mode).collect();
    m.dedup();
    m
}

/// Flies `scenario` with the default configuration in-process and through PIL, checks they
/// match; the in-process run.
fn pil_matches_in_process(scenario: &Scenario) -> Run {
    pil_flies_like_in_process(scenario, &ControllerConfig::default())
}

/// Flies `scenario` with `cfg` in-process and through PIL (the configuration sent over the
/// link before the first step), checks they match; the in-process run.
fn pil_flies_like_in_process(scenario: &Scenario, cfg: &ControllerConfig) -> Run {
    let mut controller = Controller::new(*cfg).expect("valid config");
    let reference = run(scenario, &mut controller).expect("in-process run");

    let elf = firmware_elf().expect("firmware ELF");
    let mut pil = PilFlightComputer::spawn(&elf).expect("QEMU with the firmware");
    // The boot frame: standby trim; its telemetry: a power-on (the qemu board's report).
    let boot = *pil.link().boot_frame();
    assert!(boot.link_status.contains(LinkStatus::BOOT));
    let t = pil.refresh_telemetry().expect("telemetry");
    assert_eq!(
        (t.reset_cause, t.clock),
        (ResetCause::PowerOn, ClockSource::NotReported)
    );
    pil.configure(cfg)
        .expect("the firmware applies the configuration");
    let got = run(scenario, &mut pil).expect("PIL run");
    let failure = pil.last_error().map(ToString::to_string);
    let (stats, log) = pil.shutdown();
    eprintln!(
        "{}: {:?}\nPIL stats: {stats:#?}",
        scenario.name, got.summary
    );
    assert_eq!(failure, None, "link failure; firmware log:\n{log}");

    // The firmware's counters at the end are the in-process controller's.
    assert_eq!(stats.firmware_counters, *controller.counters());
    let (s, r) = (&got.summary, &reference.summary);
    assert_eq!(s.outcome, r.outcome);
    match (s.miss_m, r.miss_m) {
        (Some(a), Some(b)) => assert!((a - b).abs() <= 0.02, "miss {a} m vs {b} m"),
        (a, b) => assert_eq!(a.is_some(), b.is_some(), "plane reached: {a:?} vs {b:?}"),
    }
    assert_eq!(modes(&got), modes(&reference));
    assert_eq!(got.samples.len(), reference.samples.len());
    for (k, (a, b)) in got.samples.iter().zip(&reference.samples).enumerate() {
        assert_eq!(a.output, b.output, "step {k}");
    }

    // Every step went through the link once, nothing was lost or rejected.
    let steps = got.samples.len() as u64;
    assert_eq!(stats.steps, steps);
    assert_eq!(stats.host.failed_steps + stats.host.timeouts, 0);
    assert_eq!(u64::from(stats.firmware_link.frames_ok), steps);
    assert_eq!(stats.firmware_link.rejected_frames(), 0);
    // Every step's frame queued within the control task's deadline, none refused by the
    // transmit queue, no engage held back (a power-on needs no acknowledgement).
    let l = stats.firmware_link;
    assert_eq!(
        (
            l.deadline_overruns,
            l.tx_dropped,
            l.tx_errors,
            l.engage_inhibited
        ),
        (0, 0, 0, 0)
    );
    assert_eq!(stats.reset_cause, ResetCause::PowerOn);
    assert_eq!(stats.firmware_counters.steps as usize, got.samples.len());
    let cost = stats.step_cost.expect("step costs");
    assert_eq!(cost.unit, CostUnit::Instructions);
    assert!(0 < cost.min && cost.min <= cost.median && cost.median <= cost.max);
    reference
}

/// The default scenario (the full environment): identical through PIL.
#[test]
fn pil_flies_the_default_scenario_like_the_in_process_controller() {
    let r = pil_matches_in_process(&Scenario::default());
    assert_eq!(r.summary.outcome, Outcome::Docked, "{:?}", r.summary);
}

/// The vertical slice's scenario (calm air, ideal camera): docks, identically through PIL.
#[test]
fn pil_docks_the_ideal_scenario_like_the_in_process_controller() {
    let s = Scenario::ideal();
    let r = pil_matches_in_process(&s);
    assert_eq!(r.summary.outcome, Outcome::Docked, "{:?}", r.summary);
}

/// The default scenario at another flight condition (137 m/s, 4,100 m: inside a cell of the
/// gain schedule): the firmware loads the interpolated design after its first step, as the
/// in-process flight computer does, and docks identically.
#[test]
fn pil_flies_the_gain_schedule_off_its_grid_like_the_in_process_controller() {
    let text = "name = \"off-grid\"\n[flight]\nairspeed_mps = 137.0\naltitude_m = 4100.0\n";
    let file = ScenarioFile::parse(text, "off-grid").expect("scenario");
    assert_eq!(
        file.controller_config(),
        ControllerConfig::default(),
        "the firmware's"
    );
    let r = pil_matches_in_process(&file.scenario());
    assert_eq!(r.summary.outcome, Outcome::Docked, "{:?}", r.summary);
    let first = r.samples.first().expect("steps");
    assert_eq!(first.output.envelope_error, None);
}

/// Every preset's controller configuration reaches the firmware over the link and flies as
/// in-process, bit for bit. The presets share a few configurations (the turbulence, the
/// start and the flight condition are the world's, not the controller's); one full docking
/// per distinct configuration is flown through PIL, the preset named first for it, and the
/// test checks that these cover every preset.
#[test]
fn pil_flies_every_presets_configuration_like_the_in_process_controller() {
    let mut flown: Vec<(ControllerConfig, &str)> = Vec::new();
    for (name, _, _) in PRESETS {
        let file = ScenarioFile::load(name).expect("preset");
        let cfg = file.controller_config();
        if flown.iter().any(|(c, _)| *c == cfg) {
            continue;
        }
        let r = pil_flies_like_in_process(&file.scenario(), &cfg);
        eprintln!("{name}: {:?}", r.summary.outcome);
        flown.push((cfg, name));
    }
    let names: Vec<&str> = flown.iter().map(|f| f.1).collect();
    eprintln!("flown through PIL: {names:?}");
    // The law, the procedure, the gains and the camera belief all differ among them.
    assert!(flown.len() >= 5, "{names:?}");
    assert!(flown.iter().any(|(c, _)| c.law == OuterLaw::Pbvs));
    assert!(flown.iter().any(|(c, _)| c.procedure == Procedure::Paper));
    assert!(
        flown
            .iter()
            .any(|(c, _)| c.procedure == Procedure::Refuelling)
    );
    // The attitude-command inner loop (the autopilot presets): the firmware's setpoints fly
    // the simulator's autopilot exactly as the in-process controller's.
    assert!(
        flown
            .iter()
            .any(|(c, _)| c.inner_loop == ibvs_core::attitude::InnerLoop::Attitude),
        "{names:?}"
    );
}

/// Runs pymavlink's checker script (`autopilot-link/tests/mavlink_check.py`, as the codec's
/// host tests do) in `mode` on two files; its output. It fails, not skips, without pymavlink.
fn mavlink_check(mode: &str, a: &std::path::Path, b: &std::path::Path) -> std::process::Output {
    let script = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../autopilot-link/tests/mavlink_check.py"
    );
    std::process::Command::new("python3")
        .arg(script)
        .arg(mode)
        .arg(a)
        .arg(b)
        .output()
        .expect("python3 runs")
}

/// A flight computer whose MAVLink bytes to the autopilot are kept, step after step.
struct Taped<'a, F: FlightComputer + ?Sized> {
    fc: &'a mut F,
    to_autopilot: Vec<u8>,
}

impl<F: FlightComputer + ?Sized> FlightComputer for Taped<'_, F> {
    fn step(&mut self, input: &ControllerInput) -> ibvs_core::ControllerOutput {
        self.fc.step(input)
    }

    fn autopilot_design(&self) -> Option<ibvs_core::attitude::AttitudeLoopConfig> {
        self.fc.autopilot_design()
    }

    fn step_through_autopilot(&mut self, link: AutopilotStep<'_>) -> ibvs_core::ControllerOutput {
        let mut mine = Vec::new();
        let out = self.fc.step_through_autopilot(AutopilotStep {
            to_autopilot: &mut mine,
            ..link
        });
        self.to_autopilot.extend_from_slice(&mine);
        link.to_autopilot.extend_from_slice(&mine);
        out
    }
}

/// Docking through the autopilot over MAVLink: the firmware reads the simulated autopilot's
/// telemetry on its second serial port (USART2) and sends its heartbeat and setpoints there.
/// The run equals the in-process one bit for bit (every output; every MAVLink byte the
/// firmware sent equals what the in-process session encodes for the same outputs), the
/// firmware's link counters say nothing was lost, and pymavlink (an implementation we did
/// not write) decodes the firmware's stream: every frame's id, CRC with its CRC extra,
/// header and fields, one setpoint per control step (50 Hz on the link clock) and a heartbeat
/// every 50 steps (1 Hz).
#[test]
fn pil_flies_through_the_autopilot_over_mavlink_like_in_process_and_pymavlink_reads_it() {
    let file = ScenarioFile::load("autopilot-level2").expect("preset");
    let (scenario, cfg) = (file.scenario(), file.controller_config());
    assert_eq!(cfg.inner_loop, InnerLoop::Attitude);
    let mut controller = Controller::new(cfg).expect("valid config");
    let mut in_process = Taped {
        fc: &mut controller,
        to_autopilot: Vec::new(),
    };
    let reference = run(&scenario, &mut in_process).expect("in-process run");
    let expected_bytes = in_process.to_autopilot;
    assert_eq!(
        reference.summary.outcome,
        Outcome::Docked,
        "{:?}",
        reference.summary
    );

    let elf = firmware_elf().expect("firmware ELF");
    let mut pil = PilFlightComputer::spawn(&elf).expect("QEMU with the firmware");
    pil.configure(&cfg).expect("applied");
    let got = run(&scenario, &mut pil).expect("PIL run");
    let failure = pil.last_error().map(ToString::to_string);
    let telemetry = pil.refresh_telemetry().expect("telemetry");
    let sent = pil.link().autopilot_sent().to_vec();
    let received = pil.link().autopilot_received().to_vec();
    let (_, log) = pil.shutdown();
    assert_eq!(failure, None, "link failure; firmware log:\n{log}");
    assert_eq!(got.samples.len(), reference.samples.len());
    for (k, (a, b)) in got.samples.iter().zip(&reference.samples).enumerate() {
        assert_eq!(a.output, b.output, "step {k}");
    }
    assert_eq!(got.summary.outcome, Outcome::Docked);

    // The firmware's MAVLink stream, message by message, for pymavlink: from the outputs.
    let mut expected = Vec::new();
    let mut seq = 0u8;
    for (k, sample) in reference.samples.iter().enumerate() {
        let now = 20 * k as u32;
        let header = |name: &str, seq: u8, fields: Value| {
            json!({"name": name, "seq": seq, "src_system": 1, "src_component": 191,
                   "fields": fields})
        };
        if k % 50 == 0 {
            expected.push(header(
                "HEARTBEAT",
                seq,
                json!({"type": 18, "autopilot": 8, "base_mode": 0, "custom_mode": 0,
                       "system_status": 4, "mavlink_version": 3}),
            ));
            seq = seq.wrapping_add(1);
        }
        // With the first heartbeat (the autopilot's has said it is ArduPlane), the two
        // attitude time constants are asked for; answered in the next step's telemetry.
        if k == 0 {
            for name in ["PTCH2SRV_TCONST", "RLL2SRV_TCONST"] {
                expected.push(header(
                    "PARAM_REQUEST_READ",
                    seq,
                    json!({"target_system": 1, "target_component": 1, "param_id": name,
                           "param_index": -1}),
                ));
                seq = seq.wrapping_add(1);
            }
        }
        let Command::Attitude(sp) = sample.output.command else {
            panic!("step {k}: not an attitude command")
        };
        let q = quaternion_zyx(sp.roll_rad, sp.pitch_rad, wrap_pi(sp.yaw_rad));
        expected.push(header(
            "SET_ATTITUDE_TARGET",
            seq,
            json!({"time_boot_ms": now, "target_system": 1, "target_component": 1,
                   "type_mask": 7, "q": q, "thrust": sp.throttle,
                   "body_roll_rate": 0.0, "body_pitch_rate": 0.0, "body_yaw_rate": 0.0}),
        ));
        seq = seq.wrapping_add(1);
    }
    assert!(
        received == expected_bytes,
        "the firmware's MAVLink bytes differ"
    );

    // What the firmware counted on the link: every frame of the autopilot's used, nothing
    // lost, every navigation sample built.
    let steps = reference.samples.len() as u32;
    let heartbeats = steps.div_ceil(50);
    let a = telemetry.autopilot;
    assert_eq!(a.frames_used, 4 * steps + heartbeats + 2, "{a:?}");
    assert_eq!(
        (a.time_constants_unknown, a.time_constants_mismatch),
        (1, 0),
        "{a:?}"
    );
    assert_eq!(
        (
            a.noise_bytes,
            a.bad_crc,
            a.dropped,
            a.rx_errors,
            a.tx_dropped
        ),
        (0, 0, 0, 0, 0),
        "{a:?}"
    );
    assert_eq!(
        a.nav_missing + a.nav_stale + a.nav_schedule + a.nav_non_finite,
        0
    );
    assert!(!sent.is_empty());

    // pymavlink decodes the firmware's stream, frame by frame (the same script as the
    // codec's host tests; it fails, not skips, without pymavlink).
    let dir = std::env::temp_dir().join(format!("ibvs-pil-mavlink-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (frames, want) = (dir.join("frames.bin"), dir.join("expected.json"));
    std::fs::write(&frames, &received).expect("written");
    std::fs::write(&want, serde_json::to_vec(&expected).expect("json")).expect("written");
    let out = mavlink_check("check", &frames, &want);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        out.status.success(),
        "pymavlink: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The firmware reads an autopilot it did not hear from our code: an ArduPlane stream of 40
/// control steps written by pymavlink (a GUIDED heartbeat, then each step
/// `LOCAL_POSITION_NED`, `VFR_HUD`, `AOA_SSA` and `ATTITUDE`, the aircraft gently rolling and
/// pitching about the trim), fed to its USART2 beside the measurement frames of a docking's
/// first steps. Every output and every MAVLink byte it sends equal those of the in-process
/// controller and session fed the same bytes; it counts every frame used and no navigation
/// sample refused, and it engages (the heartbeat's GUIDED reached it).
#[test]
fn pil_flies_on_an_autopilot_stream_pymavlink_wrote_like_in_process() {
    const STEPS: u32 = 40;
    let file = ScenarioFile::load("autopilot-level2").expect("preset");
    let (scenario, cfg) = (file.scenario(), file.controller_config());
    let mut reference = Controller::new(cfg).expect("valid config");
    let flown = run(&scenario, &mut reference).expect("in-process run");

    // pymavlink's stream: one JSON list of every step's messages.
    let trim = ibvs_core::gains::TRIM;
    let sigma = (1.0 - 2.255_77e-5 * f64::from(trim.altitude_m)).powf(4.255_88);
    let eas = f64::from(trim.speed_mps) * sigma.sqrt();
    let mut messages = vec![json!({"name": "HEARTBEAT", "fields": {"type": 1,
        "autopilot": 3, "base_mode": 217, "custom_mode": 15, "system_status": 4}})];
    // The frames of each step: the heartbeat with the first, the answers to the firmware's
    // requests for the attitude time constants with the second.
    let mut per_step = Vec::new();
    for k in 0..STEPS {
        let before = messages.len();
        if k == 1 {
            for (name, value) in [("PTCH2SRV_TCONST", 0.5), ("RLL2SRV_TCONST", 0.5)] {
                messages.push(json!({"name": "PARAM_VALUE", "fields": {"param_id": name,
                    "param_value": value, "param_type": 9, "param_count": 1,
                    "param_index": 65535}}));
            }
        }
        let (t, ms) = (f64::from(k) * 0.02, 20 * k);
        let (roll, pitch) = (
            0.05 * (2.0 * t).sin(),
            f64::from(trim.theta_rad) + 0.01 * t.sin(),
        );
        messages.extend([
            json!({"name": "LOCAL_POSITION_NED", "fields": {"time_boot_ms": ms,
                "x": 120.0 * t, "y": 0.1 * t, "z": -f64::from(trim.altitude_m),
                "vx": f64::from(trim.speed_mps) + 0.3 * t, "vy": 0.1, "vz": 0.0}}),
            json!({"name": "VFR_HUD", "fields": {"airspeed": eas, "groundspeed": 120.0,
                "heading": 0, "throttle": 50, "alt": trim.altitude_m, "climb": 0.0}}),
            json!({"name": "AOA_SSA", "fields": {"time_usec": u64::from(ms) * 1000,
                "AOA": f64::from(trim.alpha_rad).to_degrees() + 0.2 * t, "SSA": 0.1}}),
            json!({"name": "ATTITUDE", "fields": {"time_boot_ms": ms, "roll": roll,
                "pitch": pitch, "yaw": 0.002 * t, "rollspeed": 0.1 * (2.0 * t).cos(),
                "pitchspeed": 0.01 * t.cos(), "yawspeed": 0.002}}),
        ]);
        per_step.push(messages.len() - before + usize::from(k == 0));
    }
    let dir = std::env::temp_dir().join(format!("ibvs-pil-pymavlink-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (values, stream) = (dir.join("values.json"), dir.join("stream.bin"));
    let doc = json!({"src_system": 1, "src_component": 1, "messages": messages});
    std::fs::write(&values, serde_json::to_vec(&doc).expect("json")).expect("written");
    let out = mavlink_check("make", &values, &stream);
    assert!(
        out.status.success(),
        "pymavlink: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let bytes = std::fs::read(&stream).expect("the stream");
    let _ = std::fs::remove_dir_all(&dir);
    // Its frames, by their length bytes (MAVLink 2: 12 bytes and the payload).
    let mut frames: Vec<&[u8]> = Vec::new();
    let mut rest = bytes.as_slice();
    while rest.len() >= 12 {
        assert_eq!(rest[0], 0xFD, "a MAVLink 2 frame");
        let (frame, tail) = rest.split_at(12 + usize::from(rest[1]));
        frames.push(frame);
        rest = tail;
    }
    assert!(rest.is_empty());
    assert_eq!(frames.len(), 1 + 2 + 4 * STEPS as usize);
    assert_eq!(per_step.iter().sum::<usize>(), frames.len());

    let elf = firmware_elf().expect("firmware ELF");
    let mut pil = PilFlightComputer::spawn(&elf).expect("QEMU with the firmware");
    pil.configure(&cfg).expect("applied");
    let mut twin = Controller::new(cfg).expect("valid config");
    let mut session = Session::new(SessionConfig::default());
    let mut engaged = false;
    for k in 0..STEPS as usize {
        let first: usize = per_step[..k].iter().sum();
        let step_bytes: Vec<u8> = frames[first..first + per_step[k]].concat();
        let uplink = ControllerInput {
            measurement: flown.samples[k].measurement,
            nav: ibvs_core::nav::NavSample::default(),
            probe_contact: false,
            autopilot_ready: false,
            // Engage asked until flown, as the simulator asks it.
            request: if engaged {
                ibvs_core::ModeRequest::None
            } else {
                ibvs_core::ModeRequest::Engage
            },
        };
        let mut sent = Vec::new();
        let d = pil
            .try_step_through_autopilot(&uplink, &step_bytes, &mut sent)
            .unwrap_or_else(|e| panic!("step {k}: {e}"));
        let now = 20 * k as u32;
        step_bytes.iter().for_each(|&b| session.push(b, now));
        let want = host_sim::sim::FlightComputer::step(&mut twin, &session.input(now, &uplink));
        let mut burst = [0u8; MAX_BURST_LEN];
        let n = session.send(now, &want.command, &mut burst);
        assert_eq!(d.output, want, "step {k}");
        assert_eq!(sent, burst[..n], "step {k}: the MAVLink bytes");
        engaged |= want.mode != Mode::Standby;
    }
    let t = pil.refresh_telemetry().expect("telemetry");
    let (_, log) = pil.shutdown();
    assert!(engaged, "GUIDED reached the firmware; log:\n{log}");
    let a = t.autopilot;
    assert_eq!(a.frames_used as usize, frames.len(), "{a:?}");
    assert_eq!(
        (
            a.nav_missing,
            a.nav_stale,
            a.nav_schedule,
            a.nav_non_finite,
            a.dropped,
            a.bad_crc
        ),
        (0, 0, 0, 0, 0, 0),
        "{a:?}"
    );
    assert_eq!(
        a,
        session.counters(),
        "the firmware's counters are the twin's"
    );
}

/// A configuration the firmware refuses leaves it flying the one it had, and says why.
#[test]
fn pil_refuses_an_invalid_configuration_by_name_and_keeps_flying_the_old_one() {
    let elf = firmware_elf().expect("firmware ELF");
    let mut pil = PilFlightComputer::spawn(&elf).expect("QEMU with the firmware");
    let mut bad = ControllerConfig::paper();
    bad.refuelling.late_gate_taper_m = 0.0;
    let e = pil.configure(&bad).expect_err("refused");
    let text = e.to_string();
    assert!(
        text.contains("refuelling.late_gate_taper_m") && text.contains("NotPositive"),
        "{text}"
    );
    let read = pil
        .link_mut()
        .read_config(std::time::Duration::from_secs(10))
        .expect("read answered");
    assert_eq!(read.config, ControllerConfig::default());
    assert_eq!(read.config_id, config_id(&ControllerConfig::default()));
    let (_, log) = pil.shutdown();
    assert!(!log.contains("configuration 0x"), "nothing applied: {log}");
}

/// A campaign with the controller in QEMU gives the in-process campaign's records, line for
/// line (a dispersed preset: every run its own turbulence, start and controller settings).
#[test]
fn a_pil_campaign_equals_the_in_process_campaign_run_for_run() {
    let f = ScenarioFile::load("paper-level1").expect("preset");
    let idx = montecarlo::indices(0, 50, None);
    let elf = firmware_elf().expect("firmware ELF");
    let pil = montecarlo::run_campaign_on(&f, &idx, Some(2), &CampaignComputer::Pil(elf))
        .expect("PIL campaign");
    let local = montecarlo::run_campaign(&f, &idx, Some(2)).expect("in-process campaign");
    assert_eq!(pil.len(), 50);
    for (a, b) in pil.iter().zip(&local) {
        assert_eq!(a, b);
    }
    let records: Vec<RunRecord> = pil
        .iter()
        .map(|l| serde_json::from_str(l).expect("record"))
        .collect();
    assert!(
        records.iter().all(|r| r.outcome != RunOutcome::Error),
        "{pil:?}"
    );
    assert!(records.iter().filter(|r| r.docked).count() >= 45, "{pil:?}");
}

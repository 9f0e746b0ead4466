//! Hardware in the loop over a serial device: the link opened as a board's serial adapter is
//! (`serialport`, termios, raw 8N1), here against the emulated board behind QEMU's
//! `-serial pty`, must fly exactly as processor in the loop and in-process do.
//!
//! Needs `qemu-system-arm` and the `qemu` board's ELF (`IBVS_FIRMWARE_ELF`, as
//! `scripts/test-all.sh` sets it, or the default build path).

use std::process::Command;

use host_sim::pil::{PilFlightComputer, PilOptions, QemuPty, firmware_elf};
use host_sim::scenario::ScenarioFile;
use host_sim::sim::{Outcome, run};
use ibvs_core::Controller;
use ibvs_core::wire::ResetCause;

#[test]
fn hil_over_a_pty_flies_a_presets_configuration_like_the_in_process_controller() {
    let elf = firmware_elf().expect("firmware ELF");
    let qemu = QemuPty::spawn(&elf, &PilOptions::default()).expect("QEMU on a pty");
    // The paper's procedure with Table 2's gains: a configuration the firmware does not
    // boot with, so it must arrive over the serial device.
    let file = ScenarioFile::load("paper-bow-wave").expect("preset");
    let cfg = file.controller_config();
    let mut hil = PilFlightComputer::open_serial(qemu.path(), 921_600, PilOptions::default())
        .unwrap_or_else(|e| panic!("open {}: {e}\n{}", qemu.path().display(), qemu.log_text()));
    hil.configure(&cfg).expect("configuration applied");
    let got = run(&file.scenario(), &mut hil).expect("HIL run");
    assert_eq!(
        hil.last_error().map(ToString::to_string),
        None,
        "{}",
        qemu.log_text()
    );
    let reference = run(&file.scenario(), &mut Controller::new(cfg).expect("valid")).expect("run");
    assert_eq!(got.summary.outcome, Outcome::Docked, "{:?}", got.summary);
    assert_eq!(got.samples.len(), reference.samples.len());
    for (k, (a, b)) in got.samples.iter().zip(&reference.samples).enumerate() {
        assert_eq!(a.output, b.output, "step {k}");
    }
    let (stats, _) = hil.shutdown();
    assert_eq!(
        stats.host.failed_steps + stats.host.timeouts,
        0,
        "{stats:#?}"
    );
    assert_eq!(stats.firmware_link.rejected_frames(), 0, "{stats:#?}");
    assert_eq!(stats.firmware_link.config_applied, 1);
    // No boot frame over a serial link opened after the boot: the cause comes with every
    // command frame.
    assert_eq!(stats.reset_cause, ResetCause::PowerOn);
    assert_eq!(
        (
            stats.firmware_link.deadline_overruns,
            stats.firmware_link.tx_dropped
        ),
        (0, 0)
    );
}

/// The command a user runs against a board, here against the pty.
#[test]
fn dock_hil_flies_over_the_serial_device_named() {
    let elf = firmware_elf().expect("firmware ELF");
    let qemu = QemuPty::spawn(&elf, &PilOptions::default()).expect("QEMU on a pty");
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["dock", "--json", "--no-files", "--hil", "--serial"])
        .arg(qemu.path())
        .args(["--baud", "921600"])
        .output()
        .expect("run host-sim");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stderr),
        qemu.log_text()
    );
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("JSON");
    assert_eq!(v["outcome"], "docked", "{v}");
    assert!(
        v["step_instructions"]["max"]
            .as_u64()
            .is_some_and(|m| m > 0),
        "{v}"
    );
    // A device that does not exist is named.
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args([
            "dock",
            "--no-files",
            "--hil",
            "--serial",
            "/dev/nonexistent-serial",
        ])
        .output()
        .expect("run host-sim");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("/dev/nonexistent-serial"),
        "{stderr}"
    );
}

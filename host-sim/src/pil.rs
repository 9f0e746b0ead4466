//! Processor-in-the-loop (PIL): the firmware runs inside QEMU's emulated STM32F405 and flies
//! the simulated receiver over its real serial link; and hardware in the loop (HIL): the same
//! link over a serial device to a board ([`PilLink::open_serial`], `serialport`), tested
//! against QEMU on a pty ([`QemuPty`]).
//!
//! Place in the data flow: [`PilFlightComputer`] implements [`FlightComputer`], so
//! [`crate::sim::run`] drives it exactly like the in-process controller: each step's
//! [`ControllerInput`] goes out as one measurement frame ([`Uplink`], `ibvs_core::wire`) and
//! the step's [`ControllerOutput`] comes back in the firmware's command frame ([`Downlink`]).
//!
//! ```text
//! sim::run ─► PilFlightComputer::step ─► PilLink ─► unix socket ─► QEMU -serial (USART1)
//!                                                                   └─► firmware (lockstep)
//! sim::run ◄─ ControllerOutput ◄──────── Downlink ◄── unix socket ◄── USART1 TX
//! ```
//!
//! [`PilLink`] spawns `qemu-system-arm -machine netduinoplus2 -cpu cortex-m4 -icount shift=0
//! -display none -monitor none -semihosting-config enable=on,target=native,arg=firmware
//! -serial unix:SOCKET -serial unix:AUTOPILOT_SOCKET -kernel ELF`. The link has its own
//! chardev, a unix socket this process listens on; so has the firmware's autopilot port
//! (USART2, MAVLink 2): through the autopilot (the attitude-command loop,
//! [`PilFlightComputer::try_step_through_autopilot`]) each step writes the simulated
//! autopilot's frames there before the measurement frame, and reads the firmware's MAVLink
//! frames up to its `SET_ATTITUDE_TARGET` after the command frame (every byte kept both ways:
//! [`PilLink::autopilot_sent`], [`PilLink::autopilot_received`]); QEMU's stdout and stderr (the firmware's semihosting log) go to a log file
//! beside it ([`PilLink::log_path`]). `-icount shift=0` makes the firmware's TIM2 an exact
//! instruction counter, so the step costs it reports are deterministic.
//!
//! Link failures (lockstep): a step waits [`PilOptions::step_timeout`] for the command frame
//! that echoes its measurement frame, retransmits the same frame (same sequence number: the
//! firmware answers a repeat with its previous answer, without stepping again) up to
//! [`PilOptions::retries`] times, then gives up. [`FlightComputer::step`] must return an
//! output, so a failed step returns the **last output received** (the actuators hold their
//! last command, as they would on a real bus), counts it
//! ([`HostLinkCounters::failed_steps`]) and keeps the error ([`PilFlightComputer::last_error`]);
//! [`PilFlightComputer::try_step`] returns it instead. Once QEMU has exited every step fails at
//! once with [`PilError::FirmwareExited`].
//!
//! Fault injection for tests ([`PilOptions::faults`], a [`FaultPlan`]): corrupted bytes,
//! dropped, delayed and duplicated frames, garbage bursts, applied to chosen measurement
//! frames on their first transmission (never to retransmissions). Every byte written to the
//! link is kept ([`PilLink::sent_bytes`]), so a test can replay it through the core's decoder
//! and predict exactly what the firmware must have counted.
//!
//! The firmware's counters, why it last reset and which clock it runs on come in telemetry
//! frames (`Telemetry`: one after the boot frame, one on request, and in its free-running
//! schedule when a counter changed): the link keeps the latest ([`PilLink::telemetry`]),
//! asks for one when it must be current ([`PilLink::request_telemetry`]; a run's statistics
//! at its end), and the statistics report it ([`PilStats::reset_cause`]), so a
//! hardware-in-the-loop run, which opens the link after the boot frame, reports them too.
//!
//! Invariant: the child QEMU process is killed and reaped, and its temporary directory
//! removed, when the link is dropped (set `IBVS_PIL_KEEP=1` to keep the directory and log).

use std::collections::{BTreeMap, VecDeque};
use std::fs::{self, File};
use std::io::{self, Read, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use ibvs_core::ControllerConfig;
use ibvs_core::controller::{ControllerInput, ControllerOutput, Counters};
use ibvs_core::measurement::SequenceTracker;
use ibvs_core::wire::{
    ClockSource, ConfigReport, ConfigStatus, CostUnit, Downlink, FlightComputerMessage,
    FrameDecoder, LinkCounters, LinkStatus, MAX_FRAME_LEN, ResetCause, Telemetry, Uplink,
    WireError, config_id, encode_config_read, encode_config_write, encode_telemetry_request,
    encode_uplink,
};
use serde::Serialize;

use crate::sim::{AutopilotStep, FlightComputer};
use autopilot_link::peer::read_setpoint;

/// How long a step through the autopilot waits between the autopilot's bytes and the
/// measurement frame ([`PilFlightComputer::try_step_through_autopilot`]).
const AUTOPILOT_SETTLE: Duration = Duration::from_millis(1);
use ibvs_core::attitude::Command as FlightCommand;

/// Environment variable naming the firmware ELF to fly ([`firmware_elf`]).
pub const FIRMWARE_ELF_ENV: &str = "IBVS_FIRMWARE_ELF";

/// Environment variable: when set to `1`, keep each run's temporary directory (socket, log).
pub const KEEP_ENV: &str = "IBVS_PIL_KEEP";

/// The cross target of the firmware.
pub const FIRMWARE_TARGET: &str = "thumbv7em-none-eabihf";

/// Why processor-in-the-loop failed.
#[derive(Debug, thiserror::Error)]
pub enum PilError {
    /// No firmware ELF at the path.
    #[error(
        "firmware ELF not found: {0} (build it with `{FIRMWARE_BUILD_COMMAND}`, or name one in {FIRMWARE_ELF_ENV})"
    )]
    ElfMissing(PathBuf),
    /// The file is not the `qemu` board's firmware: not an ELF, not for a 32-bit
    /// little-endian ARM core, or another board's build (the `f405` board, which QEMU would
    /// run until a timeout: its first acts are the real board's clock set-up).
    #[error(
        "{path} is not the qemu board's firmware: {reason} (build it with `{FIRMWARE_BUILD_COMMAND}`)"
    )]
    NotQemuFirmware {
        /// The file.
        path: PathBuf,
        /// What it is instead.
        reason: String,
    },
    /// QEMU could not be started.
    #[error("starting {program}: {source}")]
    Spawn {
        /// The QEMU program.
        program: String,
        /// Why.
        source: io::Error,
    },
    /// QEMU did not connect to the link's socket in time.
    #[error("QEMU did not connect to the serial socket within {0:?}")]
    ConnectTimeout(Duration),
    /// A step through the autopilot on a link without the autopilot's serial port (hardware
    /// in the loop has one serial device: the peer's).
    #[error("this link has no autopilot port (MAVLink): only QEMU's second serial port is wired")]
    NoAutopilotPort,
    /// The firmware sent no `SET_ATTITUDE_TARGET` for an attitude command in time.
    #[error("no SET_ATTITUDE_TARGET from the firmware within {0:?}")]
    NoSetpoint(Duration),
    /// The firmware sent no telemetry frame in time after a request.
    #[error("no telemetry frame from the firmware within {0:?}")]
    NoTelemetry(Duration),
    /// The firmware sent no boot frame in time.
    #[error("no boot frame from the firmware within {0:?}")]
    NoBootFrame(Duration),
    /// No command frame answered a measurement frame, retransmissions included.
    #[error(
        "no command frame for measurement frame {seq} within {timeout:?} ({attempts} attempts)"
    )]
    Timeout {
        /// The measurement frame's sequence number.
        seq: u32,
        /// Wait per attempt.
        timeout: Duration,
        /// Transmissions.
        attempts: u32,
    },
    /// QEMU exited (or closed the link).
    #[error("the firmware exited ({status}); log {log}:\n{tail}")]
    FirmwareExited {
        /// Exit status, as text.
        status: String,
        /// The log file.
        log: PathBuf,
        /// Its last lines.
        tail: String,
    },
    /// The firmware sent its panic frame (`LinkStatus::PANIC`: it stopped).
    #[error("the firmware panicked (safe-state frame received); log {log}:\n{tail}")]
    FirmwarePanicked {
        /// The output it left the actuators at (trim commands).
        output: Box<ControllerOutput>,
        /// The log file.
        log: PathBuf,
        /// Its last lines (the recorded reason).
        tail: String,
    },
    /// A measurement frame could not be encoded.
    #[error("encoding a measurement frame: {0}")]
    Encode(WireError),
    /// No configuration report answered a configuration frame in time.
    #[error("no configuration report from the firmware within {0:?}")]
    NoConfigReport(Duration),
    /// The firmware did not apply the configuration sent (its answer).
    #[error("the firmware refused the configuration: {0:?}")]
    ConfigRefused(ConfigStatus),
    /// The firmware reported applying a configuration other than the one sent.
    #[error(
        "the firmware applied a configuration other than the one sent (id {got:#010x}, sent {sent:#010x})"
    )]
    ConfigMismatch {
        /// The id it reported.
        got: u32,
        /// The id of the configuration sent.
        sent: u32,
    },
    /// Socket or file I/O.
    #[error("PIL link I/O: {0}")]
    Io(#[from] io::Error),
    /// The serial device could not be opened or set up.
    #[error("serial device {path}: {source}")]
    Serial {
        /// The device.
        path: PathBuf,
        /// Why.
        source: serialport::Error,
    },
    /// The serial device closed (end of file).
    #[error("the serial link closed")]
    LinkClosed,
}

/// The firmware's schedule, chosen on its semihosting command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FirmwareSchedule {
    /// One command frame per measurement frame (what [`PilFlightComputer`] needs).
    #[default]
    Lockstep,
    /// The flight schedule: one command frame per 20 ms of emulated time (with `-icount
    /// shift=0` and the firmware idling in WFI, emulated time follows real time).
    FreeRunning,
}

/// One fault, applied to one measurement frame's first transmission.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Fault {
    /// XOR `mask` into byte `index` (modulo the frame's length without its zero) of the
    /// encoded frame. If that would make the byte zero (which would cut the frame in two),
    /// the mask's lowest bit is flipped first.
    CorruptByte {
        /// Byte position in the frame.
        index: usize,
        /// Bits to flip (non-zero).
        mask: u8,
    },
    /// Do not send the frame.
    Drop,
    /// Wait this long before sending it.
    Delay(Duration),
    /// Send these bytes just before it (with no zero at their end, they run into the frame
    /// and take it with them).
    GarbageBefore(Vec<u8>),
    /// Send the frame twice.
    Duplicate,
}

/// Faults by measurement-frame index (0 for the first frame [`PilLink::send_measurement`]
/// sends, +1 per new frame; in lockstep, the step index).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FaultPlan {
    by_frame: BTreeMap<u64, Vec<Fault>>,
}

impl FaultPlan {
    /// No faults.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `fault` on frame `frame`.
    pub fn at(mut self, frame: u64, fault: Fault) -> Self {
        self.by_frame.entry(frame).or_default().push(fault);
        self
    }

    /// Faults on frame `frame`.
    pub fn on(&self, frame: u64) -> &[Fault] {
        self.by_frame.get(&frame).map_or(&[], Vec::as_slice)
    }

    /// Number of faults planned.
    pub fn len(&self) -> usize {
        self.by_frame.values().map(Vec::len).sum()
    }

    /// True when no fault is planned.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// How to run the firmware.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PilOptions {
    /// The QEMU program (on `PATH` or a path).
    pub qemu: PathBuf,
    /// The firmware's schedule.
    pub schedule: FirmwareSchedule,
    /// Lockstep: wait per transmission for the answering command frame.
    pub step_timeout: Duration,
    /// Lockstep: retransmissions of a measurement frame after a timeout.
    pub retries: u32,
    /// Wait for the report answering a configuration write: the `f405` board stores an
    /// applied configuration before it answers, and erasing the flash sector takes up to
    /// 4 s (firmware/README.md), much longer than a step.
    pub config_timeout: Duration,
    /// Wait for QEMU to connect and the firmware to send its boot frame.
    pub boot_timeout: Duration,
    /// Faults to inject on the measurement frames.
    pub faults: FaultPlan,
    /// Extra words for the firmware's semihosting command line (tests: `panic-test`).
    pub firmware_args: Vec<String>,
}

impl Default for PilOptions {
    fn default() -> Self {
        Self {
            qemu: PathBuf::from("qemu-system-arm"),
            schedule: FirmwareSchedule::Lockstep,
            step_timeout: Duration::from_secs(2),
            retries: 1,
            config_timeout: Duration::from_secs(10),
            boot_timeout: Duration::from_secs(20),
            faults: FaultPlan::new(),
            firmware_args: Vec::new(),
        }
    }
}

/// The host side's own link counts (the firmware's are in its command frames).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct HostLinkCounters {
    /// Measurement frames written (new ones; retransmissions and duplicates not included).
    pub frames_sent: u64,
    /// Retransmissions after a timeout.
    pub retransmissions: u64,
    /// Waits for an answer that ended without it.
    pub timeouts: u64,
    /// Steps that returned the held output after a link failure.
    pub failed_steps: u64,
    /// Command frames that answered no pending measurement frame (late or duplicate).
    pub unexpected_frames: u64,
    /// Faults injected.
    pub faults_injected: u64,
    /// The receive side of the host: command frames accepted, rejected (corrupt,
    /// oversize, malformed, wrong version), and their sequence gaps and repeats.
    pub rx: LinkCounters,
}

/// Min / median / max of a cost over a run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct CostSummary {
    /// Unit of the figures.
    #[serde(serialize_with = "serialize_unit")]
    pub unit: CostUnit,
    /// Smallest.
    pub min: u32,
    /// Median (upper median for an even count).
    pub median: u32,
    /// Largest.
    pub max: u32,
    /// Number of samples.
    pub samples: usize,
}

fn serialize_unit<S: serde::Serializer>(u: &CostUnit, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(match u {
        CostUnit::Unavailable => "unavailable",
        CostUnit::Instructions => "instructions",
        CostUnit::Cycles => "cycles",
    })
}

impl CostSummary {
    /// The summary of `samples` in `unit`; `None` when empty.
    pub fn of(unit: CostUnit, samples: &[u32]) -> Option<Self> {
        let mut s = samples.to_vec();
        s.sort_unstable();
        Some(Self {
            unit,
            min: *s.first()?,
            median: s[s.len() / 2],
            max: *s.last()?,
            samples: s.len(),
        })
    }
}

/// What a PIL run measured.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct PilStats {
    /// Steps asked for.
    pub steps: u64,
    /// `Controller::step` on the MCU (instructions under QEMU).
    pub step_cost: Option<CostSummary>,
    /// Decoding each measurement frame on the MCU.
    pub decode_cost: Option<CostSummary>,
    /// Encoding each command frame on the MCU.
    pub encode_cost: Option<CostSummary>,
    /// The firmware's link counters, as last reported.
    pub firmware_link: LinkCounters,
    /// Why the firmware last reset, as last reported (the boot frame's before any step).
    pub reset_cause: ResetCause,
    /// The clock the firmware runs on, as last reported.
    pub clock: ClockSource,
    /// The controller's counters, as last reported.
    pub firmware_counters: Counters,
    /// The host's own counts.
    pub host: HostLinkCounters,
}

/// Finds the workspace's target directory: `CARGO_TARGET_DIR` or `<workspace>/target`.
pub fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target"))
}

/// The workspace's root directory (the parent of this crate's).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// Where [`FIRMWARE_BUILD_COMMAND`] puts the `qemu` board's ELF.
pub fn default_firmware_elf() -> PathBuf {
    target_dir()
        .join("qemu")
        .join(FIRMWARE_TARGET)
        .join("release")
        .join("firmware")
}

/// The command that builds the `qemu` board's ELF at [`default_firmware_elf`].
pub const FIRMWARE_BUILD_COMMAND: &str = "cargo build -p firmware --target thumbv7em-none-eabihf --release --no-default-features --features qemu --target-dir target/qemu";

/// The firmware ELF for PIL: the file named by `IBVS_FIRMWARE_ELF` if set, otherwise
/// [`default_firmware_elf`]. Nothing is built here: the ELF flown is the one the user (or the
/// test command, `scripts/test-all.sh`) built, and a missing one is an error that names
/// [`FIRMWARE_BUILD_COMMAND`]. An ELF older than the core's sources is caught at the link's
/// first frame when the protocol changed (`VersionMismatch`), not otherwise: rebuild after
/// changing the core.
pub fn firmware_elf() -> Result<PathBuf, PilError> {
    let p = std::env::var_os(FIRMWARE_ELF_ENV).map_or_else(default_firmware_elf, PathBuf::from);
    if p.is_file() {
        Ok(p)
    } else {
        Err(PilError::ElfMissing(p))
    }
}

fn tail(text: &str, lines: usize) -> String {
    let all: Vec<&str> = text.lines().collect();
    all[all.len().saturating_sub(lines)..].join("\n")
}

/// A unique temporary directory for one run.
fn run_dir() -> io::Result<PathBuf> {
    static N: AtomicU32 = AtomicU32::new(0);
    let dir = std::env::temp_dir().join(format!(
        "ibvs-pil-{}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir)?;
    Ok(dir)
}

/// A byte stream to the firmware with a read timeout: QEMU's socket (PIL) or a serial
/// device (HIL).
pub trait Transport: Read + Write + std::fmt::Debug + Send {
    /// Makes the next reads return after at most `timeout` (a timeout or `WouldBlock`
    /// error when nothing came).
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()>;
}

impl Transport for UnixStream {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        UnixStream::set_read_timeout(self, Some(timeout))
    }
}

impl Transport for serialport::TTYPort {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        serialport::SerialPort::set_timeout(self, timeout).map_err(io::Error::other)
    }
}

/// The serial link to a firmware: frames out and in, faults, counts. Over QEMU's socket
/// (processor in the loop, [`PilLink::spawn`]: the link owns the emulator) or over a serial
/// device (hardware in the loop, [`PilLink::open_serial`]: a board, or QEMU on a pty).
#[derive(Debug)]
pub struct PilLink {
    /// The emulator, when this link started one.
    child: Option<Child>,
    exited: Option<ExitStatus>,
    stream: Box<dyn Transport>,
    dir: PathBuf,
    log: PathBuf,
    decoder: FrameDecoder,
    rx_buf: VecDeque<u8>,
    rx_seq: SequenceTracker,
    host: HostLinkCounters,
    faults: FaultPlan,
    frame_index: u64,
    last_frame: Vec<u8>,
    sent: Vec<u8>,
    received: Vec<u8>,
    boot: Downlink,
    /// The latest telemetry frame received (`None` before the first).
    telemetry: Option<Telemetry>,
    /// Bytes of the command frame being received, and of the last one accepted.
    rx_frame: Vec<u8>,
    last_rx_frame: Vec<u8>,
    /// The firmware's autopilot port (USART2; QEMU's second serial), when wired.
    autopilot: Option<Box<dyn Transport>>,
    /// Bytes read from it not yet taken as whole frames; every byte written to it and read
    /// from it.
    autopilot_rx: Vec<u8>,
    autopilot_sent: Vec<u8>,
    autopilot_received: Vec<u8>,
}

/// Words the `qemu` board's firmware carries in its flash (its boot log's), and the `f405`
/// board's never does (its logs are defmt's, by index).
pub const QEMU_BOARD_MARK: &[u8] = b"firmware: qemu board";

/// The largest firmware file read for the check, bytes (the ELFs are under 4 MiB, debug
/// information included).
const MAX_ELF_BYTES: u64 = 64 << 20;

/// Checks, before QEMU starts, that `elf` is the `qemu` board's firmware: an ELF file
/// (`0x7F 'E' 'L' 'F'`), 32-bit little-endian, for ARM (`e_machine` 40), carrying
/// [`QEMU_BOARD_MARK`]. Anything else is [`PilError::NotQemuFirmware`], saying what it is;
/// a missing file is [`PilError::ElfMissing`].
pub fn check_firmware_elf(elf: &Path) -> Result<(), PilError> {
    if !elf.is_file() {
        return Err(PilError::ElfMissing(elf.to_path_buf()));
    }
    let not = |reason: String| PilError::NotQemuFirmware {
        path: elf.to_path_buf(),
        reason,
    };
    // The ELF header first (52 bytes for a 32-bit ELF), then the whole file for the mark.
    let mut bytes = Vec::new();
    File::open(elf)?.take(52).read_to_end(&mut bytes)?;
    if bytes.get(..4) != Some(b"\x7fELF".as_slice()) {
        let head: Vec<String> = bytes.iter().take(4).map(|b| format!("{b:02x}")).collect();
        return Err(not(format!(
            "not an ELF file (it starts with {}, not 7f 45 4c 46)",
            if head.is_empty() {
                "nothing".into()
            } else {
                head.join(" ")
            }
        )));
    }
    let machine = bytes.get(18..20).map(|m| u16::from_le_bytes([m[0], m[1]]));
    if bytes.get(4) != Some(&1) || bytes.get(5) != Some(&1) || machine != Some(40) {
        return Err(not(format!(
            "an ELF, but not for a 32-bit little-endian ARM core (class {:?}, data {:?}, \
             machine {machine:?}; the firmware's is class 1, data 1, machine 40)",
            bytes.get(4),
            bytes.get(5)
        )));
    }
    bytes.clear();
    File::open(elf)?
        .take(MAX_ELF_BYTES + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_ELF_BYTES {
        return Err(not(format!("an ARM ELF larger than {MAX_ELF_BYTES} bytes")));
    }
    if !bytes
        .windows(QEMU_BOARD_MARK.len())
        .any(|w| w == QEMU_BOARD_MARK)
    {
        return Err(not(
            "an ARM ELF, but not the qemu board's build (the f405 board's? it is built \
             without --features qemu and would not run in QEMU)"
                .into(),
        ));
    }
    Ok(())
}

/// Checks that `elf` is the `qemu` board's firmware ([`check_firmware_elf`]) and makes a run
/// directory for QEMU; the directory and the path of QEMU's log in it.
fn qemu_run_dir(elf: &Path) -> Result<(PathBuf, PathBuf), PilError> {
    check_firmware_elf(elf)?;
    let dir = run_dir()?;
    let log = dir.join("qemu.log");
    Ok((dir, log))
}

/// Removes a run directory, unless `IBVS_PIL_KEEP=1` asks to keep it.
fn remove_run_dir(dir: &Path) {
    if std::env::var(KEEP_ENV).as_deref() != Ok("1") {
        let _ = fs::remove_dir_all(dir);
    }
}

/// Starts QEMU's netduinoplus2 with `elf`, its USART1, USART2, ... on the chardevs `serials`
/// in order (`unix:PATH` or `pty`), the semihosting command line of `opts` (its schedule and
/// extra words), and QEMU's stdout and stderr (the firmware's semihosting log) into the file
/// `log`.
fn start_qemu(
    elf: &Path,
    opts: &PilOptions,
    serials: &[&str],
    log: &Path,
) -> Result<Child, PilError> {
    let log_file = File::create(log)?;
    let mut semihosting = String::from("enable=on,target=native,arg=firmware");
    if opts.schedule == FirmwareSchedule::FreeRunning {
        semihosting.push_str(",arg=free-running");
    }
    for word in &opts.firmware_args {
        semihosting.push_str(",arg=");
        semihosting.push_str(word);
    }
    let program = opts.qemu.display().to_string();
    let mut qemu = Command::new(&opts.qemu);
    qemu.args(["-machine", "netduinoplus2", "-cpu", "cortex-m4"])
        .args(["-icount", "shift=0", "-display", "none", "-monitor", "none"])
        .args(["-semihosting-config", &semihosting]);
    for serial in serials {
        qemu.args(["-serial", serial]);
    }
    qemu.arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(log_file.try_clone()?)
        .stderr(log_file)
        .spawn()
        .map_err(|source| PilError::Spawn { program, source })
}

impl Drop for PilLink {
    fn drop(&mut self) {
        if let (None, Some(child)) = (self.exited, &mut self.child) {
            let _ = child.kill();
            let _ = child.wait();
        }
        remove_run_dir(&self.dir);
    }
}

impl PilLink {
    /// Starts QEMU with `elf` and waits for the firmware's boot frame.
    pub fn spawn(elf: &Path, opts: &PilOptions) -> Result<Self, PilError> {
        let (dir, log) = qemu_run_dir(elf)?;
        let socket = dir.join("link.sock");
        let listener = UnixListener::bind(&socket)?;
        listener.set_nonblocking(true)?;
        let serial = format!("unix:{}", socket.display());
        // USART2: the autopilot's MAVLink port.
        let ap_socket = dir.join("autopilot.sock");
        let ap_listener = UnixListener::bind(&ap_socket)?;
        ap_listener.set_nonblocking(true)?;
        let ap_serial = format!("unix:{}", ap_socket.display());
        let child = start_qemu(elf, opts, &[&serial, &ap_serial], &log)?;
        let mut link = Self::around(
            Some(child),
            // Replaced below once QEMU connects; a placeholder pair keeps `Drop` simple.
            Box::new(UnixStream::pair()?.0),
            dir,
            log,
            opts,
        );
        let deadline = Instant::now() + opts.boot_timeout;
        let stream = link.accept(&listener, deadline, opts.boot_timeout)?;
        link.stream = Box::new(stream);
        link.autopilot = Some(Box::new(link.accept(
            &ap_listener,
            deadline,
            opts.boot_timeout,
        )?));
        let remaining = deadline.saturating_duration_since(Instant::now());
        match link.recv(remaining)? {
            Some(d) if d.link_status.contains(LinkStatus::BOOT) => link.boot = d,
            Some(d) if d.link_status.contains(LinkStatus::PANIC) => {
                return Err(link.panicked(&d));
            }
            _ => return Err(PilError::NoBootFrame(opts.boot_timeout)),
        }
        Ok(link)
    }

    /// A link over the serial device at `path` (hardware in the loop), at `baud`, 8N1, no
    /// flow control, raw. The firmware booted before the device was opened, so there is no
    /// boot frame to wait for: a configuration read is sent once a second until a report
    /// answers it (a pty's other end may drop what it writes until it notices the device
    /// open), within `opts.boot_timeout`. [`PilLink::boot_frame`] is then a placeholder
    /// holding the trim commands, which a step that failed before any answer returns.
    pub fn open_serial(path: &Path, baud: u32, opts: &PilOptions) -> Result<Self, PilError> {
        let port = serialport::new(path.to_string_lossy(), baud)
            .data_bits(serialport::DataBits::Eight)
            .parity(serialport::Parity::None)
            .stop_bits(serialport::StopBits::One)
            .flow_control(serialport::FlowControl::None)
            .timeout(Duration::from_millis(100))
            .open_native()
            .map_err(|source| PilError::Serial {
                path: path.to_path_buf(),
                source,
            })?;
        let dir = run_dir()?;
        let log = dir.join("hil.log");
        fs::write(
            &log,
            format!(
                "hardware in the loop over {} at {baud} baud\n",
                path.display()
            ),
        )?;
        let mut link = Self::around(None, Box::new(port), dir, log, opts);
        link.boot.output.command = ibvs_core::attitude::Command::Surfaces(
            ibvs_core::actuator::ActuatorCommand::from_array(ibvs_core::config::trim_command()),
        );
        let deadline = Instant::now() + opts.boot_timeout;
        while Instant::now() < deadline {
            let wait =
                Duration::from_secs(1).min(deadline.saturating_duration_since(Instant::now()));
            match link.read_config(wait) {
                Ok(_) => return Ok(link),
                Err(PilError::NoConfigReport(_)) => {}
                Err(e) => return Err(e),
            }
        }
        Err(PilError::NoConfigReport(opts.boot_timeout))
    }

    /// The link's state around a transport.
    fn around(
        child: Option<Child>,
        stream: Box<dyn Transport>,
        dir: PathBuf,
        log: PathBuf,
        opts: &PilOptions,
    ) -> Self {
        Self {
            child,
            exited: None,
            stream,
            dir,
            log,
            decoder: FrameDecoder::new(),
            rx_buf: VecDeque::new(),
            rx_seq: SequenceTracker::default(),
            host: HostLinkCounters::default(),
            faults: opts.faults.clone(),
            frame_index: 0,
            last_frame: Vec::new(),
            sent: Vec::new(),
            received: Vec::new(),
            boot: Downlink::default(),
            telemetry: None,
            rx_frame: Vec::with_capacity(MAX_FRAME_LEN),
            last_rx_frame: Vec::with_capacity(MAX_FRAME_LEN),
            autopilot: None,
            autopilot_rx: Vec::new(),
            autopilot_sent: Vec::new(),
            autopilot_received: Vec::new(),
        }
    }

    /// QEMU's connection to `listener`, within `deadline` (blocking from then on).
    fn accept(
        &mut self,
        listener: &UnixListener,
        deadline: Instant,
        timeout: Duration,
    ) -> Result<UnixStream, PilError> {
        loop {
            match listener.accept() {
                Ok((s, _)) => {
                    s.set_nonblocking(false)?;
                    return Ok(s);
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                    self.check_alive()?;
                    if Instant::now() > deadline {
                        return Err(PilError::ConnectTimeout(timeout));
                    }
                    thread::sleep(Duration::from_millis(5));
                }
                Err(e) => return Err(e.into()),
            }
        }
    }

    /// Writes the autopilot's bytes to the firmware's autopilot port (kept in
    /// [`PilLink::autopilot_sent`]).
    pub fn send_autopilot(&mut self, bytes: &[u8]) -> Result<(), PilError> {
        self.check_alive()?;
        let port = self.autopilot.as_mut().ok_or(PilError::NoAutopilotPort)?;
        port.write_all(bytes)?;
        port.flush()?;
        self.autopilot_sent.extend_from_slice(bytes);
        Ok(())
    }

    /// The firmware's MAVLink frames up to and including its next `SET_ATTITUDE_TARGET`,
    /// waiting at most `timeout` (kept in [`PilLink::autopilot_received`]).
    pub fn recv_setpoint(&mut self, timeout: Duration) -> Result<Vec<u8>, PilError> {
        let deadline = Instant::now() + timeout;
        let mut out = Vec::new();
        loop {
            // Whole frames already in: a MAVLink 2 frame is 12 bytes and its payload.
            while let Some(len) = self
                .autopilot_rx
                .get(1)
                .map(|&n| 12 + usize::from(n))
                .filter(|&len| self.autopilot_rx.len() >= len)
            {
                let frame: Vec<u8> = self.autopilot_rx.drain(..len).collect();
                let setpoint = read_setpoint(&frame, 0.0).setpoint.is_some();
                out.extend_from_slice(&frame);
                if setpoint {
                    self.autopilot_received.extend_from_slice(&out);
                    return Ok(out);
                }
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                self.autopilot_received.extend_from_slice(&out);
                return Err(PilError::NoSetpoint(timeout));
            }
            let port = self.autopilot.as_mut().ok_or(PilError::NoAutopilotPort)?;
            port.set_read_timeout(left.max(Duration::from_millis(1)))?;
            let mut buf = [0u8; 256];
            match port.read(&mut buf) {
                Ok(0) => {
                    return Err(self
                        .exit_status()
                        .map_or(PilError::NoSetpoint(timeout), |st| self.exited_error(st)));
                }
                Ok(n) => self.autopilot_rx.extend_from_slice(&buf[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) => {}
                Err(e) => return Err(e.into()),
            }
        }
    }

    /// Every byte written to the firmware's autopilot port so far.
    pub fn autopilot_sent(&self) -> &[u8] {
        &self.autopilot_sent
    }

    /// Every byte the firmware sent on its autopilot port and the link read so far.
    pub fn autopilot_received(&self) -> &[u8] {
        &self.autopilot_received
    }

    /// The error for a panic frame, once QEMU has finished (so the log is complete).
    fn panicked(&mut self, d: &Downlink) -> PilError {
        let deadline = Instant::now() + Duration::from_secs(5);
        while let (None, Some(child)) = (self.exited, &mut self.child) {
            if Instant::now() >= deadline {
                break;
            }
            self.exited = child.try_wait().ok().flatten();
            thread::sleep(Duration::from_millis(10));
        }
        PilError::FirmwarePanicked {
            output: Box::new(d.output),
            log: self.log.clone(),
            tail: tail(&self.log_text(), 20),
        }
    }

    /// QEMU's exit status, once it has exited.
    pub fn exit_status(&mut self) -> Option<ExitStatus> {
        if let (None, Some(child)) = (self.exited, &mut self.child) {
            self.exited = child.try_wait().ok().flatten();
        }
        self.exited
    }

    /// The firmware's boot frame.
    pub fn boot_frame(&self) -> &Downlink {
        &self.boot
    }

    /// The file holding QEMU's stdout and stderr (the firmware's semihosting log).
    pub fn log_path(&self) -> &Path {
        &self.log
    }

    /// The log so far.
    pub fn log_text(&self) -> String {
        fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// Every byte written to the link so far, faults included.
    pub fn sent_bytes(&self) -> &[u8] {
        &self.sent
    }

    /// Every byte read from the link so far, in order, whatever it was (frames of every kind,
    /// garbage, idle zeros): a capture of the firmware's side of the link.
    pub fn received_bytes(&self) -> &[u8] {
        &self.received
    }

    /// The last measurement frame encoded (as [`PilLink::resend`] repeats it: before faults),
    /// COBS-encoded, its zero delimiter included; empty before the first.
    pub fn last_measurement_frame(&self) -> &[u8] {
        &self.last_frame
    }

    /// The raw bytes of the last command frame accepted by [`PilLink::recv`], COBS-encoded,
    /// its zero delimiter included (the boot frame's before the first step).
    pub fn last_command_frame(&self) -> &[u8] {
        &self.last_rx_frame
    }

    /// The host's counts.
    pub fn host_counters(&self) -> &HostLinkCounters {
        &self.host
    }

    /// Returns `FirmwareExited` if QEMU has exited.
    fn check_alive(&mut self) -> Result<(), PilError> {
        if let (None, Some(child)) = (self.exited, &mut self.child) {
            self.exited = child.try_wait()?;
        }
        match self.exited {
            None => Ok(()),
            Some(status) => Err(self.exited_error(status)),
        }
    }

    fn exited_error(&self, status: ExitStatus) -> PilError {
        PilError::FirmwareExited {
            status: status.to_string(),
            log: self.log.clone(),
            tail: tail(&self.log_text(), 20),
        }
    }

    /// Writes raw bytes to the link (recorded in [`PilLink::sent_bytes`]).
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), PilError> {
        self.check_alive()?;
        self.stream.write_all(bytes)?;
        self.stream.flush()?;
        self.sent.extend_from_slice(bytes);
        Ok(())
    }

    /// Encodes and sends a new measurement frame, applying the faults planned for it.
    pub fn send_measurement(&mut self, up: &Uplink) -> Result<(), PilError> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_uplink(up, &mut buf)
            .map_err(PilError::Encode)?
            .to_vec();
        self.last_frame.clone_from(&frame);
        let index = self.frame_index;
        self.frame_index += 1;
        self.host.frames_sent += 1;
        let faults = self.faults.on(index).to_vec();
        self.host.faults_injected += faults.len() as u64;
        let mut wire = frame;
        let (mut send, mut twice) = (true, false);
        for f in &faults {
            match f {
                Fault::CorruptByte { index, mask } => {
                    let body = wire.len() - 1;
                    let i = index % body;
                    let mut m = *mask;
                    if wire[i] ^ m == 0 {
                        m ^= 1;
                    }
                    wire[i] ^= m;
                }
                Fault::Drop => send = false,
                Fault::Delay(d) => thread::sleep(*d),
                Fault::GarbageBefore(g) => self.send_raw(g)?,
                Fault::Duplicate => twice = true,
            }
        }
        if send {
            self.send_raw(&wire)?;
            if twice {
                self.send_raw(&wire)?;
            }
        }
        Ok(())
    }

    /// Sends the last measurement frame again, unchanged (a retransmission).
    pub fn resend(&mut self) -> Result<(), PilError> {
        let frame = self.last_frame.clone();
        self.host.retransmissions += 1;
        self.send_raw(&frame)
    }

    /// The next command frame within `timeout` (`None` when none came). Rejected frames are
    /// counted in [`HostLinkCounters::rx`] and skipped; a telemetry frame is kept
    /// ([`PilLink::telemetry`]); a configuration report (none is expected here: the firmware
    /// sends one only in answer to a configuration frame) is counted in
    /// [`HostLinkCounters::unexpected_frames`] and skipped.
    pub fn recv(&mut self, timeout: Duration) -> Result<Option<Downlink>, PilError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.recv_message(left)? {
                None => return Ok(None),
                Some(FlightComputerMessage::Command(d)) => return Ok(Some(d)),
                Some(FlightComputerMessage::Telemetry(t)) => self.telemetry = Some(t),
                Some(FlightComputerMessage::ConfigReport(_)) => self.host.unexpected_frames += 1,
            }
        }
    }

    /// The latest telemetry frame received: the firmware's counters, why it reset, its clock
    /// (`None` before the first; the firmware sends one after its boot frame).
    pub fn telemetry(&self) -> Option<&Telemetry> {
        self.telemetry.as_ref()
    }

    /// Asks for a telemetry frame and waits `timeout` for it (command frames meanwhile are
    /// counted in [`HostLinkCounters::unexpected_frames`] and skipped); it is also kept.
    pub fn request_telemetry(&mut self, timeout: Duration) -> Result<Telemetry, PilError> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_telemetry_request(&mut buf).map_err(PilError::Encode)?;
        self.send_raw(frame)?;
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.recv_message(left)? {
                None => return Err(PilError::NoTelemetry(timeout)),
                Some(FlightComputerMessage::Telemetry(t)) => {
                    self.telemetry = Some(t);
                    return Ok(t);
                }
                Some(FlightComputerMessage::Command(d))
                    if d.link_status.contains(LinkStatus::PANIC) =>
                {
                    return Err(self.panicked(&d));
                }
                Some(_) => self.host.unexpected_frames += 1,
            }
        }
    }

    /// The next configuration report within `timeout` (`None` when none came). A command
    /// frame meanwhile is counted in [`HostLinkCounters::unexpected_frames`] and skipped.
    pub fn recv_report(&mut self, timeout: Duration) -> Result<Option<ConfigReport>, PilError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.recv_message(left)? {
                None => return Ok(None),
                Some(FlightComputerMessage::ConfigReport(r)) => return Ok(Some(r)),
                Some(FlightComputerMessage::Command(d))
                    if d.link_status.contains(LinkStatus::PANIC) =>
                {
                    return Err(self.panicked(&d));
                }
                Some(FlightComputerMessage::Command(_)) => self.host.unexpected_frames += 1,
                Some(FlightComputerMessage::Telemetry(t)) => self.telemetry = Some(t),
            }
        }
    }

    /// Sends a configuration write and waits `timeout` for its report.
    pub fn write_config(
        &mut self,
        cfg: &ControllerConfig,
        timeout: Duration,
    ) -> Result<ConfigReport, PilError> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_config_write(cfg, &mut buf).map_err(PilError::Encode)?;
        self.send_raw(frame)?;
        // A write is never answered `Active`: such a report answers an earlier read (a
        // serial link's hello, `open_serial`, answered late) and is skipped, counted.
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.recv_report(left)? {
                Some(r) if r.status == ConfigStatus::Active => self.host.unexpected_frames += 1,
                Some(r) => return Ok(r),
                None => return Err(PilError::NoConfigReport(timeout)),
            }
        }
    }

    /// Sends a configuration read and waits `timeout` for its report.
    pub fn read_config(&mut self, timeout: Duration) -> Result<ConfigReport, PilError> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_config_read(&mut buf).map_err(PilError::Encode)?;
        self.send_raw(frame)?;
        self.recv_report(timeout)?
            .ok_or(PilError::NoConfigReport(timeout))
    }

    /// The next frame of either kind within `timeout` (`None` when none came). Rejected
    /// frames are counted in [`HostLinkCounters::rx`] and skipped.
    pub fn recv_message(
        &mut self,
        timeout: Duration,
    ) -> Result<Option<FlightComputerMessage>, PilError> {
        let deadline = Instant::now() + timeout;
        let mut chunk = [0u8; 512];
        loop {
            while let Some(b) = self.rx_buf.pop_front() {
                if self.rx_frame.len() < MAX_FRAME_LEN {
                    self.rx_frame.push(b);
                }
                let r = self
                    .decoder
                    .feed(b)
                    .map(|r| r.and_then(|p| p.flight_computer_message()));
                if b == 0 {
                    // A zero ends a frame (or an empty one): the bytes kept are that frame's.
                    if matches!(r, Some(Ok(_))) {
                        std::mem::swap(&mut self.rx_frame, &mut self.last_rx_frame);
                    }
                    self.rx_frame.clear();
                }
                let Some(r) = r else {
                    continue;
                };
                match r {
                    Ok(m) => {
                        let seq = match &m {
                            FlightComputerMessage::Command(d) => d.seq,
                            FlightComputerMessage::ConfigReport(r) => r.seq,
                            FlightComputerMessage::Telemetry(t) => t.seq,
                        };
                        self.host.rx.count_sequence(self.rx_seq.observe(seq));
                        return Ok(Some(m));
                    }
                    Err(e) => self.host.rx.count(e),
                }
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(None);
            }
            self.stream
                .set_read_timeout((deadline - now).max(Duration::from_micros(100)))?;
            match self.stream.read(&mut chunk) {
                Ok(0) => {
                    let Some(child) = &mut self.child else {
                        return Err(PilError::LinkClosed);
                    };
                    let status = child.wait()?;
                    self.exited = Some(status);
                    return Err(self.exited_error(status));
                }
                Ok(n) => {
                    self.rx_buf.extend(&chunk[..n]);
                    self.received.extend_from_slice(&chunk[..n]);
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) =>
                {
                    return Ok(None);
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e.into()),
            }
        }
    }

    /// Every command frame arriving within `window`.
    pub fn drain(&mut self, window: Duration) -> Result<Vec<Downlink>, PilError> {
        let deadline = Instant::now() + window;
        let mut out = Vec::new();
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.recv(left)? {
                Some(d) => out.push(d),
                None => return Ok(out),
            }
        }
    }

    /// Stops QEMU (if this link started it); returns its log.
    pub fn shutdown(mut self) -> String {
        if let (None, Some(child)) = (self.exited, &mut self.child) {
            let _ = child.kill();
            self.exited = child.wait().ok();
        }
        self.log_text()
    }
}

/// QEMU running a firmware with its serial link on a pseudo-terminal (`-serial pty`): the
/// device a hardware-in-the-loop link opens ([`PilLink::open_serial`]), so the termios path a
/// board's serial adapter takes is tested against the emulated board. Killed, reaped and its
/// directory removed when dropped.
#[derive(Debug)]
pub struct QemuPty {
    child: Child,
    pty: PathBuf,
    dir: PathBuf,
    log: PathBuf,
}

impl QemuPty {
    /// Starts QEMU with `elf` (the schedule of `opts`: lockstep by default) and waits,
    /// within `opts.boot_timeout`, for it to name its pty ("char device redirected to
    /// /dev/pts/N").
    pub fn spawn(elf: &Path, opts: &PilOptions) -> Result<Self, PilError> {
        let (dir, log) = qemu_run_dir(elf)?;
        let child = start_qemu(elf, opts, &["pty"], &log)?;
        let mut q = Self {
            child,
            pty: PathBuf::new(),
            dir,
            log,
        };
        let deadline = Instant::now() + opts.boot_timeout;
        loop {
            let text = fs::read_to_string(&q.log).unwrap_or_default();
            let mark = "char device redirected to ";
            if let Some(at) = text.find(mark) {
                let rest = &text[at + mark.len()..];
                q.pty = PathBuf::from(rest.split_whitespace().next().unwrap_or_default());
                return Ok(q);
            }
            if let Some(status) = q.child.try_wait()? {
                return Err(PilError::FirmwareExited {
                    status: status.to_string(),
                    log: q.log.clone(),
                    tail: tail(&text, 20),
                });
            }
            if Instant::now() > deadline {
                return Err(PilError::ConnectTimeout(opts.boot_timeout));
            }
            thread::sleep(Duration::from_millis(10));
        }
    }

    /// The pty's device path.
    pub fn path(&self) -> &Path {
        &self.pty
    }

    /// QEMU's output so far (the firmware's semihosting log).
    pub fn log_text(&self) -> String {
        fs::read_to_string(&self.log).unwrap_or_default()
    }
}

impl Drop for QemuPty {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        remove_run_dir(&self.dir);
    }
}

/// The firmware in QEMU as a [`FlightComputer`] (lockstep).
#[derive(Debug)]
pub struct PilFlightComputer {
    link: PilLink,
    opts: PilOptions,
    next_seq: u32,
    last_output: ControllerOutput,
    last_error: Option<PilError>,
    history: Vec<Downlink>,
    steps: u64,
    /// The configuration written ([`PilFlightComputer::configure`]); the firmware's
    /// default before.
    config: ControllerConfig,
}

impl PilFlightComputer {
    /// Starts the firmware at `elf` in QEMU with the default options (lockstep, no faults).
    pub fn spawn(elf: &Path) -> Result<Self, PilError> {
        Self::spawn_with(elf, PilOptions::default())
    }

    /// Flies a firmware on the serial device at `path` at `baud` (hardware in the loop,
    /// [`PilLink::open_serial`]); the firmware must run the lockstep schedule (the `f405`
    /// board's `lockstep` feature, or the `qemu` board).
    pub fn open_serial(path: &Path, baud: u32, opts: PilOptions) -> Result<Self, PilError> {
        let link = PilLink::open_serial(path, baud, &opts)?;
        Ok(Self::around(link, opts))
    }

    /// Starts the firmware at `elf` with `opts` (the schedule is forced to lockstep).
    pub fn spawn_with(elf: &Path, mut opts: PilOptions) -> Result<Self, PilError> {
        opts.schedule = FirmwareSchedule::Lockstep;
        let link = PilLink::spawn(elf, &opts)?;
        Ok(Self::around(link, opts))
    }

    fn around(link: PilLink, opts: PilOptions) -> Self {
        let last_output = link.boot_frame().output;
        Self {
            link,
            opts,
            next_seq: 1,
            last_output,
            last_error: None,
            history: Vec::new(),
            steps: 0,
            config: ControllerConfig::default(),
        }
    }

    /// Makes the firmware fly `cfg` (before the first step: the firmware takes a new
    /// configuration in standby only). Succeeds only when the firmware reports it applied
    /// exactly `cfg`; flying the default is a write too, so a run never depends on what the
    /// firmware booted with. Waits [`PilOptions::config_timeout`] for the report.
    pub fn configure(&mut self, cfg: &ControllerConfig) -> Result<(), PilError> {
        let r = self.link.write_config(cfg, self.opts.config_timeout)?;
        if r.status != ConfigStatus::Applied {
            return Err(PilError::ConfigRefused(r.status));
        }
        let sent = config_id(cfg);
        if r.config_id != sent || r.config != *cfg {
            return Err(PilError::ConfigMismatch {
                got: r.config_id,
                sent,
            });
        }
        self.config = *cfg;
        Ok(())
    }

    /// One step over the link: the command frame answering `input`, or why there is none.
    pub fn try_step(&mut self, input: &ControllerInput) -> Result<Downlink, PilError> {
        let seq = self.next_seq;
        self.next_seq = self.next_seq.wrapping_add(1);
        self.link.send_measurement(&Uplink { seq, input: *input })?;
        let timeout = self.opts.step_timeout;
        for attempt in 0..=self.opts.retries {
            if attempt > 0 {
                self.link.resend()?;
            }
            let deadline = Instant::now() + timeout;
            loop {
                let left = deadline.saturating_duration_since(Instant::now());
                match self.link.recv(left)? {
                    None => {
                        self.link.host.timeouts += 1;
                        break;
                    }
                    Some(d) if d.link_status.contains(LinkStatus::PANIC) => {
                        return Err(self.link.panicked(&d));
                    }
                    Some(d) if d.echo_seq == Some(seq) => {
                        self.last_output = d.output;
                        self.history.push(d);
                        return Ok(d);
                    }
                    Some(_) => self.link.host.unexpected_frames += 1,
                }
            }
        }
        Err(PilError::Timeout {
            seq,
            timeout,
            attempts: self.opts.retries + 1,
        })
    }

    /// One step through the autopilot: the autopilot's bytes to the firmware's autopilot
    /// port first, then the measurement frame; its command frame, and for an attitude
    /// command the firmware's MAVLink frames up to its `SET_ATTITUDE_TARGET` (appended to
    /// `to_autopilot`).
    pub fn try_step_through_autopilot(
        &mut self,
        input: &ControllerInput,
        from_autopilot: &[u8],
        to_autopilot: &mut Vec<u8>,
    ) -> Result<Downlink, PilError> {
        self.link.send_autopilot(from_autopilot)?;
        // The two ports are two sockets: QEMU may hand the guest the measurement frame
        // before the last of the autopilot's bytes. The firmware steps on the autopilot's
        // `ATTITUDE` whatever follows it, so the outputs agree either way, but the bytes left
        // over are decoded (and counted) in the next step: the benchmark's dearest decode
        // through the autopilot moved by up to 13 % between runs of one ELF (12,830..14,664
        // instructions). A millisecond lets QEMU take them all first.
        std::thread::sleep(AUTOPILOT_SETTLE);
        let d = self.try_step(input)?;
        if matches!(d.output.command, FlightCommand::Attitude(_)) {
            let frames = self.link.recv_setpoint(self.opts.step_timeout)?;
            to_autopilot.extend_from_slice(&frames);
        }
        Ok(d)
    }

    /// The error of the last failed step, if any.
    pub fn last_error(&self) -> Option<&PilError> {
        self.last_error.as_ref()
    }

    /// Every command frame received for a step, in order (retransmitted answers included
    /// once, as the answer).
    pub fn history(&self) -> &[Downlink] {
        &self.history
    }

    /// The link (sent bytes, log, host counters).
    pub fn link(&self) -> &PilLink {
        &self.link
    }

    /// The link, to send frames of its own (a configuration read, raw bytes).
    pub fn link_mut(&mut self) -> &mut PilLink {
        &mut self.link
    }

    /// A step's output: the command frame's, or on a failure the last output received
    /// (held), the failure counted and kept.
    fn held_on_failure(&mut self, result: Result<Downlink, PilError>) -> ControllerOutput {
        match result {
            Ok(d) => d.output,
            Err(e) => {
                self.link.host.failed_steps += 1;
                self.last_error = Some(e);
                self.last_output
            }
        }
    }

    /// What the run measured so far.
    pub fn stats(&self) -> PilStats {
        let unit = self
            .history
            .last()
            .map_or(CostUnit::Unavailable, |d| d.cost.unit);
        // Retransmitted answers repeat a step's figures: count each step once.
        let fresh: Vec<&Downlink> = self
            .history
            .iter()
            .filter(|d| !d.link_status.contains(LinkStatus::RETRANSMIT))
            .collect();
        let costs = |f: fn(&Downlink) -> u32| -> Vec<u32> { fresh.iter().map(|d| f(d)).collect() };
        let t = self.link.telemetry().copied().unwrap_or_default();
        PilStats {
            steps: self.steps,
            step_cost: CostSummary::of(unit, &costs(|d| d.cost.step)),
            decode_cost: CostSummary::of(unit, &costs(|d| d.cost.decode)),
            // The first frame carries the boot frame's encoding cost; all are command frames.
            encode_cost: CostSummary::of(unit, &costs(|d| d.cost.encode_prev)),
            firmware_link: t.link,
            reset_cause: t.reset_cause,
            clock: t.clock,
            firmware_counters: t.counters,
            host: self.link.host,
        }
    }

    /// Asks the firmware for its telemetry now, so the statistics are current (the
    /// lockstep firmware sends one only on request); a failure is kept as the last error.
    pub fn refresh_telemetry(&mut self) -> Option<Telemetry> {
        match self.link.request_telemetry(self.opts.step_timeout) {
            Ok(t) => Some(t),
            Err(e) => {
                self.last_error = Some(e);
                None
            }
        }
    }

    /// Stops QEMU; returns the statistics (with telemetry asked for at the end) and the
    /// firmware's log.
    pub fn shutdown(mut self) -> (PilStats, String) {
        if self.link.exit_status().is_none() {
            self.refresh_telemetry();
        }
        let stats = self.stats();
        (stats, self.link.shutdown())
    }
}

impl FlightComputer for PilFlightComputer {
    /// One lockstep step; on a link failure the last output received is returned (held),
    /// the failure counted and kept (see the module doc).
    fn step(&mut self, input: &ControllerInput) -> ControllerOutput {
        self.steps += 1;
        let result = self.try_step(input);
        self.held_on_failure(result)
    }

    /// From the configuration written.
    fn autopilot_design(&self) -> Option<ibvs_core::attitude::AttitudeLoopConfig> {
        self.config.autopilot_loop()
    }

    /// The firmware runs its own side of the link: the simulator's session is not used.
    fn step_through_autopilot(&mut self, link: AutopilotStep<'_>) -> ControllerOutput {
        self.steps += 1;
        let result =
            self.try_step_through_autopilot(link.input, link.from_autopilot, link.to_autopilot);
        self.held_on_failure(result)
    }

    /// From the latest telemetry frame (every 10 to 50 control periods; `None` before the
    /// first).
    fn probe_tip_image(&self) -> Option<[f32; 2]> {
        self.link.telemetry().map(|t| t.probe_tip_image)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summarises_costs() {
        let s = CostSummary::of(CostUnit::Instructions, &[5, 1, 9, 3]).expect("samples");
        assert_eq!((s.min, s.median, s.max, s.samples), (1, 5, 9, 4));
        assert!(CostSummary::of(CostUnit::Instructions, &[]).is_none());
    }

    #[test]
    fn plans_faults_by_frame() {
        let p = FaultPlan::new()
            .at(3, Fault::Drop)
            .at(3, Fault::Duplicate)
            .at(7, Fault::Delay(Duration::from_millis(1)));
        assert_eq!(p.on(3), [Fault::Drop, Fault::Duplicate]);
        assert!(p.on(4).is_empty());
        assert_eq!(p.len(), 3);
    }

    #[test]
    fn a_missing_elf_is_named() {
        let e = PilLink::spawn(Path::new("/nonexistent/firmware"), &PilOptions::default());
        assert!(matches!(e, Err(PilError::ElfMissing(_))));
    }

    /// Each check of the firmware file, on files made to fail only it.
    #[test]
    fn only_the_qemu_boards_arm_elf_passes() {
        let dir = run_dir().expect("a directory");
        let file = |name: &str, bytes: &[u8]| {
            let p = dir.join(name);
            fs::write(&p, bytes).expect("written");
            p
        };
        // A 32-bit little-endian ARM ELF header, then the mark or not.
        let mut arm = vec![0x7f, b'E', b'L', b'F', 1, 1, 1];
        arm.resize(18, 0);
        arm.extend_from_slice(&40u16.to_le_bytes());
        arm.resize(64, 0);
        let mut good = arm.clone();
        good.extend_from_slice(QEMU_BOARD_MARK);
        let mut x86 = good.clone();
        x86[18] = 62;
        let mut big = good.clone();
        big[5] = 2;
        let reason = |p: &Path| match check_firmware_elf(p) {
            Err(PilError::NotQemuFirmware { reason, .. }) => reason,
            other => panic!("{other:?}"),
        };
        assert!(check_firmware_elf(&file("good", &good)).is_ok());
        assert!(
            reason(&file("text", b"#!/bin/sh\n"))
                .contains("not an ELF file (it starts with 23 21 2f 62")
        );
        assert!(reason(&file("empty", b"")).contains("starts with nothing"));
        assert!(reason(&file("x86", &x86)).contains("machine Some(62)"));
        assert!(reason(&file("big-endian", &big)).contains("data Some(2)"));
        assert!(reason(&file("f405", &arm)).contains("the f405 board's?"));
        remove_run_dir(&dir);
    }
}

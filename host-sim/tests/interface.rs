//! The interface control document (`docs/interface.md`) against the types and the firmware.
//!
//! - The document's layout tables are the wire types' layout, traced from their serde derives
//!   (`layout.rs`): every container, field, type, variant and index; its size table is
//!   derived from them; its history ends at the current protocol version with the current
//!   layout's fingerprint; its bit tables are the constants in the sources. A change of the
//!   types fails here with what to do: `IBVS_BLESS=1 cargo test -p host-sim --test interface`
//!   rewrites the generated parts, keeping the hand-written units and meanings, and marks new
//!   rows `TODO` (which fails until they are written).
//! - `scripts/wire.py`, a decoder and encoder written from the document alone (Python,
//!   standard library; it reads the document's tables), decodes bodies generated from the
//!   layout with distinct values in every field (every variant, NaN payloads, the longest
//!   varints) as the types do, and encodes them byte for byte as the core does.
//! - Processor in the loop: it decodes every frame of a docking flown by the firmware in
//!   QEMU (both directions) with every field equal to the in-process values, and the frames
//!   it encodes (a configuration, measurements) are accepted and flown by the firmware.
//!   Needs `python3`, `qemu-system-arm` and the firmware ELF (`IBVS_FIRMWARE_ELF`, as
//!   `scripts/test-all.sh` sets it); a missing one fails the test.

#[path = "interface/doc.rs"]
mod doc;
#[path = "interface/layout.rs"]
mod layout;

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::Duration;

use host_sim::pil::{PilFlightComputer, workspace_root};
use host_sim::sim::{Scenario, run};
use ibvs_core::ControllerConfig;
use ibvs_core::wire::{
    FlightComputerMessage, FrameDecoder, FrameKind, PROTOCOL_VERSION, PeerMessage, config_id,
    crc32c, encode_message,
};
use layout::{Fill, Generator, canonical_of};
use serde_json::{Value as J, json};
use serde_reflection::Registry;

const DOC: &str = "docs/interface.md";
const SCRIPT: &str = "scripts/wire.py";

/// Every frame kind: its name in the document, its body (a root of the layout, or `()` for an
/// empty one) and who sends it.
const KINDS: [(FrameKind, &str, &str, &str); 7] = [
    (
        FrameKind::Measurement,
        "measurement",
        "Uplink",
        "peer to flight computer",
    ),
    (
        FrameKind::Command,
        "command",
        "Downlink",
        "flight computer to peer",
    ),
    (
        FrameKind::ConfigWrite,
        "configuration write",
        "ControllerConfig",
        "peer to flight computer",
    ),
    (
        FrameKind::ConfigRead,
        "configuration read",
        "()",
        "peer to flight computer",
    ),
    (
        FrameKind::ConfigReport,
        "configuration report",
        "ConfigReport",
        "flight computer to peer",
    ),
    (
        FrameKind::TelemetryRequest,
        "telemetry request",
        "()",
        "peer to flight computer",
    ),
    (
        FrameKind::Telemetry,
        "telemetry",
        "Telemetry",
        "flight computer to peer",
    ),
];

fn doc_path() -> PathBuf {
    workspace_root().join(DOC)
}

fn read_doc() -> String {
    std::fs::read_to_string(doc_path()).expect("docs/interface.md")
}

/// Smallest and largest length of a frame whose payload is `p` bytes, on the wire: COBS adds
/// one code byte per started block of 254 bytes (at least one; the smallest when the
/// payload's zeros end every block), then the terminating zero.
fn wire_len(p: (usize, usize)) -> (usize, usize) {
    (p.0 + 2, p.1 + p.1.div_ceil(254) + 1)
}

/// The size region, generated.
fn sizes_region(reg: &Registry) -> String {
    let caps = layout::string_capacities();
    let mut out = String::from(
        "| frame | kind byte | direction | body | body, bytes | payload, bytes | on the wire, bytes |\n\
         |---|---|---|---|---|---|---|\n",
    );
    for (kind, name, body, dir) in KINDS {
        let b = if body == "()" {
            (0, 0)
        } else {
            layout::container_size(body, reg, &caps)
        };
        let p = (b.0 + 6, b.1 + 6);
        let w = wire_len(p);
        let byte = kind.byte();
        out += &format!(
            "| {name} | `{}` 0x{byte:02X} | {dir} | `{body}` | {}..{} | {}..{} | {}..{} |\n",
            byte as char, b.0, b.1, p.0, p.1, w.0, w.1
        );
    }
    out
}

/// The constants region, generated.
fn constants_region() -> String {
    use ibvs_core::wire::{
        CRC_LEN, HEADER_LEN, MAX_BODY_LEN, MAX_FRAME_LEN, MAX_PAYLOAD_LEN, STEP_PAYLOAD_LEN,
        TELEMETRY_MAX_PERIODS, TELEMETRY_MIN_PERIODS,
    };
    let rows: [(&str, usize, &str); 9] = [
        (
            "PROTOCOL_VERSION",
            PROTOCOL_VERSION.into(),
            "every frame's first byte",
        ),
        (
            "MAX_FRAME_LEN",
            MAX_FRAME_LEN,
            "bytes: the longest frame on the wire, its zero included",
        ),
        (
            "MAX_PAYLOAD_LEN",
            MAX_PAYLOAD_LEN,
            "bytes: the longest payload (version, kind, body, CRC) before COBS",
        ),
        ("MAX_BODY_LEN", MAX_BODY_LEN, "bytes: the longest body"),
        ("HEADER_LEN", HEADER_LEN, "bytes: version and kind"),
        ("CRC_LEN", CRC_LEN, "bytes: the CRC-32C after the body"),
        (
            "STEP_PAYLOAD_LEN",
            STEP_PAYLOAD_LEN,
            "bytes: the longest payload of a measurement or command frame",
        ),
        (
            "TELEMETRY_MIN_PERIODS",
            TELEMETRY_MIN_PERIODS as usize,
            "control periods: free-running, a changed counter is sent at most this often",
        ),
        (
            "TELEMETRY_MAX_PERIODS",
            TELEMETRY_MAX_PERIODS as usize,
            "control periods: free-running, a telemetry frame at least this often",
        ),
    ];
    let mut out = String::from("| constant | value | what |\n|---|---|---|\n");
    for (name, value, what) in rows {
        out += &format!("| `{name}` | {value} | {what} |\n");
    }
    out
}

/// The fingerprint of the layout: CRC-32C of its type columns, one line per row.
fn fingerprint(types: &[layout::Container]) -> u32 {
    let mut text = String::new();
    for c in types {
        text += &format!("{} {}\n", c.name, c.kind);
        for r in &c.rows {
            text += &format!("  {:?} {} {}\n", r.index, r.name, r.ty);
        }
    }
    crc32c(text.as_bytes())
}

/// The named bits of a flag type as the source defines them: `pub const NAME: uN = 1 << k;`
/// inside `impl TYPE {`.
fn source_bits(file: &str, ty: &str) -> Vec<(u32, String)> {
    let text = std::fs::read_to_string(workspace_root().join(file)).expect("source");
    let start = text
        .find(&format!("impl {ty} {{"))
        .unwrap_or_else(|| panic!("impl {ty} in {file}"));
    let block = &text[start..];
    let block = &block[..block.find("\n}\n").expect("end of impl")];
    block
        .lines()
        .filter_map(|l| {
            let l = l.trim().strip_prefix("pub const ")?;
            let (name, rest) = l.split_once(':')?;
            let bit = rest.split("1 << ").nth(1)?.trim_end_matches(';').trim();
            Some((bit.parse().ok()?, name.trim().to_string()))
        })
        .collect()
}

/// The document's bit table of `ty` (`| bit | mask | name | meaning |`, after the marker
/// `<!-- bits:TY -->`).
fn doc_bits(doc: &str, ty: &str) -> Vec<(u32, String, String)> {
    let marker = format!("<!-- bits:{ty} -->");
    let at = doc
        .find(&marker)
        .unwrap_or_else(|| panic!("{marker} in {DOC}"));
    let lines: Vec<&str> = doc[at..].lines().skip(1).collect();
    lines
        .iter()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2)
        .map(|l| {
            let c = doc::cells(l);
            (
                c[0].parse().expect("a bit number"),
                c[2].clone(),
                c[1].clone(),
            )
        })
        .collect()
}

/// The document is the types' layout: containers, fields, types, variants and indices; the
/// sizes derived from them; the history at the current version and layout; the bit tables.
#[test]
fn the_document_is_the_layout_of_the_types() {
    let reg = layout::registry();
    let types = layout::containers(&reg);
    let mut text = read_doc();
    if std::env::var("IBVS_BLESS").as_deref() == Ok("1") {
        let (_, _, old) = doc::region(&text, "layout");
        let new = doc::bless_layout(&types, &doc::parse_layout(old));
        text = doc::replace_region(&text, "layout", &new);
        text = doc::replace_region(&text, "sizes", &sizes_region(&reg));
        text = doc::replace_region(&text, "constants", &constants_region());
        std::fs::write(doc_path(), &text).expect("write docs/interface.md");
    }
    let hint = "run `IBVS_BLESS=1 cargo test -p host-sim --test interface \
                the_document_is_the_layout_of_the_types` to regenerate the tables, then write \
                the units and meanings marked TODO";
    let (_, _, layout_text) = doc::region(&text, "layout");
    let documented = doc::parse_layout(layout_text);
    let in_doc: Vec<&layout::Container> = documented.iter().map(|d| &d.container).collect();
    let names = |v: &[&layout::Container]| v.iter().map(|c| c.name.clone()).collect::<Vec<_>>();
    let type_refs: Vec<&layout::Container> = types.iter().collect();
    assert_eq!(names(&in_doc), names(&type_refs), "the containers: {hint}");
    for (d, t) in in_doc.iter().zip(&types) {
        assert_eq!(*d, t, "{}: {hint}", t.name);
    }
    for d in &documented {
        assert!(
            !d.description.is_empty() && !d.description.contains("TODO"),
            "{}: describe it in {DOC}",
            d.container.name
        );
        for (row, (unit, meaning)) in d.container.rows.iter().zip(&d.notes) {
            let where_ = format!("{}.{}", d.container.name, row.name);
            assert!(
                !meaning.is_empty() && !meaning.contains("TODO"),
                "{where_}: its meaning in {DOC}"
            );
            if d.container.kind != "enum" {
                assert!(
                    !unit.is_empty() && !unit.contains("TODO"),
                    "{where_}: its unit in {DOC}"
                );
            }
        }
    }
    let (_, _, sizes) = doc::region(&text, "sizes");
    assert_eq!(sizes, sizes_region(&reg), "the size table: {hint}");
    let (_, _, constants) = doc::region(&text, "constants");
    assert_eq!(constants, constants_region(), "the constants: {hint}");

    // The history: its last row is this version, with this layout's fingerprint.
    let (_, _, history) = doc::region(&text, "history");
    let last = history
        .lines()
        .rfind(|l| l.starts_with("| ") && !l.starts_with("| version"))
        .map(doc::cells)
        .expect("a history row");
    let fp = format!("0x{:08x}", fingerprint(&types));
    let version = PROTOCOL_VERSION.to_string();
    assert_eq!(
        last[0], version,
        "PROTOCOL_VERSION is {version} and {DOC}'s history ends at {}: add a row for {version} \
         with its change and the layout fingerprint {fp}",
        last[0]
    );
    assert_eq!(
        last.last().map(String::as_str),
        Some(fp.as_str()),
        "the layout is not the one recorded for protocol {version}: a layout change needs a new \
         version (bump PROTOCOL_VERSION in core/src/wire.rs, add a history row with the \
         fingerprint {fp})"
    );

    // The bit tables are the constants of the sources, bit for bit and name for name.
    for (file, ty) in [
        ("core/src/wire.rs", "LinkStatus"),
        ("core/src/controller.rs", "StatusFlags"),
    ] {
        let src = source_bits(file, ty);
        let documented: Vec<(u32, String)> = doc_bits(&text, ty)
            .into_iter()
            .map(|(bit, name, mask)| {
                assert_eq!(mask, format!("0x{:04X}", 1u32 << bit), "{ty}.{name}'s mask");
                (bit, name)
            })
            .collect();
        assert_eq!(documented, src, "{ty}'s bits in {DOC} against {file}");
    }
    assert_eq!(
        source_bits("core/src/wire.rs", "LinkStatus")
            .iter()
            .map(|(b, _)| 1u8 << b)
            .collect::<Vec<_>>(),
        [
            ibvs_core::wire::LinkStatus::BOOT,
            ibvs_core::wire::LinkStatus::RETRANSMIT,
            ibvs_core::wire::LinkStatus::FREE_RUNNING,
            ibvs_core::wire::LinkStatus::INPUT_HELD,
            ibvs_core::wire::LinkStatus::STALE,
            ibvs_core::wire::LinkStatus::PANIC,
            ibvs_core::wire::LinkStatus::PREVIOUS_PANIC,
            ibvs_core::wire::LinkStatus::STORED_CONFIG,
        ],
        "the source's reading"
    );
}

/// Runs `scripts/wire.py --doc docs/interface.md ARGS` on `input`; its standard output.
fn python(args: &[&str], input: &[u8]) -> Vec<u8> {
    let root = workspace_root();
    let mut child = Command::new("python3")
        .arg(root.join(SCRIPT))
        .arg("--doc")
        .arg(root.join(DOC))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("python3 (the interface test needs it on PATH): {e}"));
    let mut stdin = child.stdin.take().expect("stdin");
    let data = input.to_vec();
    let writer = std::thread::spawn(move || stdin.write_all(&data));
    let out = child.wait_with_output().expect("python3 ran");
    writer
        .join()
        .expect("writer")
        .expect("python3 read its input");
    assert!(
        out.status.success(),
        "{SCRIPT} {args:?}: {}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

/// The frames the script decodes from `stream`, as JSON lines.
fn py_decode(stream: &[u8]) -> Vec<J> {
    String::from_utf8(python(&["decode"], stream))
        .expect("UTF-8")
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON line"))
        .collect()
}

/// The stream the script encodes from `messages` (`{"kind": "M", "body": ...}` each).
fn py_encode(messages: &[J]) -> Vec<u8> {
    let mut input = String::new();
    for m in messages {
        input += &m.to_string();
        input.push('\n');
    }
    python(&["encode"], input.as_bytes())
}

/// The kind letter of a frame kind.
fn letter(kind: FrameKind) -> String {
    (kind.byte() as char).to_string()
}

/// A frame of `kind` whose body is the postcard `body` of its type, decoded by the core
/// (whole, nothing left), its canonical form and its frame as the core encodes it.
fn through_the_types(kind: FrameKind, body: &[u8], reg: &Registry) -> (J, Vec<u8>) {
    use ibvs_core::wire::{ConfigReport, Downlink, Telemetry, Uplink};
    fn check<T: serde::Serialize + serde::de::DeserializeOwned>(
        root: &str,
        kind: FrameKind,
        body: &[u8],
        reg: &Registry,
    ) -> (J, Vec<u8>) {
        let (value, rest): (T, _) = postcard::take_from_bytes(body)
            .unwrap_or_else(|e| panic!("{root}: a body generated from the layout: {e}"));
        assert!(rest.is_empty(), "{root}: {} bytes left over", rest.len());
        let mut again = [0u8; 1024];
        let again = postcard::to_slice(&value, &mut again).expect("encodes");
        assert_eq!(
            again, body,
            "{root}: the types encode the layout's body back"
        );
        let mut out = [0u8; 1024];
        let frame = encode_message(kind, &value, &mut out)
            .expect("a frame")
            .to_vec();
        (canonical_of(root, &value, reg), frame)
    }
    match kind {
        FrameKind::Measurement => check::<Uplink>("Uplink", kind, body, reg),
        FrameKind::Command => check::<Downlink>("Downlink", kind, body, reg),
        FrameKind::ConfigWrite => check::<ControllerConfig>("ControllerConfig", kind, body, reg),
        FrameKind::ConfigReport => check::<ConfigReport>("ConfigReport", kind, body, reg),
        FrameKind::Telemetry => check::<Telemetry>("Telemetry", kind, body, reg),
        FrameKind::ConfigRead | FrameKind::TelemetryRequest => {
            let mut out = [0u8; 64];
            let frame = encode_message(kind, &(), &mut out)
                .expect("a frame")
                .to_vec();
            (J::Null, frame)
        }
    }
}

/// Bodies generated from the layout (the smallest, the largest and distinct values in every
/// field, every variant of every enum among them) decode with the types whole and encode back
/// the same (the layout is the types'); their frames are the size table's bounds; the script
/// decodes each with every field as the types read it, and encodes each byte for byte.
#[test]
fn the_script_reads_and_writes_every_layout_as_the_types_do() {
    let reg = layout::registry();
    let caps = layout::string_capacities();
    let mut stream = Vec::new();
    let mut expected = Vec::new();
    for (kind, _, body, _) in KINDS {
        let fills = [Fill::Smallest, Fill::Largest]
            .into_iter()
            .chain((0..24).map(Fill::Distinct));
        for fill in fills {
            let mut g = Generator::new(&reg, fill);
            if body != "()" {
                g.container(body);
            }
            let (value, frame) = through_the_types(kind, &g.out, &reg);
            let bounds = if body == "()" {
                (0, 0)
            } else {
                layout::container_size(body, &reg, &caps)
            };
            let w = wire_len((bounds.0 + 6, bounds.1 + 6));
            match fill {
                Fill::Smallest => {
                    assert_eq!(g.out.len(), bounds.0, "{body}'s smallest body");
                    assert!(frame.len() >= w.0, "{body}'s smallest frame");
                }
                Fill::Largest => {
                    assert_eq!(g.out.len(), bounds.1, "{body}'s largest body");
                    assert_eq!(frame.len(), w.1, "{body}'s largest frame");
                }
                Fill::Distinct(_) => assert!((bounds.0..=bounds.1).contains(&g.out.len())),
            }
            stream.extend_from_slice(&frame);
            expected.push(json!({"kind": letter(kind), "body": value}));
        }
    }
    // Idle zeros between frames are nothing.
    stream.extend_from_slice(&[0, 0]);
    let decoded = py_decode(&stream);
    assert_eq!(decoded.len(), expected.len());
    for (k, (got, want)) in decoded.iter().zip(&expected).enumerate() {
        assert_eq!(got, want, "frame {k}");
    }
    let encoded = py_encode(&expected);
    assert_eq!(
        encoded,
        stream[..stream.len() - 2],
        "the script's frames are the core's"
    );
}

/// COBS of `payload` and the terminating zero (payloads under 254 bytes: one block per zero).
fn cobs(payload: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8];
    let mut code_at = 0;
    for &b in payload {
        if b == 0 {
            out[code_at] = (out.len() - code_at) as u8;
            code_at = out.len();
            out.push(0);
        } else {
            out.push(b);
        }
    }
    out[code_at] = (out.len() - code_at) as u8;
    out.push(0);
    out
}

/// What the script says of bad frames: each rejected by name (as the core counts them), and
/// the next frame read.
#[test]
fn the_script_names_bad_frames_and_resynchronises() {
    let reg = layout::registry();
    let mut g = Generator::new(&reg, Fill::Distinct(3));
    g.container("Uplink");
    let (value, frame) = through_the_types(FrameKind::Measurement, &g.out, &reg);
    let framed = |version: u8, kind: u8, body: &[u8], crc_delta: u32| {
        let mut p = vec![version, kind];
        p.extend_from_slice(body);
        let crc = crc32c(&p) ^ crc_delta;
        p.extend_from_slice(&crc.to_le_bytes());
        cobs(&p)
    };
    let mut trailing = g.out.clone();
    trailing.push(7);
    let cases: [(&str, Vec<u8>); 7] = [
        ("crc", framed(PROTOCOL_VERSION, b'M', &g.out, 1)),
        (
            "version",
            framed(PROTOCOL_VERSION.wrapping_add(1), b'M', &g.out, 0),
        ),
        ("kind", framed(PROTOCOL_VERSION, b'X', &g.out, 0)),
        ("malformed", framed(PROTOCOL_VERSION, b'M', &trailing, 0)),
        (
            "malformed",
            framed(PROTOCOL_VERSION, b'M', &g.out[..g.out.len() - 1], 0),
        ),
        ("too_short", vec![0x03, 0x01, 0x02, 0x00]),
        ("cobs", vec![0x07, 0x33, 0x00]),
    ];
    let mut stream = Vec::new();
    for (_, bytes) in &cases {
        stream.extend_from_slice(bytes);
    }
    stream.extend_from_slice(&[0x42; ibvs_core::wire::MAX_FRAME_LEN + 60]);
    stream.push(0);
    stream.extend_from_slice(&frame);
    let got = py_decode(&stream);
    // The core's reading of the same stream, error for error.
    let mut d = FrameDecoder::new();
    let core: Vec<String> = stream
        .iter()
        .filter_map(|&b| d.feed(b).map(|r| r.and_then(|p| p.uplink().map(|_| ()))))
        .map(|r| match r {
            Ok(()) => "ok".to_string(),
            Err(e) => format!("{e:?}"),
        })
        .collect();
    assert_eq!(
        core,
        [
            "Crc",
            "VersionMismatch",
            "WrongKind",
            "Malformed",
            "Malformed",
            "TooShort",
            "Cobs",
            "Oversize",
            "ok"
        ]
    );
    assert_eq!(got.len(), cases.len() + 2, "{got:?}");
    for (k, (name, _)) in cases.iter().enumerate() {
        assert_eq!(got[k], json!({"error": name}), "case {k}");
    }
    assert_eq!(got[cases.len()], json!({"error": "oversize"}));
    assert_eq!(got[cases.len() + 1], json!({"kind": "M", "body": value}));
}

/// Splits a stream at its zeros into frames (each with its zero), idle zeros dropped.
fn frames_of(stream: &[u8]) -> Vec<Vec<u8>> {
    stream
        .split_inclusive(|&b| b == 0)
        .filter(|f| f.len() > 1)
        .map(<[u8]>::to_vec)
        .collect()
}

/// The canonical form of every frame of `stream` as the core decodes it: the peer's frames
/// (`peer`) or the flight computer's.
fn core_decode(stream: &[u8], peer: bool, reg: &Registry) -> Vec<J> {
    let mut d = FrameDecoder::new();
    let mut out = Vec::new();
    for &b in stream {
        let Some(r) = d.feed(b) else { continue };
        let p = r.expect("a good frame");
        let kind = letter(p.kind);
        let body = if peer {
            match p.peer_message().expect("a peer message") {
                PeerMessage::Measurement(m) => canonical_of("Uplink", &m, reg),
                PeerMessage::ConfigWrite(c) => canonical_of("ControllerConfig", &c, reg),
                PeerMessage::ConfigRead | PeerMessage::TelemetryRequest => J::Null,
            }
        } else {
            match p
                .flight_computer_message()
                .expect("a flight computer message")
            {
                FlightComputerMessage::Command(c) => canonical_of("Downlink", &c, reg),
                FlightComputerMessage::ConfigReport(r) => canonical_of("ConfigReport", &r, reg),
                FlightComputerMessage::Telemetry(t) => canonical_of("Telemetry", &t, reg),
            }
        };
        out.push(json!({"kind": kind, "body": body}));
    }
    out
}

/// The script reads every frame of a docking flown through processor in the loop, both
/// directions, each field equal to the in-process values; the frames it writes (the
/// configuration, the docking's first measurements, a read and a request) are accepted by the
/// firmware, which flies them exactly as it flew the core's.
#[test]
fn the_script_reads_a_pil_docking_and_the_firmware_flies_its_frames() {
    let reg = layout::registry();
    let scenario = Scenario::default();
    let cfg = ControllerConfig::default();
    let elf = host_sim::pil::firmware_elf().expect("firmware ELF");

    let mut pil = PilFlightComputer::spawn(&elf).expect("QEMU with the firmware");
    pil.refresh_telemetry().expect("telemetry");
    pil.configure(&cfg).expect("configured");
    let flown = run(&scenario, &mut pil).expect("PIL run");
    assert!(pil.last_error().is_none(), "{:?}", pil.last_error());
    pil.link_mut()
        .read_config(Duration::from_secs(10))
        .expect("a read answered");
    pil.refresh_telemetry().expect("telemetry");
    let sent = pil.link().sent_bytes().to_vec();
    let received = pil.link().received_bytes().to_vec();
    let history = pil.history().to_vec();
    let _ = pil.shutdown();
    eprintln!(
        "{} steps, {} bytes sent, {} received",
        flown.samples.len(),
        sent.len(),
        received.len()
    );

    // Both directions: the script's reading is the core's, field for field.
    for (stream, peer) in [(&sent, true), (&received, false)] {
        let want = core_decode(stream, peer, &reg);
        let got = py_decode(stream);
        assert_eq!(got.len(), want.len(), "frames (peer: {peer})");
        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
            assert_eq!(g, w, "frame {k} (peer: {peer})");
        }
        let kinds: std::collections::BTreeSet<String> = got
            .iter()
            .map(|f| f["kind"].as_str().expect("a kind").to_string())
            .collect();
        let all: &[&str] = if peer {
            &["M", "Q", "R", "W"]
        } else {
            &["C", "K", "T"]
        };
        assert_eq!(kinds.into_iter().collect::<Vec<_>>(), all);
    }
    // The command frames that answered the steps are the ones the simulation flew.
    let commands: Vec<J> = py_decode(&received)
        .into_iter()
        .filter(|f| f["kind"] == "C")
        .skip(1) // the boot frame
        .map(|f| f["body"].clone())
        .collect();
    assert_eq!(commands.len(), history.len());
    for (k, (c, d)) in commands.iter().zip(&history).enumerate() {
        assert_eq!(*c, canonical_of("Downlink", d, &reg), "step {k}");
    }

    // The script encodes: the configuration, the first measurements, a read, a request.
    let peer_frames = py_decode(&sent);
    let measurements: Vec<J> = peer_frames
        .iter()
        .filter(|f| f["kind"] == "M")
        .take(300)
        .cloned()
        .collect();
    let mut messages =
        vec![json!({"kind": "W", "body": canonical_of("ControllerConfig", &cfg, &reg)})];
    messages.extend(measurements.iter().cloned());
    messages.push(json!({"kind": "R", "body": null}));
    messages.push(json!({"kind": "Q", "body": null}));
    let written = frames_of(&py_encode(&messages));
    assert_eq!(written.len(), messages.len());
    let core_frames = frames_of(&sent);
    // Byte for byte the core's frames of the same messages (the run's first write and
    // measurements).
    assert_eq!(written[0], core_frames[1], "the configuration write");
    for (k, f) in written[1..=measurements.len()].iter().enumerate() {
        assert_eq!(*f, core_frames[2 + k], "measurement {k}");
    }

    // A fresh firmware takes them one at a time and answers each.
    let mut pil = PilFlightComputer::spawn(&elf).expect("QEMU with the firmware");
    let link = pil.link_mut();
    link.send_raw(&written[0]).expect("sent");
    let report = link
        .recv_report(Duration::from_secs(10))
        .expect("link")
        .expect("a report");
    assert_eq!(
        (report.status, report.config_id, report.config),
        (ibvs_core::wire::ConfigStatus::Applied, config_id(&cfg), cfg),
        "the firmware applied the script's configuration"
    );
    for (k, f) in written[1..=measurements.len()].iter().enumerate() {
        link.send_raw(f).expect("sent");
        let d = link
            .recv(Duration::from_secs(5))
            .expect("link")
            .unwrap_or_else(|| panic!("no answer to the script's measurement {k}"));
        assert_eq!(d.echo_seq, Some(k as u32 + 1), "measurement {k}");
        assert_eq!(
            d.output, history[k].output,
            "step {k} flown as the core's frame was"
        );
    }
    link.send_raw(&written[written.len() - 2]).expect("sent");
    let read = link
        .recv_report(Duration::from_secs(10))
        .expect("link")
        .expect("a read answered");
    assert_eq!(read.status, ibvs_core::wire::ConfigStatus::Active);
    link.send_raw(&written[written.len() - 1]).expect("sent");
    let t = loop {
        match link.recv_message(Duration::from_secs(5)).expect("link") {
            Some(FlightComputerMessage::Telemetry(t)) => break t,
            Some(_) => continue,
            None => panic!("no telemetry answered the script's request"),
        }
    };
    let n = measurements.len() as u32;
    assert_eq!(
        (t.link.frames_ok, t.link.rejected_frames(), t.counters.steps),
        (n, 0, n),
        "every frame of the script accepted"
    );
    let _ = pil.shutdown();
}

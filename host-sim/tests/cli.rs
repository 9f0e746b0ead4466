//! The command-line contract of `host-sim`: what `trim`, `gains` and `dock` print.

use std::process::Command;

use nalgebra::DMatrix;
use serde_json::Value;

fn host_sim(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .expect("run host-sim");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

fn json(args: &[&str]) -> Value {
    let (ok, stdout, stderr) = host_sim(args);
    assert!(ok, "host-sim {args:?} failed: {stderr}");
    serde_json::from_str(&stdout).unwrap_or_else(|e| panic!("not JSON ({e}): {stdout}"))
}

fn matrix(v: &Value) -> DMatrix<f64> {
    let rows: Vec<Vec<f64>> = serde_json::from_value(v.clone()).expect("nested array of numbers");
    DMatrix::from_fn(rows.len(), rows[0].len(), |r, c| rows[r][c])
}

#[test]
fn trim_json_has_the_documented_fields_and_a_tiny_residual() {
    let v = json(&[
        "trim",
        "--speed-mps",
        "120",
        "--altitude-m",
        "3000",
        "--json",
    ]);
    for key in [
        "alpha_rad",
        "theta_rad",
        "throttle",
        "elevator_deg",
        "aileron_deg",
        "rudder_deg",
        "residual",
    ] {
        assert!(v[key].is_number(), "missing {key}: {v}");
    }
    assert!(v["residual"].as_f64().unwrap() < 1e-6);
    let alpha = v["alpha_rad"].as_f64().unwrap();
    assert!((0.09..0.13).contains(&alpha), "alpha {alpha}");
    assert_eq!(v["alpha_rad"], v["theta_rad"], "level flight");
    // A forward cg needs more nose-up elevator (more negative).
    let forward = json(&["trim", "--xcg", "0.30", "--json"]);
    assert!(forward["elevator_deg"].as_f64().unwrap() < v["elevator_deg"].as_f64().unwrap());
    // A heavier receiver flies level at a larger angle of attack and more throttle; a mass
    // factor outside the plant's limits is refused.
    let heavy = json(&["trim", "--mass-factor", "1.25", "--json"]);
    let base = json(&["trim", "--json"]);
    for key in ["alpha_rad", "throttle"] {
        assert!(
            heavy[key].as_f64().unwrap() > base[key].as_f64().unwrap() + 1e-3,
            "{key}"
        );
    }
    let (ok, _, stderr) = host_sim(&["trim", "--mass-factor", "3"]);
    assert!(!ok && stderr.contains("--mass-factor"), "{stderr}");
}

#[test]
fn gains_json_closes_stable_loops_with_the_reported_riccati_solution() {
    let v = json(&["gains", "--json"]);
    for ch in ["lon", "lat"] {
        let d = &v[ch];
        let (a, b, q, r, k, p) = (
            matrix(&d["A"]),
            matrix(&d["B"]),
            matrix(&d["Q"]),
            matrix(&d["R"]),
            matrix(&d["K"]),
            matrix(&d["P"]),
        );
        assert_eq!(d["ts"].as_f64(), Some(0.02));
        assert_eq!(
            (a.nrows(), b.nrows(), k.ncols(), k.nrows()),
            (a.ncols(), a.nrows(), a.nrows(), b.ncols())
        );
        // K is the optimal gain for (A, B, Q, R, P) and P solves the Riccati equation.
        let s = &r + b.transpose() * &p * &b;
        let k_check = s.clone().try_inverse().unwrap() * b.transpose() * &p * &a;
        assert!(
            (&k - k_check).norm() < 1e-9 * k.norm(),
            "{ch}: K is not the LQR gain of P"
        );
        let res = a.transpose() * &p * &a - &p - a.transpose() * &p * &b * &k + &q;
        assert!(
            res.norm() < 1e-9 * p.norm(),
            "{ch}: Riccati residual {}",
            res.norm() / p.norm()
        );
        let radius = (&a - &b * &k)
            .complex_eigenvalues()
            .iter()
            .map(|e| e.norm())
            .fold(0.0, f64::max);
        assert!(radius < 1.0, "{ch}: closed-loop spectral radius {radius}");
    }
}

#[test]
fn dock_json_reports_a_docking_from_the_paper_start() {
    let v = json(&["dock", "--json", "--no-files"]);
    assert_eq!(v["outcome"], "docked", "{v}");
    assert_eq!(v["docked"], true);
    let miss = v["miss_m"].as_f64().unwrap();
    let closure = v["closure_mps"].as_f64().unwrap();
    assert!(miss < 0.1, "{v}");
    assert!((0.5..=2.6).contains(&closure), "{v}");
    assert!(v["time_s"].as_f64().unwrap() > 1.0);
}

#[test]
fn dock_writes_its_files_and_pbvs_is_selectable() {
    let dir = std::env::temp_dir().join(format!("host-sim-cli-{}", std::process::id()));
    let (ok, stdout, stderr) = host_sim(&[
        "dock",
        "--scenario",
        "paper-level1",
        "--controller",
        "pbvs",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert!(stdout.starts_with("Docked"), "{stdout}");
    let csv = std::fs::read_to_string(dir.join("run.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    for col in [
        "time_s",
        "mode",
        "image_x",
        "depth_m",
        "drogue_from_tip_right_m",
        "cmd_throttle",
        "v_des_fwd_mps",
    ] {
        assert!(
            header.split(',').any(|c| c == col),
            "missing column {col}: {header}"
        );
    }
    assert!(csv.lines().count() > 100);
    assert!(
        std::fs::read(dir.join("dock.png"))
            .unwrap()
            .starts_with(b"\x89PNG")
    );
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["outcome"], "docked");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bad_arguments_are_named_errors() {
    let (ok, _, stderr) = host_sim(&["dock", "--start", "1,2", "--no-files"]);
    assert!(!ok);
    assert!(stderr.contains("--start takes three values"), "{stderr}");
    let (ok, _, stderr) = host_sim(&["trim", "--speed-mps=-5"]);
    assert!(!ok);
    assert!(
        stderr.contains("--speed-mps = -5 must be finite and positive"),
        "{stderr}"
    );
    let (ok, _, stderr) = host_sim(&["dock", "--ibvs-gains", "0,2,0.3,3,1", "--no-files"]);
    assert!(!ok);
    assert!(
        stderr.contains("controller.ibvs.k1_mps is NotPositive"),
        "{stderr}"
    );
    let (ok, _, stderr) = host_sim(&["dock", "--controller", "lqr", "--no-files"]);
    assert!(!ok);
    assert!(
        stderr.contains("lqr") && stderr.contains("ibvs or pbvs"),
        "{stderr}"
    );
}

#[test]
fn the_configuration_schema_and_a_scenarios_configuration_are_printed() {
    // The schema: every setting with its unit, default and rules, as JSON.
    let v = json(&["config", "schema", "--json"]);
    let settings = v["settings"].as_array().expect("settings");
    let k1 = settings
        .iter()
        .find(|s| s["key"] == "ibvs.k1_mps")
        .expect("ibvs.k1_mps");
    assert_eq!(k1["unit"], "m/s");
    assert_eq!(k1["default"], "1.0");
    assert_eq!(k1["rules"][0], "finite, > 0");
    let late = settings
        .iter()
        .find(|s| s["key"] == "refuelling.late_gate_final_radius_m")
        .expect("late gate");
    assert_eq!(
        late["rules"][1],
        "refuelling.late_gate_final_radius_m <= refuelling.late_gate_radius_m"
    );
    // What a scenario flies, every key: Table 2 under the bow wave, the camera at the tip.
    let (ok, text, stderr) = host_sim(&["config", "show", "--scenario", "paper-bow-wave"]);
    assert!(ok, "{stderr}");
    let t: toml::Table = text.parse().expect("TOML");
    let c = &t["controller"];
    assert_eq!(c["procedure"].as_str(), Some("paper"));
    assert_eq!(c["ibvs"]["k1_mps"].as_float(), Some(3.0));
    assert_eq!(c["nav_latency_steps"].as_integer(), Some(0));
    let shown = json(&["config", "show", "--scenario", "calm", "--json"]);
    assert_eq!(shown["procedure"], "refuelling");
    assert_eq!(shown["nav_latency_steps"], 1);
}

#[test]
fn scenarios_are_listed_shown_and_loaded_from_files() {
    let (ok, list, _) = host_sim(&["scenarios"]);
    assert!(ok);
    for name in [
        "calm",
        "paper-level1",
        "paper-level2",
        "paper-bow-wave",
        "paper-mount-error-ibvs",
        "paper-mount-error-pbvs",
    ] {
        assert!(
            list.lines().any(|l| l.starts_with(name)),
            "{name} missing:\n{list}"
        );
    }
    let (ok, toml_text, stderr) = host_sim(&["scenario", "show", "paper-bow-wave"]);
    assert!(ok, "{stderr}");
    assert!(
        toml_text.contains("[bow_wave]") && toml_text.contains("enabled = true"),
        "{toml_text}"
    );
    // What `scenario show` prints is a scenario file: fly it, with one value edited.
    let dir = std::env::temp_dir().join(format!("host-sim-scenario-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("mine.toml");
    std::fs::write(&file, toml_text.replace("seed = 1", "seed = 4")).unwrap();
    let v = json(&[
        "dock",
        "--scenario",
        file.to_str().unwrap(),
        "--json",
        "--no-files",
    ]);
    assert!(v["outcome"].is_string(), "{v}");
    let typo = dir.join("typo.toml");
    std::fs::write(&typo, "[camera]\npixel_noise = 1.0\n").unwrap();
    let (ok, _, stderr) = host_sim(&["dock", "--scenario", typo.to_str().unwrap(), "--no-files"]);
    assert!(!ok);
    assert!(stderr.contains("pixel_noise"), "{stderr}");
    let (ok, _, stderr) = host_sim(&["dock", "--scenario", "no-such-preset", "--no-files"]);
    assert!(!ok);
    assert!(
        stderr.contains("paper-level1"),
        "the error lists the presets: {stderr}"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn paper_writes_figures_data_and_the_summary_table() {
    let dir = std::env::temp_dir().join(format!("host-sim-paper-{}", std::process::id()));
    let (ok, table, stderr) = host_sim(&["paper", "--out", dir.to_str().unwrap(), "--seeds", "1"]);
    assert!(ok, "{stderr}");
    assert_eq!(
        table
            .lines()
            .filter(|l| l.starts_with("| ") && !l.starts_with("| experiment"))
            .count(),
        5,
        "{table}"
    );
    for (exp, preset) in [
        ("level1", "paper-level1"),
        ("level2", "paper-level2"),
        ("bow-wave", "paper-bow-wave"),
        ("mount-error", "paper-mount-error-pbvs"),
    ] {
        for f in [
            "image_error.png",
            "paths.png",
            &format!("{preset}-seed1.csv"),
        ] {
            let path = dir.join(exp).join(f);
            assert!(path.exists(), "{} missing", path.display());
        }
    }
    assert_eq!(
        std::fs::read_to_string(dir.join("summary.md")).unwrap(),
        table
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn dock_pil_reports_the_step_cost_on_the_mcu_and_flies_a_presets_own_configuration() {
    let v = json(&["dock", "--pil", "--json", "--no-files"]);
    assert_eq!(v["outcome"], "docked", "{v}");
    let cost = &v["step_instructions"];
    let (min, median, max) = (
        cost["min"].as_u64().unwrap(),
        cost["median"].as_u64().unwrap(),
        cost["max"].as_u64().unwrap(),
    );
    assert!(0 < min && min <= median && median <= max, "{cost}");
    assert_eq!(v["link"]["host"]["failed_steps"], 0, "{v}");
    // The paper's procedure with Table 2's gains: sent over the link, flown as in-process.
    let args = [
        "dock",
        "--scenario",
        "paper-bow-wave",
        "--json",
        "--no-files",
    ];
    let pil = json(&[&args[..], &["--pil"]].concat());
    let local = json(&args);
    for key in [
        "outcome",
        "attempts",
        "miss_m",
        "closure_mps",
        "time_s",
        "breakaway_reason",
    ] {
        assert_eq!(pil[key], local[key], "{key}: {pil} vs {local}");
    }
    assert_eq!(pil["link"]["firmware"]["config_applied"], 1, "{pil}");
}

/// PIL flies the ELF it is given and builds nothing: a missing one is refused with the
/// command that builds it.
#[test]
fn cli_pil_without_the_firmware_elf_names_the_build_command() {
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["dock", "--pil", "--no-files"])
        .env("IBVS_FIRMWARE_ELF", "/nonexistent/firmware")
        .output()
        .expect("run host-sim");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("/nonexistent/firmware")
            && stderr.contains("--no-default-features --features qemu --target-dir target/qemu"),
        "{stderr}"
    );
}

/// A scratch directory of its own for a test.
fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("host-sim-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    dir
}

/// Runs host-sim, which must fail; its stderr.
fn refused(args: &[&str]) -> String {
    let (ok, stdout, stderr) = host_sim(args);
    assert!(!ok, "host-sim {args:?} succeeded: {stdout}");
    stderr
}

/// Counts, times and the number of threads are bounded, each refused by its option's name
/// with the range it takes.
#[test]
fn counts_times_and_jobs_out_of_range_are_refused_by_name() {
    let e = refused(&["montecarlo", "--scenario", "calm", "--runs", "0"]);
    assert!(e.contains("--runs") && e.contains("0 is not in 1.."), "{e}");
    let e = refused(&[
        "paper",
        "--seeds",
        "0",
        "--out",
        "/nonexistent/never-written",
    ]);
    assert!(
        e.contains("--seeds") && e.contains("0 is not in 1..=10000"),
        "{e}"
    );
    for jobs in ["0", "100000"] {
        let e = refused(&[
            "montecarlo",
            "--scenario",
            "calm",
            "--runs",
            "1",
            "--jobs",
            jobs,
        ]);
        assert!(
            e.contains("--jobs") && e.contains("is not in 1..=256"),
            "{jobs}: {e}"
        );
    }
    let e = refused(&[
        "montecarlo",
        "--scenario",
        "calm",
        "--runs",
        "1",
        "--shards",
        "0",
    ]);
    assert!(e.contains("--shards"), "{e}");
    for t in ["nan", "-5", "inf"] {
        let e = refused(&[
            "dock",
            "--animate",
            &format!("--still-s={t}"),
            "--out",
            "/nonexistent/x",
        ]);
        assert!(
            e.contains("--still-s") && e.contains("finite, at least 0"),
            "{t}: {e}"
        );
    }
}

/// trim takes a flight condition inside the models' range, named as the option is written.
#[test]
fn trim_outside_the_models_range_is_refused_by_name() {
    let e = refused(&["trim", "--altitude-m=-5"]);
    assert!(
        e.contains("--altitude-m = -5 must be finite and positive"),
        "{e}"
    );
    let e = refused(&["trim", "--altitude-m=100"]);
    assert!(
        e.contains("--altitude-m = 100 m is out of range: allowed"),
        "{e}"
    );
    let e = refused(&["trim", "--speed-mps=400"]);
    assert!(e.contains("--speed-mps") && e.contains("Mach"), "{e}");
}

/// A law the chosen procedure does not fly is an error, not ignored; the start is checked
/// against its own range, named by the option.
#[test]
fn dock_options_that_would_be_ignored_or_out_of_range_are_named() {
    let e = refused(&["dock", "--controller", "pbvs", "--no-files"]);
    assert!(
        e.contains("--controller pbvs")
            && e.contains("paper's procedure only")
            && e.contains("refuelling procedure"),
        "{e}"
    );
    let e = refused(&["dock", "--start", "100,0,0", "--no-files"]);
    assert!(
        e.contains("--start: initial.drogue_minus_probe_m[0] (forward) = 100 is out of range: allowed 1.5..=30"),
        "{e}"
    );
    let e = refused(&["dock", "--start", "8,45,0", "--no-files"]);
    assert!(
        e.contains("--start") && e.contains("[1] (right) = 45") && e.contains("-30..=30"),
        "{e}"
    );
}

/// Scenario files: read with a size limit; every error names the file, the line of the key
/// as written and the allowed range; an old form gets the current one; long input is not
/// echoed whole.
#[test]
fn scenario_file_errors_name_the_file_the_line_the_key_and_the_range() {
    let e = refused(&["dock", "--scenario", "/dev/zero", "--no-files"]);
    assert!(e.contains("/dev/zero is larger than 1048576 bytes"), "{e}");

    let dir = scratch("bad-scenarios");
    let file = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).expect("written");
        p.to_str().expect("UTF-8").to_string()
    };
    let cases = [
        (
            "range.toml",
            "name = \"r\"\n[camera]\npixel_noise_px = 50.0\n",
            ":3: camera.pixel_noise_px = 50 is out of range: allowed 0..=20",
        ),
        (
            "latency.toml",
            "[navigation.ins]\nlatency_steps = 5\n",
            ":2: navigation.ins.latency_steps = 5 is out of range: allowed 0..=4",
        ),
        (
            "old.toml",
            "name = \"old\"\ncontroller = \"ibvs\"\n",
            ":2: controller = \"ibvs\" is the form before the controller's settings became one table: write a [controller] table: [controller] with law = \"ibvs\"",
        ),
        (
            "unknown.toml",
            "[controller]\nprocedure = \"paper\"\n\n[controller.ibvs]\nk9_mps = 1.0\n",
            ":5: controller.ibvs.k9_mps is not a controller setting",
        ),
        (
            "type.toml",
            "[controller.ibvs]\nk1_mps = \"fast\"\n",
            ":2: controller.ibvs.k1_mps: invalid type: string \"fast\"",
        ),
        (
            "rule.toml",
            "[controller]\n\n[controller.ibvs]\nk2_mps = -1.0\n",
            ":4: controller.ibvs.k2_mps is NotPositive",
        ),
        (
            "start.toml",
            "[initial]\ndrogue_minus_probe_m = [100.0, 0.0, 0.0]\n",
            ":2: initial.drogue_minus_probe_m[0] (forward) = 100 is out of range: allowed 1.5..=30",
        ),
    ];
    for (name, text, want) in cases {
        let path = file(name, text);
        let e = refused(&["dock", "--scenario", &path, "--no-files"]);
        assert!(e.contains(&format!("{path}{want}")), "{name}: {e}");
    }
    // A long garbage line: the message quotes a bounded part of it.
    let long = file(
        "long.toml",
        &format!("x = {}\n", "#".repeat(0) + &"y".repeat(500_000)),
    );
    let e = refused(&["dock", "--scenario", &long, "--no-files"]);
    assert!(e.len() < 2_000, "{} bytes of stderr", e.len());
    assert!(
        e.contains(&long) && e.contains("more bytes not shown"),
        "{e}"
    );
    let binary = dir.join("binary.toml");
    std::fs::write(&binary, [0xffu8, 0xfe, 0x00, 0x41]).expect("written");
    let e = refused(&["dock", "--scenario", binary.to_str().unwrap(), "--no-files"]);
    assert!(e.contains("not UTF-8 text"), "{e}");
    std::fs::remove_dir_all(dir).ok();
}

/// A shard given twice to merge is named.
#[test]
fn merging_a_shard_twice_is_refused() {
    let dir = scratch("merge-twice");
    let m1 = dir.join("m1");
    std::fs::create_dir_all(&m1).expect("a directory");
    let m1 = m1.to_str().unwrap();
    let also = format!("{m1}/../m1");
    let e = refused(&[
        "montecarlo",
        "merge",
        m1,
        &also,
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    assert!(e.contains("is given twice") && e.contains(m1), "{e}");
    std::fs::remove_dir_all(dir).ok();
}

/// The firmware file for processor in the loop is checked before QEMU starts: a file that
/// is not an ELF, an ELF for another machine, and another board's build, each named.
#[test]
fn a_firmware_file_that_is_not_the_qemu_boards_is_refused_before_qemu_starts() {
    let dir = scratch("not-firmware");
    let text = dir.join("notes.txt");
    std::fs::write(&text, "not firmware\n").expect("written");
    let e = refused(&[
        "dock",
        "--pil",
        "--firmware",
        text.to_str().unwrap(),
        "--no-files",
    ]);
    assert!(
        e.contains("is not the qemu board's firmware: not an ELF file")
            && e.contains("--features qemu"),
        "{e}"
    );
    let host = env!("CARGO_BIN_EXE_host-sim");
    let e = refused(&["dock", "--pil", "--firmware", host, "--no-files"]);
    assert!(e.contains("not for a 32-bit little-endian ARM core"), "{e}");
    // The f405 board's build (the test command builds it; else an ARM ELF without the
    // qemu board's mark stands in for it).
    let f405 = std::env::var("IBVS_FIRMWARE_F405_ELF").unwrap_or_else(|_| {
        let mut arm = vec![0x7f, b'E', b'L', b'F', 1, 1, 1];
        arm.resize(18, 0);
        arm.extend_from_slice(&40u16.to_le_bytes());
        arm.resize(4096, 0);
        let p = dir.join("f405-like.elf");
        std::fs::write(&p, arm).expect("written");
        p.to_str().unwrap().to_string()
    });
    let e = refused(&[
        "montecarlo",
        "--scenario",
        "calm",
        "--runs",
        "1",
        "--pil",
        "--firmware",
        &f405,
        "--out",
        dir.join("mc").to_str().unwrap(),
    ]);
    assert!(
        e.contains("not the qemu board's build (the f405 board's?"),
        "{e}"
    );
    assert!(!dir.join("mc").exists(), "nothing flown");
    std::fs::remove_dir_all(dir).ok();
}

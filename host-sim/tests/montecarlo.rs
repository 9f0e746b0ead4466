//! Monte Carlo campaigns: determinism per run index, shards merging into exactly the
//! one-machine output, the summary's numbers, the command line. Campaigns here are small (CI);
//! the held-out campaigns of 1,000 and 10,000 runs are measured by hand (`docs/scenarios.md`,
//! "Measured campaigns").

use std::path::{Path, PathBuf};
use std::process::Command;

use host_sim::montecarlo::{
    self, CampaignMeta, CampaignSummary, RunOutcome, RunRecord, Shard, indices, run_campaign,
    write_campaign,
};
use host_sim::referee::{CrossingVerdict, HazardKind};
use host_sim::scenario::ScenarioFile;
use host_sim::sim::{self, Outcome};
use ibvs_core::Controller;

const FILES: [&str; 7] = [
    "runs.jsonl",
    "campaign.json",
    "summary.json",
    "miss_scatter.png",
    "hazards.png",
    "success_vs_turbulence.png",
    "success_vs_condition.png",
];

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("host-sim-mc-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&d).ok();
    d
}

fn campaign(f: &ScenarioFile, runs: u64, shard: Option<Shard>, jobs: usize, dir: &Path) {
    campaign_from(f, 0, runs, shard, jobs, dir);
}

/// The campaign of runs `first..first + runs` (`shard` of it) written to `dir`.
fn campaign_from(
    f: &ScenarioFile,
    first: u64,
    runs: u64,
    shard: Option<Shard>,
    jobs: usize,
    dir: &Path,
) {
    let lines = run_campaign(f, &indices(first, runs, shard), Some(jobs)).expect("campaign runs");
    let meta = CampaignMeta::new(f, runs, shard).from_run(first);
    write_campaign(dir, &meta, &lines).expect("written");
}

fn records(dir: &Path) -> Vec<RunRecord> {
    std::fs::read_to_string(dir.join("runs.jsonl"))
        .expect("runs.jsonl")
        .lines()
        .map(|l| serde_json::from_str(l).expect("a record per line"))
        .collect()
}

fn summary(dir: &Path) -> CampaignSummary {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).expect("summary"))
        .expect("summary parses")
}

#[test]
fn shards_merge_into_exactly_the_one_machine_campaign() {
    let f = ScenarioFile::load("paper-bow-wave").expect("preset");
    let runs = 9;
    let whole = temp("whole");
    campaign(&f, runs, None, 2, &whole);
    let shards: Vec<PathBuf> = (1..=3)
        .map(|k| {
            let d = temp(&format!("shard{k}"));
            campaign(&f, runs, Some(Shard { k, m: 3 }), 1, &d);
            d
        })
        .collect();
    // Shards merged in any order, one of them given twice.
    let merged = temp("merged");
    let order = [
        shards[2].clone(),
        shards[0].clone(),
        shards[1].clone(),
        shards[0].clone(),
    ];
    montecarlo::merge(&order, &merged).expect("merges");
    for file in FILES {
        let (a, b) = (
            std::fs::read(whole.join(file)).expect("whole"),
            std::fs::read(merged.join(file)).expect("merged"),
        );
        assert!(
            a == b,
            "{file} differs between one machine and the merged shards"
        );
    }
    // The per-cell table of the flight condition is the one machine's, and holds every run.
    let (one, all) = (summary(&whole), summary(&merged));
    assert_eq!(one.success_by_condition, all.success_by_condition);
    assert_eq!(
        all.success_by_condition.iter().map(|c| c.runs).sum::<u64>() + all.outside_condition_grid,
        runs
    );
    // A run is a function of the scenario and its index: the records match single runs.
    let recs = records(&whole);
    assert_eq!(
        recs.iter().map(|r| r.index).collect::<Vec<_>>(),
        (0..runs).collect::<Vec<_>>()
    );
    for r in [&recs[0], &recs[7]] {
        let file = f.dispersed(r.index);
        let run = sim::run(
            &file.scenario(),
            &mut Controller::new(file.controller_config()).expect("config"),
        )
        .expect("runs");
        assert_eq!(r.seed, file.seed);
        assert_eq!(r.miss_m, run.summary.miss_m);
        assert_eq!(r.docked, run.verdict.docked());
        assert_eq!(r.docked, run.summary.outcome == Outcome::Docked);
        assert_eq!(r.hazards, run.verdict.hazards);
    }
    // Incomplete or foreign shards are refused, naming the problem.
    let e = montecarlo::merge(&shards[..2], &temp("partial"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("3 of 9 runs missing"), "{e}");
    let other = temp("other");
    campaign(
        &ScenarioFile::load("calm").expect("preset"),
        1,
        None,
        1,
        &other,
    );
    let e = montecarlo::merge(&[whole.clone(), other.clone()], &temp("mixed"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("another campaign") && e.contains("scenario"),
        "{e}"
    );
    for d in shards.iter().chain([&whole, &merged, &other]) {
        std::fs::remove_dir_all(d).ok();
    }
}

#[test]
fn the_summary_counts_every_run_once_and_states_its_intervals() {
    let dir = temp("summary");
    let f = ScenarioFile::load("paper-level2").expect("preset");
    campaign(&f, 8, None, 2, &dir);
    let (s, recs) = (summary(&dir), records(&dir));
    assert_eq!((s.runs, s.campaign_runs, s.shard.as_deref()), (8, 8, None));
    let count = |f: &dyn Fn(&RunRecord) -> bool| recs.iter().filter(|r| f(r)).count() as u64;
    assert_eq!(s.docked, count(&|r| r.docked));
    assert_eq!(s.success, count(&|r| r.docked && r.hazards.is_empty()));
    assert_eq!(s.unsafe_runs, count(&|r| !r.hazards.is_empty()));
    assert_eq!(s.outcomes.values().sum::<u64>(), 8);
    assert_eq!(s.failure_causes.values().sum::<u64>(), 8 - s.docked);
    assert!(s.success_ci95.lower <= s.success_rate && s.success_rate <= s.success_ci95.upper);
    assert_eq!(
        s.success_ci95,
        montecarlo::wilson(s.success, s.runs),
        "Wilson 95 %"
    );
    assert_eq!(s.docked_ci95, montecarlo::wilson(s.docked, s.runs));
    assert_eq!(s.unsafe_upper95, montecarlo::upper95(s.unsafe_runs, s.runs));
    // Every hazard kind is listed, and the counts are the records'.
    assert_eq!(s.hazards.len(), HazardKind::ALL.len());
    for k in HazardKind::ALL {
        let h = s.hazards[k.name()];
        assert_eq!(h.runs, count(&|r| r.hazards.iter().any(|x| x.kind == k)));
        assert_eq!(h.runs_upper95, montecarlo::upper95(h.runs, s.runs));
    }
    // Every crossing is counted once, under its verdict.
    let crossings: u64 = recs.iter().map(|r| r.crossings.len() as u64).sum();
    assert_eq!(s.crossings.values().sum::<u64>(), crossings);
    let m = s.miss_m.expect("some runs reach the plane");
    assert!(m.min <= m.p5 && m.p5 <= m.p50 && m.p50 <= m.p95 && m.p95 <= m.p99 && m.p99 <= m.max);
    assert_eq!(m.count, recs.iter().filter(|r| r.miss_m.is_some()).count());
    for r in &recs {
        assert_eq!(r.docked, r.outcome == RunOutcome::Docked);
        assert_eq!(r.failure.is_none(), r.docked);
        assert_eq!(r.success, r.docked && r.safe);
        assert_eq!(r.safe, r.hazards.is_empty());
        for c in &r.crossings {
            assert!(
                (c.offset_m[0].hypot(c.offset_m[1]) - c.miss_m).abs() < 1e-9,
                "the offset's length is the miss: {c:?}"
            );
        }
        // The docking is the one crossing judged docked, and the last crossing.
        let docked: Vec<_> = r
            .crossings
            .iter()
            .filter(|c| c.verdict == CrossingVerdict::Docked)
            .collect();
        assert_eq!(docked.len(), usize::from(r.docked), "{r:?}");
        if r.docked {
            assert_eq!(
                r.crossings.last().map(|c| c.verdict),
                Some(CrossingVerdict::Docked)
            );
        }
    }
    let bins = &s.success_by_turbulence;
    assert_eq!(bins.iter().map(|b| b.runs).sum::<u64>(), 8);
    assert_eq!(
        (bins[0].sigma_lo_mps, bins[bins.len() - 1].sigma_hi_mps),
        (0.56, 0.84)
    );
    for png in [
        "miss_scatter.png",
        "hazards.png",
        "success_vs_turbulence.png",
    ] {
        let bytes = std::fs::read(dir.join(png)).expect("plot written");
        assert_eq!(&bytes[1..4], b"PNG", "{png}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A campaign from another first run flies other runs (its own seeds and dispersions), and its
/// shards still merge into exactly the one-machine output; a shard of the same scenario and
/// size from another first run is refused.
#[test]
fn a_first_run_offset_flies_other_runs_and_its_shards_merge_exactly() {
    let f = ScenarioFile::load("paper-level1").expect("preset");
    let (first, runs) = (1_000_000, 4);
    let root = temp("offset");
    let (zero, whole) = (root.join("zero"), root.join("whole"));
    campaign_from(&f, 0, runs, None, 2, &zero);
    campaign_from(&f, first, runs, None, 2, &whole);
    let (a, b) = (records(&zero), records(&whole));
    assert_eq!(
        b.iter().map(|r| r.index).collect::<Vec<_>>(),
        (first..first + runs).collect::<Vec<_>>()
    );
    for (x, y) in a.iter().zip(&b) {
        assert_ne!(x.seed, y.seed, "run {} and run {}", x.index, y.index);
        assert_ne!(x.inputs, y.inputs);
    }
    assert_eq!(summary(&whole).first_run, first);
    let shards: Vec<PathBuf> = (1..=2)
        .map(|k| {
            let d = root.join(format!("shard{k}"));
            campaign_from(&f, first, runs, Some(Shard { k, m: 2 }), 1, &d);
            d
        })
        .collect();
    let merged = root.join("merged");
    montecarlo::merge(&shards, &merged).expect("merges");
    for file in FILES {
        assert!(
            std::fs::read(whole.join(file)).expect("whole")
                == std::fs::read(merged.join(file)).expect("merged"),
            "{file} differs"
        );
    }
    let e = montecarlo::merge(&[shards[0].clone(), zero.clone()], &root.join("mixed"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("first run"), "{e}");
    std::fs::remove_dir_all(&root).ok();
}

/// The summary counts the referee's hazards: a hazard added to one docked record makes that
/// run unsafe and not a success, and is counted under its kind.
#[test]
fn the_summary_counts_a_hazard_and_the_run_stops_being_a_success() {
    let f = ScenarioFile::load("paper-level1").expect("preset");
    let dir = temp("hazard");
    campaign(&f, 3, None, 2, &dir);
    let mut recs = records(&dir);
    let before = summary(&dir);
    let k = recs
        .iter()
        .position(|r| r.success)
        .expect("a successful run");
    recs[k].hazards.push(host_sim::referee::Hazard {
        kind: HazardKind::HoseContact,
        time_s: 1.0,
        position_tanker_m: [-12.0, 0.5, 4.0],
        speed_mps: 1.0,
        measure: 0.05,
        limit: 0.1,
        what: "hose 0.050 m from the probe".into(),
    });
    recs[k].safe = false;
    recs[k].success = false;
    let meta = CampaignMeta::new(&f, 3, None);
    let after = montecarlo::summarise(&meta, &f.dispersion, &recs);
    assert_eq!(after.unsafe_runs, before.unsafe_runs + 1);
    assert_eq!(after.success, before.success - 1);
    assert_eq!(after.docked, before.docked, "still docked");
    assert_eq!(
        after.hazards["hose_contact"].runs,
        before.hazards["hose_contact"].runs + 1
    );
    assert!(after.unsafe_upper95 > before.unsafe_upper95);
    std::fs::remove_dir_all(&dir).ok();
}

/// The cell rule at the grid's nodes, on its lines, inside and outside, with the edges taken
/// from the core's generated grid.
#[test]
fn a_condition_on_a_grid_line_is_in_the_cell_below_it() {
    use ibvs_core::gains::{SCHEDULE_ALTITUDES_M, SCHEDULE_SPEEDS_MPS};
    let v: Vec<f64> = SCHEDULE_SPEEDS_MPS.iter().map(|&x| f64::from(x)).collect();
    let h: Vec<f64> = SCHEDULE_ALTITUDES_M.iter().map(|&x| f64::from(x)).collect();
    assert_eq!(montecarlo::condition_grid(), (v.clone(), h.clone()));
    let (nv, nh) = (v.len() - 1, h.len() - 1);
    let mid = |a: &[f64], k: usize| 0.5 * (a[k] + a[k + 1]);
    let cell = montecarlo::condition_cell;
    // An inner node belongs to the cell whose upper corner it is.
    assert_eq!(cell(v[1], h[1]), Some((0, 0)));
    assert_eq!(cell(v[2], h[2]), Some((1, 1)));
    // Just above it in speed, in altitude, in both: the next cells.
    let up = |x: f64| x + 1e-9 * x.abs().max(1.0);
    assert_eq!(cell(up(v[1]), h[1]), Some((1, 0)));
    assert_eq!(cell(v[1], up(h[1])), Some((0, 1)));
    assert_eq!(cell(up(v[1]), up(h[1])), Some((1, 1)));
    // On an inner speed line, an inner altitude line: the lower cell on that axis only.
    assert_eq!(cell(v[1], mid(&h, 1)), Some((0, 1)));
    assert_eq!(cell(mid(&v, 2), h[1]), Some((2, 0)));
    // Inside a cell; the grid's outer corners and edges are inside.
    assert_eq!(cell(mid(&v, 1), mid(&h, 2)), Some((1, 2)));
    assert_eq!(cell(v[0], h[0]), Some((0, 0)));
    assert_eq!(cell(v[nv], h[nh]), Some((nv - 1, nh - 1)));
    assert_eq!(cell(v[0], mid(&h, 1)), Some((0, 1)));
    // Outside, on either side of either axis, and not finite: no cell.
    let down = |x: f64| x - 1e-9 * x.abs().max(1.0);
    for (s, a) in [
        (down(v[0]), mid(&h, 0)),
        (up(v[nv]), mid(&h, 0)),
        (mid(&v, 0), down(h[0])),
        (mid(&v, 0), up(h[nh])),
        (f64::NAN, h[1]),
        (v[1], f64::INFINITY),
    ] {
        assert_eq!(cell(s, a), None, "{s} m/s, {a} m");
    }
}

/// A small `envelope` campaign, flown in two shards and merged: the per-cell table counts
/// every run once, its cells' counts add up to the totals and to the shards', each cell's
/// interval is Wilson's, the heat map is written; a run moved outside the grid or onto a
/// node is counted where the rule says. 24 runs: about 6 s on 2 cores in the debug
/// profile.
#[test]
fn an_envelope_campaign_counts_every_run_in_one_condition_cell() {
    let f = ScenarioFile::load("envelope").expect("preset");
    let runs = 24;
    let root = temp("envelope");
    let shards: Vec<PathBuf> = (1..=2)
        .map(|k| {
            let d = root.join(format!("shard{k}"));
            campaign(&f, runs, Some(Shard { k, m: 2 }), 2, &d);
            d
        })
        .collect();
    let merged = root.join("all");
    montecarlo::merge(&shards, &merged).expect("merges");
    let (s, recs) = (summary(&merged), records(&merged));
    assert_eq!(s.runs, runs);
    let cells = &s.success_by_condition;
    let (v, h) = montecarlo::condition_grid();
    assert_eq!(cells.len(), (v.len() - 1) * (h.len() - 1));
    let sum = |f: &dyn Fn(&montecarlo::ConditionCell) -> u64| cells.iter().map(f).sum::<u64>();
    assert_eq!(sum(&|c| c.runs) + s.outside_condition_grid, s.runs);
    assert_eq!(s.outside_condition_grid, 0, "the envelope is the grid");
    assert_eq!(sum(&|c| c.success), s.success);
    assert_eq!(sum(&|c| c.unsafe_runs), s.unsafe_runs);
    assert_eq!(sum(&|c| c.first_attempt_docked), s.first_attempt_docked);
    for (k, c) in cells.iter().enumerate() {
        let (i, j) = (k % (v.len() - 1), k / (v.len() - 1));
        assert_eq!(c.airspeed_mps, [v[i], v[i + 1]], "cell {k}");
        assert_eq!(c.altitude_m, [h[j], h[j + 1]], "cell {k}");
        let inside: Vec<&RunRecord> = recs
            .iter()
            .filter(|r| {
                montecarlo::condition_cell(r.inputs.airspeed_mps, r.inputs.altitude_m)
                    == Some((i, j))
            })
            .collect();
        assert_eq!(c.runs, inside.len() as u64, "cell {k}");
        assert_eq!(
            c.success,
            inside.iter().filter(|r| r.success).count() as u64
        );
        if c.runs > 0 {
            assert_eq!(
                c.success_ci95,
                Some(montecarlo::wilson(c.success, c.runs)),
                "cell {k}"
            );
            assert_eq!(c.success_rate, Some(c.success as f64 / c.runs as f64));
        } else {
            // An empty cell has no rate: null in summary.json, not 0.
            assert_eq!((c.success_rate, c.success_ci95), (None, None), "cell {k}");
        }
        // The shards' tables add up to the merged one.
        let of = |d: &PathBuf| summary(d).success_by_condition[k];
        let (a, b) = (of(&shards[0]), of(&shards[1]));
        assert_eq!(
            (
                a.runs + b.runs,
                a.success + b.success,
                a.unsafe_runs + b.unsafe_runs
            ),
            (c.runs, c.success, c.unsafe_runs),
            "cell {k}"
        );
    }
    let populated = cells.iter().filter(|c| c.runs > 0).count();
    assert!(
        populated >= 4,
        "24 runs over the envelope fill {populated} cells"
    );
    for d in shards.iter().chain([&merged]) {
        let bytes = std::fs::read(d.join("success_vs_condition.png")).expect("plot written");
        assert_eq!(&bytes[1..4], b"PNG", "{}", d.display());
    }
    // Moved outside the grid, a run leaves the cells; moved onto an inner node, it joins the
    // cell whose upper corner the node is.
    let meta = CampaignMeta::new(&f, runs, None);
    let mut moved = recs.clone();
    moved[0].inputs.airspeed_mps = v[v.len() - 1] + 1.0;
    moved[1].inputs.airspeed_mps = v[1];
    moved[1].inputs.altitude_m = h[1];
    let before = |r: &RunRecord| {
        montecarlo::condition_cell(r.inputs.airspeed_mps, r.inputs.altitude_m)
            .map(|(i, j)| j * (v.len() - 1) + i)
    };
    let t = montecarlo::summarise(&meta, &f.dispersion, &moved);
    assert_eq!(t.outside_condition_grid, 1);
    let mut expected: Vec<u64> = cells.iter().map(|c| c.runs).collect();
    for (r, delta) in [(&recs[0], -1i64), (&recs[1], -1)] {
        if let Some(k) = before(r) {
            expected[k] = expected[k].checked_add_signed(delta).expect("counted");
        }
    }
    expected[0] += 1;
    assert_eq!(
        t.success_by_condition
            .iter()
            .map(|c| c.runs)
            .collect::<Vec<_>>(),
        expected
    );
    std::fs::remove_dir_all(&root).ok();
}

/// Runs 0..39 of `nominal-level2` and of `level2` (the same sorties, the plant dispersed in
/// the second), judged by the referee. Each bound is where the held-out campaign's rate
/// (`docs/scenarios.md`, "Measured: the refuelling presets", runs 1,000,000..1,009,999)
/// puts the tail below 0.5 %: a count beyond it says the controller or the plant changed.
#[test]
fn level2_campaigns_on_the_design_plant_and_on_dispersed_plants_keep_their_rates() {
    let dir = temp("level2");
    // nominal-level2: 9,999 of 10,000 docked, 23 unsafe. Held out, one failure in 40 has a
    // probability of 0.4 %, two unsafe runs 0.4 %. Measured here: 40 docked, 0 unsafe.
    let f = ScenarioFile::load("nominal-level2").expect("preset");
    campaign(&f, 40, None, 2, &dir);
    let s = summary(&dir);
    assert_eq!(s.runs, 40);
    assert_eq!(s.docked, 40, "{:?}", s.failure_causes);
    assert!(s.unsafe_runs <= 1, "hazards: {:?}", s.hazards);
    std::fs::remove_dir_all(&dir).ok();
    // level2: success 82.61 %, unsafe 6.02 % held out. 24 or fewer successes in 40 have a
    // probability of 0.06 %, more than 8 unsafe runs 0.05 %. Measured here: 35 successes,
    // 3 unsafe (a basket strike, two upsets).
    let f = ScenarioFile::load("level2").expect("preset");
    campaign(&f, 40, None, 2, &dir);
    let s = summary(&dir);
    assert_eq!(s.runs, 40);
    assert!(
        s.success >= 25,
        "{} of 40: {:?}",
        s.success,
        s.failure_causes
    );
    assert!(s.unsafe_runs <= 8, "hazards: {:?}", s.hazards);
    // The dispersed plant is flown: the summary's dispersion carries it.
    assert!(
        serde_json::to_string(&s.dispersion)
            .expect("json")
            .contains("engine_time_constant_scale"),
        "{:?}",
        s.dispersion
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_off_nominal_cg_is_trimmed_for_and_still_docks() {
    let nominal_theta = host_sim::receiver::F16::new(0.35)
        .map(|m| m.trim_straight_level(120.0, 3000.0))
        .expect("model")
        .expect("trim")
        .theta_rad;
    for xcg in [0.30, 0.40] {
        let mut f = ScenarioFile::load("calm").expect("preset");
        f.receiver.xcg = xcg;
        let run = sim::run(
            &f.scenario(),
            &mut Controller::new(f.controller_config()).expect("config"),
        )
        .expect("runs");
        assert_eq!(
            run.summary.outcome,
            Outcome::Docked,
            "xcg {xcg}: {:?}",
            run.summary
        );
        // The receiver starts from its own trim (0.3 deg from the nominal one).
        assert!(
            (run.trim.theta_rad - nominal_theta).abs() > 1e-3,
            "xcg {xcg}"
        );
    }
}

/// The variables a batch system sets for the shard of a job.
const BATCH_VARS: [&str; 6] = [
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_MAX",
    "SLURM_ARRAY_TASK_COUNT",
    "SLURM_ARRAY_TASK_STEP",
    "JOB_COMPLETION_INDEX",
];

fn host_sim(args: &[&str]) -> (bool, String, String) {
    host_sim_in(&[], args)
}

/// `host-sim args` with exactly the batch variables `vars` set (none inherited from the
/// environment the tests run in, which may itself be a batch job).
fn host_sim_in(vars: &[(&str, &str)], args: &[&str]) -> (bool, String, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_host-sim"));
    for v in BATCH_VARS {
        cmd.env_remove(v);
    }
    let out = cmd
        .envs(vars.iter().copied())
        .args(args)
        .output()
        .expect("host-sim runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The CI campaign: 50 dispersed runs of `paper-level2` through the command line, sharded
/// and merged. Its numbers are a regression guard, not the measurement (that is 1,000 runs).
#[test]
fn cli_runs_a_fifty_run_campaign_in_shards_and_merges_it() {
    let root = temp("cli");
    let dir = |n: &str| root.join(n).to_str().expect("utf-8").to_string();
    for k in ["1/2", "2/2"] {
        let (ok, line, stderr) = host_sim(&[
            "montecarlo",
            "--scenario",
            "paper-level2",
            "--runs",
            "50",
            "--shard",
            k,
            "--out",
            &dir(&k.replace('/', "of")),
        ]);
        assert!(ok, "{stderr}");
        assert!(line.contains("25 runs (shard"), "{line}");
        assert!(
            stderr.contains("25 runs in"),
            "wall time on stderr: {stderr}"
        );
    }
    let (ok, line, stderr) = host_sim(&[
        "montecarlo",
        "merge",
        &dir("1of2"),
        &dir("2of2"),
        "--out",
        &dir("all"),
    ]);
    assert!(ok, "{stderr}");
    assert!(line.starts_with("paper-level2: 50 runs, success"), "{line}");
    let s = summary(&root.join("all"));
    assert_eq!(s.runs, 50);
    // Measured: 50 of these 50 docked; 988 of the 1,000 held-out runs (`docs/scenarios.md`).
    // At that rate three or more failures in 50 have a probability of 2.2 %.
    assert!(
        s.docked >= 48,
        "paper-level2 docks 98.8 % of held-out runs and 50 of these 50: {line}"
    );
    // Run 3's scenario file, flown by `dock`, gives run 3's record.
    let (ok, toml_text, stderr) = host_sim(&[
        "montecarlo",
        "--scenario",
        "paper-level2",
        "--show-run",
        "3",
    ]);
    assert!(ok, "{stderr}");
    assert!(!toml_text.contains("[dispersion]"), "{toml_text}");
    let file = root.join("run3.toml");
    std::fs::write(&file, toml_text).expect("written");
    let (ok, json, stderr) = host_sim(&[
        "dock",
        "--scenario",
        file.to_str().expect("utf-8"),
        "--json",
        "--no-files",
    ]);
    assert!(ok, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&json).expect("json");
    let r3 = &records(&root.join("all"))[3];
    assert_eq!(v["miss_m"].as_f64(), r3.miss_m, "{json}");
    // Bad arguments are named.
    let (ok, _, stderr) = host_sim(&[
        "montecarlo",
        "--scenario",
        "calm",
        "--runs",
        "4",
        "--shard",
        "3/2",
    ]);
    assert!(!ok && stderr.contains("K/M"), "{stderr}");
    let (ok, _, stderr) = host_sim(&["montecarlo", "--scenario", "calm"]);
    assert!(!ok && stderr.contains("--runs"), "{stderr}");
    std::fs::remove_dir_all(&root).ok();
}

/// A Slurm array task and a Kubernetes Indexed Job pod each fly the shard their environment
/// names (checked in campaign.json and in the run indices written), an explicit `--shard`
/// wins over the environment, and an Indexed Job without `--shards` is refused.
#[test]
fn cli_takes_the_shard_from_a_batch_job_environment() {
    let root = temp("batch");
    let dir = |n: &str| root.join(n).to_str().expect("utf-8").to_string();
    let fly = |vars: &[(&str, &str)], extra: &[&str], name: &str| {
        let mut args = vec!["montecarlo", "--scenario", "calm", "--runs", "4", "--out"];
        let out = dir(name);
        args.push(&out);
        args.extend_from_slice(extra);
        let (ok, _, stderr) = host_sim_in(vars, &args);
        assert!(ok, "{stderr}");
        let meta: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(root.join(name).join("campaign.json")).expect("campaign"),
        )
        .expect("json");
        let runs: Vec<u64> = records(&root.join(name)).iter().map(|r| r.index).collect();
        (meta["shard"].as_str().map(str::to_owned), runs, stderr)
    };
    let slurm = [
        ("SLURM_ARRAY_TASK_ID", "5"),
        ("SLURM_ARRAY_TASK_MIN", "4"),
        ("SLURM_ARRAY_TASK_MAX", "6"),
        ("SLURM_ARRAY_TASK_COUNT", "3"),
        ("SLURM_ARRAY_TASK_STEP", "1"),
    ];
    let (shard, runs, stderr) = fly(&slurm, &[], "slurm");
    assert_eq!(shard.as_deref(), Some("2/3"), "{stderr}");
    assert_eq!(runs, [1]);
    assert!(stderr.contains("from the Slurm job array"), "{stderr}");
    let (shard, runs, _) = fly(&[("JOB_COMPLETION_INDEX", "2")], &["--shards", "3"], "k8s");
    assert_eq!(shard.as_deref(), Some("3/3"));
    assert_eq!(runs, [2]);
    let (shard, runs, _) = fly(&slurm, &["--shard", "1/2"], "explicit");
    assert_eq!(shard.as_deref(), Some("1/2"));
    assert_eq!(runs, [0, 2]);
    let (ok, _, stderr) = host_sim_in(
        &[("JOB_COMPLETION_INDEX", "0")],
        &[
            "montecarlo",
            "--scenario",
            "calm",
            "--runs",
            "4",
            "--out",
            &dir("refused"),
        ],
    );
    assert!(!ok && stderr.contains("--shards M"), "{stderr}");
    std::fs::remove_dir_all(&root).ok();
}

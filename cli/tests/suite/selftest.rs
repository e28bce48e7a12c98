//! `raycast selftest` on lavapipe: every check passes; a result made wrong in one pixel or ray
//! fails the check it is planted in, for every kind of check, and no other; the command's exit
//! codes and output.

use crate::common;

use raycast_cli::study::selftest::{self, Adapter, Check, F32Rule, Options, Outcome};

fn run(options: &Options) -> selftest::Report {
    run_as(&Adapter::probe(common::gpu()).unwrap(), options)
}

fn run_as(adapter: &Adapter, options: &Options) -> selftest::Report {
    let print = &mut |c: &Check| println!("{}", c.line());
    selftest::run(common::gpu(), adapter, options, print).unwrap()
}

/// lavapipe judged as a driver that fuses would be: its unfused f32 meets the bounds too, and
/// one wrong pixel still fails the checks whose bounds allow none (ray lists and the lit
/// render allow 0.1% and 0.5% there: one wrong ray or pixel is within them).
#[test]
fn the_bounds_for_fusing_drivers_hold_and_catch_a_planted_fault() {
    let adapter = Adapter {
        rule: F32Rule::Bounded,
        ..Adapter::probe(common::gpu()).unwrap()
    };
    let report = run_as(&adapter, &Options::default());
    assert!(report.passed(), "{}", report.summary());
    for name in [
        "random-0/f32/packets",
        "streaming/random-2",
        "extremes/dyadic-base/f32",
    ] {
        let options = Options {
            only: vec![name.into()],
            plant: Some(name.into()),
        };
        let report = run_as(&adapter, &options);
        let summary = report.summary();
        assert!(summary.ends_with(&format!("FAILED: {name}")), "{summary}");
    }
}

#[test]
fn every_check_passes_on_lavapipe() {
    let adapter = Adapter::probe(common::gpu()).unwrap();
    assert_eq!(
        adapter.rule,
        F32Rule::Exact,
        "lavapipe does not fuse a*b - c*d"
    );
    // The header says which traversal renders take here, and that the adapter's ray queries
    // (lavapipe has them, #65) are not what is checked.
    let header = adapter.lines.join("\n");
    for part in [
        "BVH traversal by default: packets from 0.15 rays a sphere or triangle",
        "ray queries: the adapter has them (unused",
    ] {
        assert!(header.contains(part), "{header}");
    }
    let report = run(&Options::default());
    println!("{}", report.summary());
    assert!(report.passed(), "{}", report.summary());
    let skipped: Vec<&str> = (report.checks.iter())
        .filter(|c| c.result == Outcome::Skip)
        .map(|c| c.name.as_str())
        .collect();
    assert_eq!(
        skipped,
        ["packets/wide"],
        "lavapipe's subgroups are 8 lanes"
    );
    let names: Vec<&str> = report.checks.iter().map(|c| c.name.as_str()).collect();
    for part in [
        "course/",
        "random-",
        "extremes/scaled",
        "extremes/translated",
        "rays/",
        "lit/",
    ] {
        assert!(names.iter().any(|n| n.contains(part)), "no {part} check");
    }
    assert_eq!(names, selftest::names(common::gpu(), &Options::default()));
}

/// One check of each kind, each with one pixel or ray made wrong: that check fails, and the
/// others its name selects still pass.
#[test]
fn a_planted_wrong_result_fails_its_check_in_every_kind_of_check() {
    let kinds = [
        "course/triangle",
        "random-0/f32/packets",
        "random-0/f32/per-ray",
        "random-2/f64",
        "random-2/adaptive",
        "extremes/dyadic-base/f32",
        "extremes/scaled-2e40",
        "extremes/translated-1e6",
        "rays/one-origin/f32",
        "rays/incoherent/adaptive",
        "lit/bunny",
        "streaming/random-2",
    ];
    for name in kinds {
        let options = Options {
            only: vec![name.into()],
            plant: Some(name.into()),
        };
        let report = run(&options);
        for c in &report.checks {
            let expected = if c.name == name {
                Outcome::Fail
            } else {
                Outcome::Pass
            };
            assert_eq!(c.result, expected, "planted in {name}: {}", c.line());
        }
        assert!(report.summary().ends_with(&format!("FAILED: {name}")));
    }
}

fn selftest_command(args: &[&str]) -> std::process::Output {
    common::raycast()
        .arg("selftest")
        .args(args)
        .env("NODEVICE_SELECT", "1")
        .output()
        .unwrap()
}

#[test]
fn the_command_exits_1_naming_a_failed_check() {
    let out = selftest_command(&["--only", "course/triangle", "--plant", "course/triangle"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    let line = stdout
        .lines()
        .find(|l| l.starts_with("course/triangle"))
        .unwrap();
    assert!(
        line.contains("id differs on 1 px") && line.contains("FAIL"),
        "{line}"
    );
    let last = stdout.lines().last().unwrap();
    assert!(last.contains("0 passed, 1 failed") && last.ends_with("FAILED: course/triangle"));

    let out = selftest_command(&["--only", "course/triangle", "--json"]);
    assert_eq!(out.status.code(), Some(0));
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 2);
    assert_eq!(lines[0]["name"], "course/triangle");
    assert_eq!(lines[0]["result"], "pass");
    assert_eq!(lines[1]["summary"]["passed"], 1);
    assert_eq!(lines[1]["summary"]["failed"], 0);
}

#[test]
fn bad_options_are_one_error_line_and_exit_2() {
    for (args, names) in [
        (&["--plant", "course/nothing"][..], "--plant"),
        (
            &["--only", "course/", "--plant", "lit/bunny"][..],
            "--plant",
        ),
        (&["--only", "no-such-check"][..], "--only"),
    ] {
        let out = selftest_command(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(out.stdout.is_empty(), "{args:?}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.starts_with(&format!("error: {names}: ")), "{stderr}");
    }
}

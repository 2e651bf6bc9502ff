//! `densepack bench`: the report directory of a quick run of two fast studies. Timings are
//! not checked (performance is measured, not asserted), but the files must be complete and
//! well-formed, and what the studies claim about correctness must hold: every success of the
//! relaxer is accepted by the independent check, the columns agree with each other, and the
//! ellipsoid predictors' contacts are touches by the independent Perram–Wertheim check.

mod common;

use common::{densepack, temp_dir};

/// RFC 4180 records (quoted fields may hold commas, quotes and line breaks); a test oracle
/// independent of the writer.
fn parse_csv(text: &str) -> Vec<Vec<String>> {
    let mut records = Vec::new();
    let mut record = Vec::new();
    let mut field = String::new();
    let mut quoted = false;
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match (quoted, c) {
            (true, '"') if chars.peek() == Some(&'"') => {
                field.push('"');
                chars.next();
            }
            (true, '"') => quoted = false,
            (true, c) => field.push(c),
            (false, '"') if field.is_empty() => quoted = true,
            (false, ',') => record.push(std::mem::take(&mut field)),
            (false, '\n') => {
                record.push(std::mem::take(&mut field));
                records.push(std::mem::take(&mut record));
            }
            (false, c) => field.push(c),
        }
    }
    assert!(!quoted, "unterminated quoted field");
    assert!(
        field.is_empty() && record.is_empty(),
        "the last record lacks its line break"
    );
    records
}

fn column(records: &[Vec<String>], name: &str) -> Vec<String> {
    let k = records[0]
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name} in {:?}", records[0]));
    records[1..].iter().map(|r| r[k].clone()).collect()
}

/// The SVG parses as XML, its root is `<svg>`, and its text includes `title`.
fn assert_svg(path: &std::path::Path, title: &str) {
    let text = std::fs::read_to_string(path).unwrap();
    let doc = roxmltree::Document::parse(&text)
        .unwrap_or_else(|e| panic!("{}: not well-formed XML: {e}", path.display()));
    assert_eq!(doc.root_element().tag_name().name(), "svg");
    let texts: String = doc
        .descendants()
        .filter(|n| n.is_text())
        .filter_map(|n| n.text())
        .collect();
    assert!(
        texts.contains(title),
        "{}: no `{title}` in {texts}",
        path.display()
    );
    assert!(
        doc.descendants().any(|n| n.tag_name().name() == "circle"),
        "{}: no data markers",
        path.display()
    );
}

#[test]
fn quick_bench_writes_report_csv_and_svg_per_study() {
    let dir = temp_dir("bench");
    let out = dir.join("report");
    let run = densepack(&[
        "bench",
        "--quick",
        "--only",
        "relaxer,ellipsoid-predictor",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );

    let report = std::fs::read_to_string(out.join("BENCHMARKS.md")).unwrap();
    for needle in [
        "- CPU: ",
        "- cores: ",
        "- densepack: ",
        "- command: `",
        "bench --quick --only relaxer,ellipsoid-predictor",
        "## ellipsoid-predictor",
        "## relaxer",
        "![relaxer](relaxer.svg)",
        "_Total: ",
    ] {
        assert!(
            report.contains(needle),
            "no `{needle}` in the report:\n{report}"
        );
    }
    // Suite order, not command-line order.
    assert!(report.find("## ellipsoid-predictor") < report.find("## relaxer"));

    // Relaxer: 5 time steps and 4 rescaling limits, 3 seeds each.
    let relaxer = parse_csv(&std::fs::read_to_string(out.join("relaxer.csv")).unwrap());
    assert_eq!(
        relaxer[0],
        [
            "parameter",
            "value",
            "runs",
            "failed",
            "median s (successes)",
            "spread",
            "deepest residual overlap ℓ",
            "smallest verified gap",
        ]
    );
    assert_eq!(relaxer.len(), 1 + 9);
    assert!(relaxer.iter().all(|r| r.len() == relaxer[0].len()));
    let parameters = column(&relaxer, "parameter");
    let values: Vec<f64> = column(&relaxer, "value")
        .iter()
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(
        parameters.iter().filter(|p| *p == "time_step").count(),
        5,
        "{parameters:?}"
    );
    assert_eq!(
        values[..5],
        [0.025, 0.05, 0.1, 0.2, 0.4],
        "time steps, in order"
    );
    assert_eq!(values[5..], [0.25, 1.0, 4.0, 16.0], "max prefactors");
    // Runs may fail within the study's time limit on a busy machine, so the count of failures
    // is not fixed; each row must be consistent with it. A success is a packing the
    // independent check accepted (its smallest gap ≥ 0 and a time); a failure of the relaxer
    // leaves an intersection (depth > 0); no packing may be rejected by the check.
    let rows = column(&relaxer, "runs")
        .into_iter()
        .zip(column(&relaxer, "failed"))
        .zip(column(&relaxer, "median s (successes)"))
        .zip(column(&relaxer, "deepest residual overlap ℓ"))
        .zip(column(&relaxer, "smallest verified gap"));
    for ((((runs, failed), median), depth), gap) in rows {
        assert_eq!(runs, "3");
        assert!(
            !failed.contains("rejected"),
            "a packing failed the check: {failed}"
        );
        let failed: usize = failed.parse().unwrap();
        let (median, depth): (f64, f64) = (median.parse().unwrap(), depth.parse().unwrap());
        if failed < 3 {
            assert!(median > 0.0, "{failed} failed, median {median}");
            let gap: f64 = gap
                .parse()
                .unwrap_or_else(|_| panic!("no verified gap: {gap}"));
            assert!(gap >= 0.0, "a verified success overlaps: {gap}");
        } else {
            assert!(median.is_nan(), "no success, median {median}");
            assert_eq!(gap, "–");
        }
        assert_eq!(
            depth > 0.0,
            failed > 0,
            "{failed} failed, deepest overlap {depth}"
        );
    }

    // Ellipsoid predictors: 2 aspect ratios × 2 predictors, 300 pairs each.
    let ell = parse_csv(&std::fs::read_to_string(out.join("ellipsoid-predictor.csv")).unwrap());
    assert_eq!(ell.len(), 1 + 4);
    assert_eq!(
        column(&ell, "predictor"),
        [
            "separating_axis",
            "characteristic",
            "separating_axis",
            "characteristic"
        ]
    );
    assert_eq!(column(&ell, "aspect ratio"), ["1.5", "1.5", "5", "5"]);
    // Both predictors find the same contacts (BENCHMARKS.md: 2000/2000 on the full set,
    // whose first 300 pairs these are), and every predicted contact is a touch by the
    // independent Perram–Wertheim scale: 1 − scale within verify's tolerance 1e-9 of 0 on
    // the overlap side, and not short of contact by more than the predictors' contact
    // tolerance (1e-12 of the smallest semi-axis, a few 1e-12 of the scale).
    let contacts = column(&ell, "contacts");
    for (row, agree) in column(&ell, "agree with separating_axis")
        .iter()
        .enumerate()
    {
        assert_eq!(agree, "300/300", "row {row}");
        assert_eq!(contacts[row], contacts[row - row % 2], "row {row}");
    }
    assert!(contacts.iter().all(|c| c.parse::<usize>().unwrap() > 0));
    for worst in column(&ell, "worst overlap (1 − scale)") {
        let worst: f64 = worst.parse().unwrap();
        assert!(worst < 1e-9 && worst > -1e-9, "worst overlap {worst}");
    }
    for us in column(&ell, "µs/prediction") {
        assert!(us.parse::<f64>().unwrap() > 0.0);
    }

    assert_svg(&out.join("relaxer.svg"), "Relaxer");
    assert_svg(&out.join("ellipsoid-predictor.svg"), "Ellipsoid predictors");
}

#[test]
fn bench_rejects_an_unknown_study_naming_it_and_the_allowed_ones() {
    let dir = temp_dir("bench-bad");
    let run = densepack(&[
        "bench",
        "--only",
        "scaling,nonsense",
        "--out",
        dir.join("r").to_str().unwrap(),
    ]);
    assert_eq!(run.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("`nonsense`"), "{stderr}");
    assert!(stderr.contains("scaling, equilibrium"), "{stderr}");
    assert!(!dir.join("r").exists(), "nothing written on bad input");
}

/// The records of `runs.jsonl`, one JSON object per line.
fn journal_lines(path: &std::path::Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

/// The ψ column of a success-rate study's CSV.
fn success_rates(csv: &std::path::Path) -> Vec<String> {
    column(&parse_csv(&std::fs::read_to_string(csv).unwrap()), "ψ")
}

#[test]
fn bench_resume_reuses_the_recorded_runs_of_this_build_only() {
    let dir = temp_dir("bench-resume");
    let out = dir.join("report");
    let out_arg = out.to_str().unwrap();
    let bench = |resume: bool| {
        let mut args = vec![
            "bench",
            "--quick",
            "--only",
            "fuller-fine",
            "--out",
            out_arg,
        ];
        if resume {
            args.push("--resume");
        }
        let run = densepack(&args);
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        String::from_utf8_lossy(&run.stderr).into_owned()
    };
    bench(false);
    let journal = out.join("runs.jsonl");
    let csv = out.join("fuller-fine.csv");
    let fresh = journal_lines(&journal);
    let fresh_rates = success_rates(&csv);
    // Quick fuller-fine: EDMD in the 32 mm cube, two seeds per step.
    assert!(fresh.len() == 2 || fresh.len() == 4, "{fresh:?}");
    for line in &fresh {
        assert!(line["build"]
            .as_str()
            .unwrap()
            .starts_with(env!("CARGO_PKG_VERSION")));
        assert!(line["scene"].as_str().unwrap().contains("seed = "));
        assert!(line["outcome"]["cpu_seconds"].as_f64().unwrap() > 0.0);
    }

    // Every recorded outcome inverted, a line of another build and a line cut short: a resume
    // must report the inverted outcomes (so it re-used them) and ignore the other two.
    let mut text = String::new();
    for line in &fresh {
        let mut flipped = line.clone();
        let ok = flipped["outcome"]["ok"].as_bool().unwrap();
        flipped["outcome"]["ok"] = (!ok).into();
        flipped["outcome"]["message"] = "stalled".into();
        text += &format!("{flipped}\n");
    }
    let mut foreign = fresh[0].clone();
    foreign["build"] = "0.0.0 elsewhere".into();
    text += &format!("{foreign}\n{{\"build\": \"cut");
    std::fs::write(&journal, text).unwrap();
    let stderr = bench(true);
    assert!(
        stderr.contains(&format!("resume: {} runs of this build", fresh.len()))
            && stderr.contains("1 of other builds and 1 unreadable lines"),
        "{stderr}"
    );
    let resumed_rates = success_rates(&csv);
    let inverted = |psi: &str| format!("{:.2}", 1.0 - psi.parse::<f64>().unwrap());
    assert_eq!(resumed_rates[0], inverted(&fresh_rates[0]));
    // No recorded scene ran again: each is still in one line of this build (the first also
    // in `foreign`).
    let lines = std::fs::read_to_string(&journal).unwrap();
    // The line cut short was closed when the journal was opened again.
    assert!(lines.ends_with("{\"build\": \"cut\n"), "{lines}");
    for (k, line) in fresh.iter().enumerate() {
        let scene = serde_json::to_string(&line["scene"]).unwrap();
        let copies = if k == 0 { 2 } else { 1 };
        assert_eq!(lines.matches(scene.as_str()).count(), copies, "{scene}");
    }

    // Without --resume nothing is re-used: the true outcomes come back, and the file keeps
    // what it held (no run into the same directory erases a journal) with the new runs after.
    let before = std::fs::read_to_string(&journal).unwrap();
    bench(false);
    let after = std::fs::read_to_string(&journal).unwrap();
    assert!(after.starts_with(&before));
    assert_eq!(after.lines().count(), before.lines().count() + fresh.len());
    assert_eq!(success_rates(&csv), fresh_rates);
}

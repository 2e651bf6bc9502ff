//! Ensembles: realisations of one scene that differ only in their seed, kept in one
//! directory.
//!
//! The directory holds, for each seed `k` whose run succeeded, the verified packing
//! `seed-<k>.json` ([`packing_path`]; the JSON of [`crate::io::packing::Packing`], written
//! atomically), and `summary.csv` ([`SUMMARY_FILE`]), one row per finished realisation,
//! appended and flushed as each finishes (so an ensemble killed half-way keeps its rows):
//!
//! ```text
//! seed,status,packing_fraction,min_gap,reduced_pressure,events,wall_seconds,message
//! 3,ok,0.6391,1.2e-13,1.0e12,412345,2.5,
//! 4,failed,,,,,0.8,"stage 0 stopped without reaching its goal (…)"
//! ```
//!
//! A seed may have several rows (a rerun appends); the last one counts ([`read_summary`]). A
//! row cut short by a kill is skipped by the reader and cut off when the summary is reopened.
//!
//! **Resume rule** ([`seeds_to_run`]): a rerun of the same seeds into the same directory
//! skips a seed whose last row is `ok` and whose packing file exists, and a seed whose last
//! row is `failed` (a failure is a verdict on the scene and seed: the run is deterministic,
//! so running it again gives the same failure). It runs a seed without a row, a seed whose
//! last row is `lost` (it never reported a result: cancelled, crashed, or its packing could
//! not be written) and a seed whose last row is `ok` but whose packing file is missing.
//! The rule does not look at the scene: an ensemble directory is for one scene.

use crate::cancel::CancelFlag;
use crate::io::scene::AnyScene;
use crate::run::{run, RunError, RunOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The summary file of an ensemble directory.
pub const SUMMARY_FILE: &str = "summary.csv";

/// The header line of [`SUMMARY_FILE`].
pub const SUMMARY_HEADER: &str =
    "seed,status,packing_fraction,min_gap,reduced_pressure,events,wall_seconds,message";

/// How a realisation ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// Verified packing written.
    Ok,
    /// The run failed (a stage missed its goal, seeding failed, …): a verdict on the scene
    /// and seed, with the error as the message. No packing.
    Failed,
    /// No result: cancelled, crashed (a panic) or the packing could not be written.
    Lost,
}

impl Status {
    /// The name in the summary: `ok`, `failed`, `lost`.
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Failed => "failed",
            Status::Lost => "lost",
        }
    }

    fn parse(text: &str) -> Option<Self> {
        [Status::Ok, Status::Failed, Status::Lost]
            .into_iter()
            .find(|s| s.as_str() == text)
    }
}

/// One realisation, as a row of [`SUMMARY_FILE`]. The measurements are those of the written
/// packing (`None` unless the status is [`Status::Ok`], and `min_gap` also with fewer than
/// two particles near each other).
#[derive(Clone, Debug, PartialEq)]
pub struct SummaryRow {
    /// The seed.
    pub seed: u64,
    /// How it ended.
    pub status: Status,
    /// Packing fraction of the packing.
    pub packing_fraction: Option<f64>,
    /// Smallest surface-to-surface distance between two particles, measured by the
    /// independent check (`crate::verify`), in the scene's length unit.
    pub min_gap: Option<f64>,
    /// Reduced pressure `Z` at the end of the last stage (`None` for RSA and mixture
    /// scenes, which measure none).
    pub reduced_pressure: Option<f64>,
    /// Events of the run (EDMD events; RSA candidates or relaxer steps for mixtures).
    pub events: Option<u64>,
    /// Wall-clock seconds of the realisation, from the start of the run to the written
    /// packing.
    pub wall_seconds: f64,
    /// Why it failed or was lost (empty when ok).
    pub message: String,
}

/// Why an ensemble's seeds or directory cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum EnsembleError {
    /// A seed list that does not parse.
    #[error("seeds `{text}`: {message}")]
    Seeds {
        /// The text given.
        text: String,
        /// What is wrong and what is allowed.
        message: String,
    },
    /// Reading or writing the directory failed.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: String,
        /// The error.
        source: std::io::Error,
    },
    /// A summary row that does not parse.
    #[error("{path}: record {record}: {message}")]
    Summary {
        /// The summary file.
        path: String,
        /// Record number (the header is record 1).
        record: usize,
        /// What is wrong.
        message: String,
    },
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> EnsembleError + '_ {
    move |source| EnsembleError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// The packing file of `seed` in the ensemble directory `dir`: `dir/seed-<seed>.json`.
pub fn packing_path(dir: &Path, seed: u64) -> PathBuf {
    dir.join(format!("seed-{seed}.json"))
}

/// Runs `scene` with `seed` ([`AnyScene::with_seed`]), writes the verified packing to
/// [`packing_path`] and returns the row. A failed run writes no packing (and removes a
/// packing of the seed left by an earlier run) and returns a [`Status::Failed`] row with the
/// error as its message; a cancelled run, a panic or a packing that cannot be written gives
/// a [`Status::Lost`] row. `dir` must exist. Same scene and seed give the same packing as
/// `densepack run --seed` (bit for bit).
pub fn run_realisation(
    scene: &AnyScene,
    seed: u64,
    dir: &Path,
    cancel: Option<CancelFlag>,
) -> SummaryRow {
    let started = std::time::Instant::now();
    let scene = scene.with_seed(seed);
    let path = packing_path(dir, seed);
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        run(
            &scene,
            RunOptions {
                cancel,
                ..RunOptions::default()
            },
        )
    }));
    let row = |status, message: String| SummaryRow {
        seed,
        status,
        packing_fraction: None,
        min_gap: None,
        reduced_pressure: None,
        events: None,
        wall_seconds: started.elapsed().as_secs_f64(),
        message,
    };
    match result {
        Ok(Ok(outcome)) => {
            if let Err(e) = outcome.packing.write(&path) {
                return row(Status::Lost, format!("packing not written: {e}"));
            }
            let stats = &outcome.packing.stats;
            SummaryRow {
                packing_fraction: Some(stats.packing_fraction),
                min_gap: outcome.verification.min_pair_gap,
                reduced_pressure: stats.reduced_pressure,
                events: Some(stats.events),
                ..row(Status::Ok, String::new())
            }
        }
        Ok(Err(e @ RunError::Cancelled)) => row(Status::Lost, e.to_string()),
        Ok(Err(e)) => {
            // A packing of an earlier run of this seed would contradict the verdict.
            let _ = std::fs::remove_file(&path);
            row(Status::Failed, e.to_string())
        }
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            row(Status::Lost, format!("the run panicked: {what}"))
        }
    }
}

/// A number as the summary writes it: the shortest text that reads back to the same value,
/// plain between 10⁻⁴ and 10⁶ and in exponent form (`2.2e-15`) beyond; empty for `None`.
fn number(x: Option<f64>) -> String {
    x.map_or_else(String::new, |x| {
        if x == 0.0 || !x.is_finite() || (1e-4..1e6).contains(&x.abs()) {
            x.to_string()
        } else {
            format!("{x:e}")
        }
    })
}

/// A CSV field: quoted (inner quotes doubled) when it holds a comma, quote or line break.
fn quoted(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

impl SummaryRow {
    /// The row as a CSV line of [`SUMMARY_FILE`] (with its line break).
    pub fn to_csv(&self) -> String {
        format!(
            "{},{},{},{},{},{},{},{}\n",
            self.seed,
            self.status.as_str(),
            number(self.packing_fraction),
            number(self.min_gap),
            number(self.reduced_pressure),
            self.events.map_or_else(String::new, |e| e.to_string()),
            number(Some(self.wall_seconds)),
            quoted(&self.message)
        )
    }

    /// The row of the CSV `fields`, or what is wrong with them.
    fn from_fields(fields: &[String]) -> Result<Self, String> {
        let [seed, status, fraction, gap, pressure, events, wall, message] = fields else {
            return Err(format!("{} fields, expected 8", fields.len()));
        };
        fn opt<T: std::str::FromStr>(name: &str, text: &str) -> Result<Option<T>, String> {
            if text.is_empty() {
                return Ok(None);
            }
            text.parse()
                .map(Some)
                .map_err(|_| format!("{name} `{text}` is not a number"))
        }
        Ok(SummaryRow {
            seed: seed
                .parse()
                .map_err(|_| format!("seed `{seed}` is not an integer in [0, 2^64)"))?,
            status: Status::parse(status)
                .ok_or_else(|| format!("status `{status}` is not ok, failed or lost"))?,
            packing_fraction: opt("packing_fraction", fraction)?,
            min_gap: opt("min_gap", gap)?,
            reduced_pressure: opt("reduced_pressure", pressure)?,
            events: opt("events", events)?,
            wall_seconds: opt("wall_seconds", wall)?.ok_or("wall_seconds is empty")?,
            message: message.clone(),
        })
    }
}

/// The complete records of CSV `text` (RFC 4180 quoting), each with its fields, and the
/// length in bytes of the text they take. A last record without its line break (a write cut
/// short) is left out.
///
/// Written here rather than with the `csv` crate: a record counts only when its line break
/// falls outside quotes, so a row cut short inside its quoted message (after a line break
/// in it) is still recognised as cut short; the crate ends an open quote at the end of the
/// input and would hand such a row back as whole.
fn records(text: &str) -> (Vec<Vec<String>>, usize) {
    let mut out = Vec::new();
    let mut fields = Vec::new();
    let mut field = String::new();
    let mut chars = text.char_indices().peekable();
    let mut quoted = false;
    let mut complete = 0;
    while let Some((at, c)) = chars.next() {
        let next = chars.peek().map(|&(_, c)| c);
        match (quoted, c) {
            (true, '"') if next == Some('"') => {
                chars.next();
                field.push('"');
            }
            (true, '"') => quoted = false,
            (true, c) => field.push(c),
            (false, '"') if field.is_empty() => quoted = true,
            (false, ',') => fields.push(std::mem::take(&mut field)),
            (false, '\r') if next == Some('\n') => {}
            (false, '\n') => {
                fields.push(std::mem::take(&mut field));
                out.push(std::mem::take(&mut fields));
                complete = at + 1;
            }
            (false, c) => field.push(c),
        }
    }
    (out, complete)
}

/// The last row of each seed in `dir`'s [`SUMMARY_FILE`], by ascending seed; none when the
/// file does not exist. A last record cut short (a killed writer) is ignored.
pub fn read_summary(dir: &Path) -> Result<Vec<SummaryRow>, EnsembleError> {
    let path = dir.join(SUMMARY_FILE);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(io_error(&path)(e)),
    };
    let bad = |record: usize, message: String| EnsembleError::Summary {
        path: path.display().to_string(),
        record,
        message,
    };
    let mut rows = std::collections::BTreeMap::new();
    for (k, fields) in records(&text).0.iter().enumerate() {
        if k == 0 {
            if fields.join(",") != SUMMARY_HEADER {
                return Err(bad(1, format!("the header is not `{SUMMARY_HEADER}`")));
            }
            continue;
        }
        let row = SummaryRow::from_fields(fields).map_err(|m| bad(k + 1, m))?;
        rows.insert(row.seed, row);
    }
    Ok(rows.into_values().collect())
}

/// Appends rows to `dir`'s [`SUMMARY_FILE`], each written whole and flushed to the file at
/// once.
#[derive(Debug)]
pub struct SummaryWriter {
    file: std::fs::File,
    path: PathBuf,
}

impl SummaryWriter {
    /// Opens (creating `dir` and the file with its header if need be) the summary of `dir`
    /// for appending. A last record cut short by a killed writer is cut off first (its
    /// realisation never reported: the resume rule runs it again).
    pub fn open(dir: &Path) -> Result<Self, EnsembleError> {
        std::fs::create_dir_all(dir).map_err(io_error(dir))?;
        let path = dir.join(SUMMARY_FILE);
        let existing = match std::fs::read_to_string(&path) {
            Ok(text) => text,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
            Err(e) => return Err(io_error(&path)(e)),
        };
        let mut file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .map_err(io_error(&path))?;
        let complete = records(&existing).1;
        if complete < existing.len() {
            file.set_len(complete as u64).map_err(io_error(&path))?;
        }
        if complete == 0 {
            file.write_all(format!("{SUMMARY_HEADER}\n").as_bytes())
                .map_err(io_error(&path))?;
        }
        Ok(Self { file, path })
    }

    /// Appends `row` and flushes it to the file.
    pub fn append(&mut self, row: &SummaryRow) -> Result<(), EnsembleError> {
        self.file
            .write_all(row.to_csv().as_bytes())
            .and_then(|()| self.file.flush())
            .map_err(io_error(&self.path))
    }
}

/// The seeds of `seeds` (in their order) that a run into `dir` still has to do, by the
/// resume rule of the module documentation.
pub fn seeds_to_run(dir: &Path, seeds: &[u64]) -> Result<Vec<u64>, EnsembleError> {
    let last: std::collections::HashMap<u64, Status> = read_summary(dir)?
        .into_iter()
        .map(|r| (r.seed, r.status))
        .collect();
    Ok(seeds
        .iter()
        .copied()
        .filter(|&seed| match last.get(&seed) {
            None | Some(Status::Lost) => true,
            Some(Status::Failed) => false,
            Some(Status::Ok) => !packing_path(dir, seed).exists(),
        })
        .collect())
}

/// Parses a seed list: comma-separated items, each a seed (`7`) or an inclusive range
/// (`1..100` is the 100 seeds 1 to 100), e.g. `1..10,20`. Every seed is an integer in
/// `[0, 2^64)`; a range may not be empty (`5..4`) and no seed may appear twice.
pub fn parse_seeds(text: &str) -> Result<Vec<u64>, EnsembleError> {
    let bad = |message: String| EnsembleError::Seeds {
        text: text.to_string(),
        message,
    };
    let seed = |s: &str| {
        s.trim().parse::<u64>().map_err(|_| {
            bad(format!(
                "`{}` is not a seed (an integer in [0, 2^64)); give seeds as 1..100 \
                 (inclusive), 1,5,9 or 1..10,20",
                s.trim()
            ))
        })
    };
    let mut seeds = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for item in text.split(',') {
        let (first, last) = match item.split_once("..") {
            Some((a, b)) => (seed(a)?, seed(b)?),
            None => {
                let s = seed(item)?;
                (s, s)
            }
        };
        if last < first {
            return Err(bad(format!(
                "the range {first}..{last} is empty (ranges are inclusive and ascending)"
            )));
        }
        for s in first..=last {
            if !seen.insert(s) {
                return Err(bad(format!("seed {s} appears twice")));
            }
            seeds.push(s);
        }
    }
    Ok(seeds)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_lists_are_inclusive_ranges_and_single_seeds() {
        assert_eq!(parse_seeds("1..4").unwrap(), vec![1, 2, 3, 4]);
        assert_eq!(parse_seeds("1,5,9").unwrap(), vec![1, 5, 9]);
        assert_eq!(parse_seeds("1..3,20").unwrap(), vec![1, 2, 3, 20]);
        assert_eq!(parse_seeds(" 7 ").unwrap(), vec![7]);
        for (text, says) in [
            ("", "`` is not a seed"),
            ("1..", "`` is not a seed"),
            ("a", "`a` is not a seed"),
            ("-1", "`-1` is not a seed"),
            ("5..4", "5..4 is empty"),
            ("1..3,2", "seed 2 appears twice"),
        ] {
            let e = parse_seeds(text).unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("seeds `{text}`: ")) && e.contains(says),
                "{text}: {e}"
            );
        }
    }

    fn row(seed: u64, status: Status, message: &str) -> SummaryRow {
        SummaryRow {
            seed,
            status,
            packing_fraction: (status == Status::Ok).then_some(0.1 + 0.2),
            min_gap: (status == Status::Ok).then_some(1.5e-13),
            reduced_pressure: None,
            events: (status == Status::Ok).then_some(12),
            wall_seconds: 0.25,
            message: message.into(),
        }
    }

    #[test]
    fn rows_round_trip_through_the_csv_with_quoted_messages() {
        let dir = std::env::temp_dir().join(format!("densepack-summary-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let rows = [
            row(3, Status::Ok, ""),
            row(4, Status::Failed, "stage 0: \"jammed\", twice\nsecond line"),
            row(5, Status::Lost, "the run was cancelled"),
            row(3, Status::Lost, "later row, wins"),
        ];
        let mut w = SummaryWriter::open(&dir).unwrap();
        for r in &rows {
            w.append(r).unwrap();
        }
        drop(w);
        // A writer killed mid-row leaves a record cut short (here inside a quoted message
        // with a line break); the reader skips it and reopening cuts it off.
        let path = dir.join(SUMMARY_FILE);
        let whole = std::fs::read_to_string(&path).unwrap();
        assert!(whole.starts_with(&format!("{SUMMARY_HEADER}\n3,ok,0.30000000000000004,")));
        std::fs::write(&path, format!("{whole}6,failed,,,,,0.5,\"cut\nshort")).unwrap();
        let read = read_summary(&dir).unwrap();
        assert_eq!(
            read,
            vec![rows[3].clone(), rows[1].clone(), rows[2].clone()]
        );
        SummaryWriter::open(&dir)
            .unwrap()
            .append(&row(7, Status::Ok, ""))
            .unwrap();
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            format!("{whole}{}", row(7, Status::Ok, "").to_csv())
        );
        let read = read_summary(&dir).unwrap();
        assert_eq!(read.len(), 4, "{read:?}");
        assert_eq!(read[3], row(7, Status::Ok, ""));
        // 0.1 + 0.2 is not 0.3: the shortest text still reads back to the same bits.
        assert_eq!(read[3].packing_fraction, Some(0.1 + 0.2));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_resume_rule_reruns_missing_lost_and_unwritten_seeds_only() {
        let dir = std::env::temp_dir().join(format!("densepack-resume-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut w = SummaryWriter::open(&dir).unwrap();
        // 1: ok with its file; 2: ok, file gone; 3: failed; 4: lost; 5: no row.
        for r in [
            row(1, Status::Ok, ""),
            row(2, Status::Ok, ""),
            row(3, Status::Failed, "verdict"),
            row(4, Status::Lost, "cancelled"),
        ] {
            w.append(&r).unwrap();
        }
        std::fs::write(packing_path(&dir, 1), "{}").unwrap();
        assert_eq!(seeds_to_run(&dir, &[1, 2, 3, 4, 5]).unwrap(), vec![2, 4, 5]);
        // A later ok row of a lost seed (with its file) settles it.
        w.append(&row(4, Status::Ok, "")).unwrap();
        std::fs::write(packing_path(&dir, 4), "{}").unwrap();
        assert_eq!(seeds_to_run(&dir, &[1, 2, 3, 4, 5]).unwrap(), vec![2, 5]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

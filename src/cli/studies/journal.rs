//! The run journal of `densepack bench`: every finished run of the concrete studies, one JSON
//! line each in `<out>/runs.jsonl`, so that a study of many hours that is interrupted (a
//! session ends, a machine is needed back) can be resumed without repeating its finished runs
//! (`densepack bench --resume`).
//!
//! A line is `{"build": …, "scene": …, "outcome": …}`: the build that ran it (version and git
//! commit), the exact scene text (seed included) and the study's outcome record. A run is
//! re-used only for the identical scene text and the identical build, so a resumed table is
//! the table an uninterrupted run of that build would have written (its CPU times are those
//! measured when each run ran). Lines of other builds are kept in the file but not used; a
//! last line cut short by the interruption is ignored. A build from uncommitted changes
//! carries the commit it started from: resume with the binary that wrote the file.

use serde::de::DeserializeOwned;
use serde::Serialize;
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufRead as _, BufReader, Read as _, Seek as _, SeekFrom, Write as _};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The finished runs of earlier attempts (when resuming) and the file that records new ones.
#[derive(Debug)]
pub struct Journal {
    path: PathBuf,
    file: Mutex<File>,
    /// Outcome of each recorded scene text of this build.
    recorded: HashMap<String, serde_json::Value>,
}

/// One line of the journal (`S`: `&str` to write, `String` to read, as scene texts hold
/// escaped line breaks).
#[derive(serde::Deserialize, Serialize)]
struct Line<S, T> {
    build: S,
    scene: S,
    outcome: T,
}

/// The build a run is recorded under: version and, when built in a git checkout, the commit.
fn build() -> String {
    format!(
        "{} {}",
        env!("CARGO_PKG_VERSION"),
        option_env!("DENSEPACK_GIT_COMMIT").unwrap_or("(no commit)")
    )
}

impl Journal {
    /// The file name inside a report directory.
    pub const FILE: &'static str = "runs.jsonl";

    /// Opens `path` for appending. With `resume`, the runs it records for this build are
    /// re-used (a missing file records none); without, none is, but the file is kept and
    /// appended to (a run of other studies into the same directory must not erase it). Reports on
    /// stderr how many runs are re-used and how many lines of other builds are left aside.
    pub fn open(path: &Path, resume: bool) -> std::io::Result<Self> {
        let mut recorded = HashMap::new();
        if resume && path.exists() {
            let this = build();
            let (mut other, mut unreadable) = (0usize, 0usize);
            for line in BufReader::new(File::open(path)?).lines() {
                match serde_json::from_str::<Line<String, serde_json::Value>>(&line?) {
                    Ok(l) if l.build == this => {
                        recorded.insert(l.scene, l.outcome);
                    }
                    Ok(_) => other += 1,
                    Err(_) => unreadable += 1,
                }
            }
            eprintln!(
                "resume: {} runs of this build ({this}) re-used from {}; {other} of other \
                 builds and {unreadable} unreadable lines left aside",
                recorded.len(),
                path.display()
            );
        }
        let mut file = std::fs::OpenOptions::new()
            .create(true)
            .read(true)
            .append(true)
            .open(path)?;
        // A line cut short by an interruption is closed, so that the next record starts a
        // line of its own. Only the last byte is read (the file grows to megabytes); writes
        // in append mode go to the end wherever the read left the position.
        if file.metadata()?.len() > 0 {
            let mut last = [0u8];
            file.seek(SeekFrom::End(-1))?;
            file.read_exact(&mut last)?;
            if last[0] != b'\n' {
                writeln!(file)?;
            }
        }
        Ok(Self {
            path: path.to_owned(),
            file: Mutex::new(file),
            recorded,
        })
    }

    /// The outcome recorded for `scene` by this build, if any.
    pub fn get<T: DeserializeOwned>(&self, scene: &str) -> Option<T> {
        self.recorded
            .get(scene)
            .and_then(|v| T::deserialize(v).ok())
    }

    /// Appends the outcome of `scene` (one line, written whole and flushed, so that an
    /// interruption loses at most the runs still going).
    pub fn record<T: Serialize>(&self, scene: &str, outcome: &T) {
        let build = build();
        let line = serde_json::to_string(&Line {
            build: build.as_str(),
            scene,
            outcome,
        })
        .expect("an outcome record serialises");
        let mut file = self.file.lock().expect("no writer panicked");
        if let Err(e) = writeln!(file, "{line}").and_then(|()| file.flush()) {
            eprintln!(
                "warning: {}: {e}; this run will not be resumable",
                self.path.display()
            );
        }
    }
}

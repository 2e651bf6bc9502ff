//! Checkpoint files: a run's state at a time barrier, to resume it after a crash or a kill.
//!
//! Layout: the magic line `densepack-checkpoint\n`, then two [postcard] records (a compact
//! binary serde encoding that stores every `f64` bit for bit, NaN included): the
//! [`CheckpointHeader`] (versions, the scene's TOML text, the stage in progress with its
//! [`StageProgress`], the reports of the finished stages), then the kernel's
//! [`KernelSnapshot`], whose particle type the scene decides (so it is decoded after the
//! header, by the run). Files are replaced atomically ([`write_atomically`]): a kill during a
//! write leaves the previous checkpoint intact.
//!
//! A checkpoint is only resumed by the densepack version that wrote it: the events of a
//! resumed run are those of the uninterrupted run only if the code is the same.

use crate::io::packing::write_atomically;
use crate::kernel::{KernelSnapshot, StageProgress, StageReport};
use crate::shape::Collidable;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::cell::RefCell;
use std::io::Write;
use std::path::Path;

/// First bytes of every checkpoint file.
pub const MAGIC: &[u8] = b"densepack-checkpoint\n";

/// Version of the checkpoint layout.
/// 2: event counters gained `prediction_failures`; ellipsoid kernels (with their spins).
/// 3: kernels store their neighbour envelopes (empty for spheres).
/// 4: ellipsoid envelopes store their capsule (radius and half-length of the spine); the
/// kernel numbers its particles along a Morton curve of the cells, so a version-3 snapshot
/// would resume in a numbering the uninterrupted run never had.
/// 5: particles store their state at kernel time 0 and no update time.
/// 6: a neighbour-list sphere's centre and radius are one record.
/// 7: a stage in progress stores its current growth rate and growth clock (pressure-adaptive
/// rates).
/// 8: the cell grid links its members one way (no `prev`); particles keep two local events,
/// so a run's events differ from version 7's.
/// 9: no collision counters (pair events are checked against the partner's last change,
/// which starts afresh at every barrier).
pub const CHECKPOINT_VERSION: u32 = 9;

/// Everything of a checkpoint but the kernel.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CheckpointHeader<'a> {
    /// [`CHECKPOINT_VERSION`] of the writer.
    pub version: u32,
    /// Crate version of the writer.
    pub crate_version: Cow<'a, str>,
    /// The scene, as the TOML text the run was started with.
    pub scene_toml: Cow<'a, str>,
    /// Index of the stage in progress.
    pub stage: usize,
    /// Where that stage stands.
    pub progress: Cow<'a, StageProgress>,
    /// Reports of the stages before it.
    pub reports: Cow<'a, [StageReport]>,
}

impl<'a> CheckpointHeader<'a> {
    /// A header of this version of densepack.
    pub fn new(
        scene_toml: &'a str,
        stage: usize,
        progress: &'a StageProgress,
        reports: &'a [StageReport],
    ) -> Self {
        Self {
            version: CHECKPOINT_VERSION,
            crate_version: Cow::Borrowed(env!("CARGO_PKG_VERSION")),
            scene_toml: Cow::Borrowed(scene_toml),
            stage,
            progress: Cow::Borrowed(progress),
            reports: Cow::Borrowed(reports),
        }
    }
}

/// A checkpoint that cannot be read or resumed.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// I/O failure.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// Not a checkpoint of this densepack version, or damaged.
    #[error("{path}: {message}")]
    Format {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
}

/// Writes a checkpoint atomically (temporary file, then rename).
pub fn write_checkpoint<S>(
    path: &Path,
    header: &CheckpointHeader<'_>,
    kernel: &KernelSnapshot<'_, S>,
) -> std::io::Result<()>
where
    S: Collidable + Serialize,
    S::Spin: Serialize,
{
    write_atomically(path, |w| {
        w.write_all(MAGIC)?;
        postcard::to_io(header, &mut *w).map_err(std::io::Error::other)?;
        postcard::to_io(kernel, &mut *w).map_err(std::io::Error::other)?;
        Ok(())
    })
}

/// A checkpoint read from disk: the decoded header and the kernel record, decoded by
/// [`CheckpointFile::take_kernel`] once the particle type is known.
#[derive(Debug)]
pub struct CheckpointFile {
    /// The header.
    pub header: CheckpointHeader<'static>,
    path: String,
    /// The file's bytes, the kernel record from `kernel_start` on; empty once the kernel is
    /// taken. They are as large as the kernel itself (320 MB for two million spheres), so a
    /// resumed run must not keep them: the run holds the file for its whole length.
    bytes: RefCell<Vec<u8>>,
    kernel_start: usize,
}

impl CheckpointFile {
    /// Reads and checks a checkpoint file of this densepack version.
    pub fn read(path: &Path) -> Result<Self, CheckpointError> {
        let bytes = std::fs::read(path).map_err(|source| CheckpointError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_bytes(bytes, &path.display().to_string())
    }

    /// Decodes the header of a checkpoint file's bytes; `path` names it in errors.
    pub fn from_bytes(bytes: Vec<u8>, path: &str) -> Result<Self, CheckpointError> {
        let format = |message: String| CheckpointError::Format {
            path: path.to_string(),
            message,
        };
        let body = bytes
            .strip_prefix(MAGIC)
            .ok_or_else(|| format("not a densepack checkpoint (no checkpoint header)".into()))?;
        let (header, rest): (CheckpointHeader<'static>, &[u8]) = postcard::take_from_bytes(body)
            .map_err(|e| format(format!("damaged checkpoint header: {e}")))?;
        if header.version != CHECKPOINT_VERSION || header.crate_version != env!("CARGO_PKG_VERSION")
        {
            return Err(format(format!(
                "written by densepack {} (checkpoint version {}); this is densepack {} \
                 (checkpoint version {CHECKPOINT_VERSION}), which cannot resume it identically",
                header.crate_version,
                header.version,
                env!("CARGO_PKG_VERSION")
            )));
        }
        let kernel_start = bytes.len() - rest.len();
        Ok(Self {
            header,
            path: path.to_string(),
            bytes: RefCell::new(bytes),
            kernel_start,
        })
    }

    /// An error about this checkpoint.
    pub fn error(&self, message: impl Into<String>) -> CheckpointError {
        CheckpointError::Format {
            path: self.path.clone(),
            message: message.into(),
        }
    }

    /// The kernel snapshot, decoded for particle type `S`, once: the file's bytes are
    /// released as it is decoded, and a second call is an error.
    pub fn take_kernel<S>(&self) -> Result<KernelSnapshot<'static, S>, CheckpointError>
    where
        S: Collidable + DeserializeOwned,
        S::Spin: DeserializeOwned,
    {
        let bytes = self.bytes.take();
        if bytes.is_empty() {
            // A file read has at least its magic line: only a taken kernel leaves none.
            return Err(self.error("its kernel record was already taken"));
        }
        let (snapshot, rest) = postcard::take_from_bytes(&bytes[self.kernel_start..])
            .map_err(|e| self.error(format!("damaged kernel record: {e}")))?;
        if !rest.is_empty() {
            return Err(self.error(format!(
                "{} unexpected bytes after the kernel record",
                rest.len()
            )));
        }
        Ok(snapshot)
    }
}

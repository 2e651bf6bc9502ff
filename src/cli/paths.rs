//! Output paths checked before the work: a run that ends in an unwritable `--out` after
//! hours has wasted them, and an output that names an input would replace it.

use std::path::{Path, PathBuf};

/// One file a command reads or writes, with the option that names it (`--out`, `scene`).
pub type Named<'a> = (&'static str, &'a Path);

/// Refuses, before any work, `outputs` that cannot be written, that name one of `inputs`,
/// or that name each other. An output can be written when its directory exists and takes a
/// new file (tried with an empty probe file, removed at once) and the path is not a
/// directory or a special file: outputs are replaced atomically by a rename (see
/// `write_atomically`), which would put a regular file in place of a device such as
/// `/dev/null`. The message names the option.
pub fn check_outputs(outputs: &[Named], inputs: &[Named]) -> Result<(), String> {
    for (k, &(option, out)) in outputs.iter().enumerate() {
        writable(out).map_err(|e| format!("{option} {}: {e}", out.display()))?;
        for &(input, path) in inputs {
            if same_file(out, path) {
                return Err(format!(
                    "{option} {} is the {input} {}: an output never replaces an input; \
                     choose another file",
                    out.display(),
                    path.display()
                ));
            }
        }
        for &(other, path) in &outputs[..k] {
            if same_file(out, path) {
                return Err(format!(
                    "{option} {} is also {other}: give each output its own file",
                    out.display()
                ));
            }
        }
    }
    Ok(())
}

/// The directory a file `path` is created in.
fn directory_of(path: &Path) -> &Path {
    path.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// Whether a file can be put at `out` (see [`check_outputs`]); leaves nothing behind.
fn writable(out: &Path) -> Result<(), String> {
    let dir = directory_of(out);
    if !dir.is_dir() {
        return Err(format!("directory {} does not exist", dir.display()));
    }
    if out.is_dir() {
        return Err("is a directory".into());
    }
    if out.exists() && !out.is_file() {
        return Err(
            "is not a regular file (outputs are replaced atomically by a rename, \
                    which would replace this special file)"
                .into(),
        );
    }
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| "names no file".to_string())?;
    let probe = dir.join(format!(".{name}.{}.probe", std::process::id()));
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(file) => {
            drop(file);
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(format!(
            "cannot create a file in directory {}: {e}",
            dir.display()
        )),
    }
}

/// The path `p` resolves to: canonical if it exists, else its canonical directory joined
/// with its name (`None` if even the directory cannot be resolved).
fn resolved(p: &Path) -> Option<PathBuf> {
    if let Ok(c) = p.canonicalize() {
        return Some(c);
    }
    let dir = directory_of(p).canonicalize().ok()?;
    Some(dir.join(p.file_name()?))
}

/// Whether `a` and `b` name the same file: the same device and inode when both exist (hard
/// links, symbolic links, `./x` and `x` alike), else the same resolved path.
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    match (resolved(a), resolved(b)) {
        (Some(x), Some(y)) => x == y,
        _ => false,
    }
}

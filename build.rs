//! Records the git commit the crate is built from, so that a packing's provenance tells builds
//! of one version apart (`DENSEPACK_GIT_COMMIT`, read with `option_env!`).
//!
//! Built outside a git checkout (a crates.io package, a tarball) or without `git` on the path,
//! the variable is not set and the provenance leaves the commit out. No dependency: the
//! commit comes from `git rev-parse HEAD`.

use std::path::Path;
use std::process::Command;

/// `git ARGS` in the crate's directory, its trimmed standard output when it succeeds.
fn git(args: &[&str]) -> Option<String> {
    let dir = std::env::var_os("CARGO_MANIFEST_DIR")?;
    let out = Command::new("git")
        .args(args)
        .current_dir(dir)
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let text = String::from_utf8(out.stdout).ok()?;
    let text = text.trim();
    (!text.is_empty()).then(|| text.to_string())
}

fn main() {
    // Without this line cargo would rerun the script on every change of any file in the
    // package; with it, only on the files named here.
    println!("cargo:rerun-if-changed=build.rs");
    let Some(commit) = git(&["rev-parse", "HEAD"]) else {
        return;
    };
    println!("cargo:rustc-env=DENSEPACK_GIT_COMMIT={commit}");
    // A new commit moves the branch's ref (loose or packed) and a checkout moves HEAD: watch
    // those so the recorded commit follows them. Only existing files are named, because cargo
    // treats a missing one as always changed and would rebuild every time.
    let git_dir = git(&["rev-parse", "--git-dir"]);
    let common_dir = git(&["rev-parse", "--git-common-dir"]);
    let branch_ref = git(&["symbolic-ref", "-q", "HEAD"]);
    let manifest = std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default();
    let mut watched = Vec::new();
    if let Some(dir) = &git_dir {
        watched.push(Path::new(&manifest).join(dir).join("HEAD"));
    }
    if let Some(dir) = &common_dir {
        let common = Path::new(&manifest).join(dir);
        if let Some(r) = &branch_ref {
            watched.push(common.join(r));
        }
        watched.push(common.join("packed-refs"));
    }
    for path in watched.into_iter().filter(|p| p.exists()) {
        println!("cargo:rerun-if-changed={}", path.display());
    }
}

//! A firmware image of one run's own: the build under a lock and a private
//! copy, so runs at once do not run each other's record.
//!
//! Every configuration builds into one path (`firmware`'s build script
//! bakes the record and settings in). This module owns the lock file
//! `build.lock` and the copies `firmware-PID` in its directory; it does not
//! build (the caller's closure does) and does not run the image.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// Runs `build` under an exclusive lock on `dir/build.lock` and copies the
/// image it returns to `dir/firmware-PID` (removed when dropped).
///
/// Two runs at once (the QEMU tests run two) each run their own image, and
/// one's QEMU run overlaps the other's build. Copies left by killed runs
/// are removed first ([`remove_stale_images`]).
pub fn own_copy(dir: &Path, build: impl FnOnce() -> Result<PathBuf>) -> Result<PrivateImage> {
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    let lock_path = dir.join("build.lock");
    let lock = std::fs::File::create(&lock_path)
        .with_context(|| format!("{}: cannot create", lock_path.display()))?;
    lock.lock()
        .with_context(|| format!("{}: cannot lock", lock_path.display()))?;
    remove_stale_images(dir);
    let elf = build()?;
    let own = dir.join(format!("firmware-{}", std::process::id()));
    std::fs::copy(&elf, &own)
        .with_context(|| format!("{}: cannot copy to {}", elf.display(), own.display()))?;
    // The lock is released when `lock` is dropped, here.
    Ok(PrivateImage(own))
}

/// Removes from `dir` the copies (`firmware-PID`) of runs whose process is
/// gone: a run killed before it dropped its [`PrivateImage`]. Only where
/// `/proc` tells which processes run; elsewhere they are left.
pub fn remove_stale_images(dir: &Path) {
    let proc = Path::new("/proc");
    if !proc.join("self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        let pid = name
            .to_str()
            .and_then(|n| n.strip_prefix("firmware-"))
            .and_then(|p| p.parse::<u32>().ok());
        if let Some(pid) = pid {
            if !proc.join(pid.to_string()).exists() {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
}

/// A firmware image copied for one run; the copy is removed on drop.
pub struct PrivateImage(PathBuf);

impl PrivateImage {
    /// The copy's path.
    pub fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for PrivateImage {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A copy whose process is gone is removed; this process's copy and
    /// other files stay.
    #[test]
    fn a_killed_runs_image_copy_is_removed() {
        let dir = std::env::temp_dir().join(format!("xtask-images-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let own = dir.join(format!("firmware-{}", std::process::id()));
        // Above Linux's largest process id (2^22).
        let gone = dir.join("firmware-999999999");
        let other = dir.join("build.lock");
        for f in [&own, &gone, &other] {
            std::fs::write(f, b"elf").unwrap();
        }
        remove_stale_images(&dir);
        let proc_tells = Path::new("/proc/self").exists();
        assert_eq!(gone.exists(), !proc_tells);
        assert!(own.exists() && other.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

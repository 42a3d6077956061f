//! `cargo xtask header [--check]`: generates the C header
//! `include/fracbms.h` from `estimator-ffi` with cbindgen (its settings in
//! `estimator-ffi/cbindgen.toml`); `--check` fails when the committed header
//! differs from the generated one (CI runs it).

use std::path::Path;

use anyhow::{bail, Context, Result};

/// Generates the header; with `check`, compares instead of writing.
pub fn header(root: &Path, check: bool) -> Result<()> {
    let krate = root.join("estimator-ffi");
    let config = cbindgen::Config::from_file(krate.join("cbindgen.toml"))
        .map_err(|e| anyhow::anyhow!("estimator-ffi/cbindgen.toml: {e}"))?;
    let bindings = cbindgen::Builder::new()
        .with_crate(&krate)
        .with_config(config)
        .generate()
        .context("cbindgen could not generate the header")?;
    let mut text = Vec::new();
    bindings.write(&mut text);
    let path = root.join("include").join("fracbms.h");
    if check {
        let committed = std::fs::read(&path).unwrap_or_default();
        if committed != text {
            bail!(
                "{}: stale (the C ABI changed); run `cargo xtask header` and commit it",
                path.display()
            );
        }
        eprintln!("{}: up to date", path.display());
        return Ok(());
    }
    std::fs::create_dir_all(root.join("include"))?;
    std::fs::write(&path, text).with_context(|| format!("{}: cannot write", path.display()))?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

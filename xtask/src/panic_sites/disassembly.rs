//! The image as text: `llvm-objdump` found and run, its output split into
//! functions and instructions, and Rust symbol names made readable.

use super::*;

/// `llvm-objdump` of the toolchain (rustup component `llvm-tools`), else
/// the one on PATH.
pub(super) fn objdump() -> Result<PathBuf> {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let query = |args: &[&str]| -> Option<String> {
        let out = Command::new(&rustc)
            .current_dir(root())
            .args(args)
            .output()
            .ok()?;
        out.status
            .success()
            .then(|| String::from_utf8_lossy(&out.stdout).into_owned())
    };
    if let (Some(sysroot), Some(vv)) = (query(&["--print", "sysroot"]), query(&["-vV"])) {
        if let Some(host) = vv.lines().find_map(|l| l.strip_prefix("host: ")) {
            let p = Path::new(sysroot.trim())
                .join("lib/rustlib")
                .join(host.trim())
                .join("bin/llvm-objdump");
            if p.exists() {
                return Ok(p);
            }
        }
    }
    let path = PathBuf::from("llvm-objdump");
    match Command::new(&path).arg("--version").output() {
        Ok(o) if o.status.success() => Ok(path),
        _ => bail!("llvm-objdump not found (rustup component add llvm-tools)"),
    }
}

pub(super) fn disassemble(elf: &Path) -> Result<String> {
    let tool = objdump()?;
    let out = Command::new(&tool)
        .args(["--disassemble", "--demangle", "--no-show-raw-insn"])
        .arg(elf)
        .output()
        .with_context(|| format!("cannot run {}", tool.display()))?;
    if !out.status.success() {
        bail!(
            "{} failed on {}: {}",
            tool.display(),
            elf.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// One instruction of the disassembly.
#[derive(Debug)]
pub(super) struct Insn {
    pub(super) addr: u32,
    pub(super) mnemonic: String,
    pub(super) operands: String,
}

/// A function: the code from one symbol to the next.
#[derive(Debug)]
pub(super) struct Func {
    pub(super) addr: u32,
    /// Demangled, without the hash.
    pub(super) name: String,
    pub(super) insns: Vec<Insn>,
}

/// Splits `llvm-objdump -d -C --no-show-raw-insn` output into functions.
pub(super) fn parse_disassembly(text: &str) -> Vec<Func> {
    let mut funcs: Vec<Func> = Vec::new();
    for line in text.lines() {
        if let Some((addr, name)) = header(line) {
            funcs.push(Func {
                addr,
                name: clean_name(name),
                insns: Vec::new(),
            });
        } else if let (Some(f), Some(i)) = (funcs.last_mut(), insn(line)) {
            f.insns.push(i);
        }
    }
    funcs.sort_by_key(|f| f.addr);
    funcs
}

/// `0001e780 <core::panicking::panic_fmt>:`
pub(super) fn header(line: &str) -> Option<(u32, &str)> {
    let (addr, rest) = line.split_once(' ')?;
    let name = rest.strip_prefix('<')?.strip_suffix(">:")?;
    Some((u32::from_str_radix(addr, 16).ok()?, name))
}

/// `   1e798:      \tbl\t0x1e71e <…> @ imm = #0x1df82`
pub(super) fn insn(line: &str) -> Option<Insn> {
    if !line.starts_with(' ') {
        return None;
    }
    let (addr, rest) = line.trim_start().split_once(':')?;
    let addr = u32::from_str_radix(addr, 16).ok()?;
    // The first field is blank (or a data directive's raw bytes).
    let mut fields = rest.split('\t').skip(1);
    let mnemonic = fields.next()?.trim().to_owned();
    let operands = fields.collect::<Vec<_>>().join("\t");
    Some(Insn {
        addr,
        mnemonic,
        operands,
    })
}

/// A Rust legacy symbol as `llvm-objdump -C` leaves it
/// (`core::slice::_$LT$impl$u20$$u5b$T$u5d$$GT$::copy_within::h5eaf…`)
/// made readable (`core::slice::<impl [T]>::copy_within`).
pub(super) fn clean_name(name: &str) -> String {
    let mut segs: Vec<String> = Vec::new();
    for seg in name.split("::") {
        let seg = seg
            .strip_prefix("_$")
            .map_or(seg.to_owned(), |s| format!("${s}"));
        segs.push(unescape(&seg));
    }
    if segs.last().is_some_and(|s| {
        s.len() == 17 && s.starts_with('h') && s[1..].bytes().all(|b| b.is_ascii_hexdigit())
    }) {
        segs.pop();
    }
    segs.join("::")
}

pub(super) fn unescape(s: &str) -> String {
    let mut out = String::new();
    let mut rest = s;
    while let Some(i) = rest.find(['$', '.']) {
        out.push_str(&rest[..i]);
        let tail = &rest[i..];
        if let Some(t) = tail.strip_prefix("..") {
            out.push_str("::");
            rest = t;
            continue;
        }
        let escape = tail
            .strip_prefix('$')
            .and_then(|t| t.find('$').map(|j| &t[..j]));
        let decoded = escape.and_then(|e| match e {
            "SP" => Some('@'),
            "BP" => Some('*'),
            "RF" => Some('&'),
            "LT" => Some('<'),
            "GT" => Some('>'),
            "LP" => Some('('),
            "RP" => Some(')'),
            "C" => Some(','),
            _ => e
                .strip_prefix('u')
                .and_then(|h| u32::from_str_radix(h, 16).ok())
                .and_then(char::from_u32),
        });
        match (escape, decoded) {
            (Some(e), Some(c)) => {
                out.push(c);
                rest = &tail[e.len() + 2..];
            }
            _ => {
                out.push_str(&tail[..1]);
                rest = &tail[1..];
            }
        }
    }
    out.push_str(rest);
    out
}

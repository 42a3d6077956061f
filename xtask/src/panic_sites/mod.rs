//! `cargo xtask panic-sites [--features F | --elf ELF] [--root NAME]…
//! [--sites] [--deny-reachable]`: the panic call sites of a firmware image
//! and those of them the per-sample step can reach (docs/panic-paths.md).
//!
//! 1. Builds the release firmware (`cargo build --release -p firmware
//!    --target thumbv7em-none-eabihf`, with `--no-default-features
//!    --features F` for another board; `FRACBMS_*` from the environment),
//!    or takes `--elf`.
//! 2. Disassembles it with the toolchain's `llvm-objdump` (rustup component
//!    `llvm-tools`) and splits it into functions at the symbols.
//! 3. A *panic entry* is a function of the panic machinery
//!    (`core::panicking::*`, `core::slice::index::*_fail`,
//!    `core::option::unwrap_failed`, `core::result::unwrap_failed`, …, the
//!    panic handler `rust_begin_unwind`); a *panic call site* is a branch
//!    (`bl`, `b`, conditional or not) from any other function to one.
//! 4. The call graph is that of the direct branch targets (`bl`/`b.w` to
//!    another function), and of code running off a function's end into
//!    the next. The sample step is the function(s) named by `--root`
//!    (default `EstimatorTask<_,_,_>::on_sample`, which is
//!    `#[inline(never)]` for this); a site is *reachable* when its function
//!    is reachable from a root without passing through the panic
//!    machinery. An indirect call (`blx rN`, `bx rN`) in a reachable
//!    function has an unknown target and a trap (`udf`) is a HardFault
//!    rather than a panic: both are counted and listed, so a report with
//!    neither followed every call.
//! 5. Each site's source location is the `core::panic::Location` the call
//!    passes (the file:line:column its panic message would print), read
//!    from the image's flash; a call block shared by several checks lists
//!    the location of each path into it.
//!
//! Prints the totals, the table function → sites (reachable ones marked
//! `*`), with `--sites` every site, and as the last line one JSON object
//! `{"elf", "roots", "sites", "functions", "reachable_sites",
//! "reachable_functions", "indirect_calls", "traps"}`. `--deny-reachable`
//! exits with status 1 when `reachable_sites` or `indirect_calls` is not 0.

use super::{root, target_dir};
use anyhow::{bail, Context, Result};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

mod disassembly;
mod elf;

use disassembly::*;
use elf::Elf;

const TARGET: &str = "thumbv7em-none-eabihf";
/// The firmware's per-sample step (`firmware/src/task.rs`).
const DEFAULT_ROOT: &str = "EstimatorTask<_,_,_>::on_sample";

#[derive(clap::Args)]
pub struct PanicSitesArgs {
    /// Build the firmware with these features instead of the default
    /// (QEMU) board, e.g. `board-stm32l452` or `stm32l452-bq769x0`
    /// (`--no-default-features --features F`).
    #[arg(long)]
    features: Option<String>,
    /// Analyse this image instead of building the firmware (e.g. the C
    /// example `target/c-demo/fracbms-c-demo.elf` with `--root
    /// fracbms_cell_push`).
    #[arg(long, conflicts_with = "features")]
    elf: Option<PathBuf>,
    /// The per-sample entry point: a demangled function name, or its last
    /// path segments (`on_sample`, `fracbms_cell_push`); repeat for
    /// several. Default: `EstimatorTask<_,_,_>::on_sample`.
    #[arg(long = "root")]
    roots: Vec<String>,
    /// List every site: address, panic, source location, function
    /// (reachable ones first, marked `*`).
    #[arg(long)]
    sites: bool,
    /// Exit with status 1 when a panic call site (or an indirect call) is
    /// reachable from the sample step.
    #[arg(long)]
    deny_reachable: bool,
}

pub fn run(a: &PanicSitesArgs) -> Result<()> {
    let elf = match &a.elf {
        Some(p) => p.clone(),
        None => build(a.features.as_deref())?,
    };
    let bytes = std::fs::read(&elf).with_context(|| format!("{}: cannot read", elf.display()))?;
    let image =
        Elf::parse(&bytes).with_context(|| format!("{}: not an ELF32 image", elf.display()))?;
    let text = disassemble(&elf)?;
    let funcs = parse_disassembly(&text);
    if funcs.is_empty() {
        bail!("{}: no functions in the disassembly", elf.display());
    }
    let roots: Vec<String> = if a.roots.is_empty() {
        vec![DEFAULT_ROOT.to_owned()]
    } else {
        a.roots.clone()
    };
    let r = analyse(&funcs, &image, &roots)?;
    report(&r, &funcs, a.sites);
    println!(
        "{}",
        serde_json::json!({
            "elf": elf.display().to_string(),
            "roots": r.roots.iter().map(|&i| funcs[i].name.clone()).collect::<Vec<_>>(),
            "sites": r.sites.len(),
            "functions": r.by_function().len(),
            "reachable_sites": r.reachable_sites().count(),
            "reachable_functions": r.by_function().keys().filter(|f| r.reachable.contains(f)).count(),
            "indirect_calls": r.indirect.len(),
            "traps": r.traps.len(),
        })
    );
    if a.deny_reachable {
        let n = r.reachable_sites().count();
        if n > 0 || !r.indirect.is_empty() {
            bail!(
                "{n} panic call site(s) and {} indirect call(s) reachable from the sample step",
                r.indirect.len()
            );
        }
    }
    Ok(())
}

/// Builds the release firmware; returns the image's path.
fn build(features: Option<&str>) -> Result<PathBuf> {
    let mut cargo = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    cargo.current_dir(root()).args([
        "build",
        "--quiet",
        "--release",
        "-p",
        "firmware",
        "--target",
        TARGET,
    ]);
    if let Some(f) = features {
        cargo.args(["--no-default-features", "--features", f]);
    }
    let out = cargo
        .stderr(Stdio::piped())
        .output()
        .context("cannot run cargo")?;
    if !out.status.success() {
        eprint!("{}", String::from_utf8_lossy(&out.stderr));
        bail!("the firmware build failed (see above)");
    }
    Ok(target_dir().join(TARGET).join("release/firmware"))
}

/// A function of the panic machinery (calls into it are the sites).
fn is_panic_entry(name: &str) -> bool {
    let last = name.rsplit("::").next().unwrap_or(name);
    name.ends_with("rust_begin_unwind")
        || name == "rust_panic"
        || ((name.starts_with("core::") || name.starts_with("std::"))
            && (name.contains("panic") || last.ends_with("_fail") || last.ends_with("_failed")))
}

const CONDITIONS: [&str; 16] = [
    "eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le",
];

/// What a branch instruction is.
#[derive(Debug, PartialEq)]
enum Branch {
    /// `b`/`bl` (conditional or not) to this address.
    Direct(u32),
    /// `blx rN`, `bx rN` (not `lr`), `mov pc, rN`, `ldr pc, [rN…]`.
    Indirect,
}

fn branch(i: &Insn) -> Option<Branch> {
    let m = i.mnemonic.trim_end_matches(".w").trim_end_matches(".n");
    let cond = |s: &str| s.is_empty() || CONDITIONS.contains(&s);
    let first = i.operands.split_whitespace().next().unwrap_or("");
    if let Some(c) = m.strip_prefix("bx").or_else(|| m.strip_prefix("blx")) {
        return (cond(c) && first != "lr").then_some(Branch::Indirect);
    }
    if let Some(c) = m.strip_prefix('b') {
        let c = c.strip_prefix('l').filter(|c| cond(c)).unwrap_or(c);
        if !cond(c) {
            return None;
        }
        let hex = first.trim_start_matches("0x");
        return u32::from_str_radix(hex, 16).ok().map(Branch::Direct);
    }
    let ops = i.operands.replace(' ', "");
    if (m == "mov" && ops.starts_with("pc,")) || (m == "ldr" && ops.starts_with("pc,[r")) {
        return Some(Branch::Indirect);
    }
    None
}

/// One panic call site.
#[derive(Debug)]
struct Site {
    addr: u32,
    func: usize,
    /// The panic entry called (its last path segment).
    panic: String,
    /// `file:line:col` of the `Location` passed, if found.
    location: Option<String>,
    /// Constant arguments in r0, r1 (index and length of a bounds check).
    args: [Option<u32>; 2],
}

struct Analysis {
    sites: Vec<Site>,
    roots: Vec<usize>,
    reachable: BTreeSet<usize>,
    /// (function, address) of the indirect calls of reachable functions.
    indirect: Vec<(usize, u32)>,
    /// (function, address) of the traps (`udf`: a HardFault, not a panic)
    /// in reachable functions.
    traps: Vec<(usize, u32)>,
}

impl Analysis {
    fn reachable_sites(&self) -> impl Iterator<Item = &Site> {
        self.sites
            .iter()
            .filter(|s| self.reachable.contains(&s.func))
    }

    /// Sites per function.
    fn by_function(&self) -> BTreeMap<usize, usize> {
        let mut m = BTreeMap::new();
        for s in &self.sites {
            *m.entry(s.func).or_default() += 1;
        }
        m
    }
}

/// The function containing `addr`.
fn containing(funcs: &[Func], addr: u32) -> Option<usize> {
    let k = funcs.partition_point(|f| f.addr <= addr);
    k.checked_sub(1)
}

/// Does `name` match a root pattern: the whole name or its last segments.
fn matches_root(name: &str, pattern: &str) -> bool {
    name == pattern || name.ends_with(&format!("::{pattern}"))
}

/// The target of `cbz`/`cbnz` (always inside the function).
fn compare_branch_target(i: &Insn) -> Option<u32> {
    if !i.mnemonic.starts_with("cb") {
        return None;
    }
    let t = i.operands.split(',').nth(1)?.split_whitespace().next()?;
    u32::from_str_radix(t.trim_start_matches("0x"), 16).ok()
}

/// Control leaves the instruction's block after it (or it is data).
fn ends_block(i: &Insn) -> bool {
    let m = i.mnemonic.as_str();
    let ops = i.operands.replace(' ', "");
    branch(i).is_some()
        || m.starts_with("bx")
        || m.starts_with("cb")
        || m.starts_with("tb")
        || m.starts_with('.')
        || (m.starts_with("pop") && ops.contains("pc"))
        || (m.starts_with("ldr") && ops.starts_with("pc,"))
}

fn analyse(funcs: &[Func], image: &Elf, roots: &[String]) -> Result<Analysis> {
    let entry: Vec<bool> = funcs.iter().map(|f| is_panic_entry(&f.name)).collect();
    let mut sites = Vec::new();
    let mut calls: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); funcs.len()];
    let mut indirect_of: Vec<Vec<u32>> = vec![Vec::new(); funcs.len()];
    let mut traps_of: Vec<Vec<u32>> = vec![Vec::new(); funcs.len()];
    for (k, f) in funcs.iter().enumerate() {
        if entry[k] {
            continue;
        }
        // Block starts: the targets of the function's own branches.
        let mut labels = Labels::new();
        for (n, i) in f.insns.iter().enumerate() {
            let target = match branch(i) {
                Some(Branch::Direct(t)) => Some(t),
                _ => compare_branch_target(i),
            };
            if let Some(t) = target {
                labels.entry(t).or_default().push(n);
            }
        }
        for (n, i) in f.insns.iter().enumerate() {
            if i.mnemonic.starts_with("udf") {
                traps_of[k].push(i.addr);
            }
            match branch(i) {
                Some(Branch::Indirect) => indirect_of[k].push(i.addr),
                Some(Branch::Direct(t)) => {
                    let Some(g) = containing(funcs, t).filter(|&g| g != k) else {
                        continue;
                    };
                    if entry[g] {
                        let (location, args) = arguments(&f.insns, n, &labels, image);
                        let name = &funcs[g].name;
                        sites.push(Site {
                            addr: i.addr,
                            func: k,
                            panic: name.rsplit("::").next().unwrap_or(name).to_owned(),
                            location,
                            args,
                        });
                    } else {
                        calls[k].insert(g);
                    }
                }
                None => {}
            }
        }
        // Code that runs off its end continues in the next function: an
        // edge too, unless the last instruction returns, jumps, or calls
        // the panic machinery (which does not return).
        let last = f
            .insns
            .iter()
            .rev()
            .find(|i| !(i.mnemonic.starts_with('.') || i.mnemonic == "nop"));
        let stops = last.is_some_and(|i| {
            let panics = matches!(branch(i), Some(Branch::Direct(t))
                if containing(funcs, t).is_some_and(|g| entry[g]));
            (ends_block(i) && !i.mnemonic.starts_with("bl")) || panics
        });
        if !stops && k + 1 < funcs.len() {
            calls[k].insert(k + 1);
        }
    }
    let mut root_ids = Vec::new();
    for p in roots {
        let found: Vec<usize> = (0..funcs.len())
            .filter(|&k| matches_root(&funcs[k].name, p))
            .collect();
        if found.is_empty() {
            bail!("no function `{p}` in the image (not linked, or inlined: a root must be #[inline(never)])");
        }
        root_ids.extend(found);
    }
    let mut reachable = BTreeSet::new();
    let mut stack = root_ids.clone();
    while let Some(k) = stack.pop() {
        if !entry[k] && reachable.insert(k) {
            stack.extend(calls[k].iter().copied());
        }
    }
    let of = |v: &[Vec<u32>]| -> Vec<(usize, u32)> {
        reachable
            .iter()
            .flat_map(|&k| v[k].iter().map(move |&a| (k, a)))
            .collect()
    };
    Ok(Analysis {
        sites,
        roots: root_ids,
        indirect: of(&indirect_of),
        traps: of(&traps_of),
        reachable,
    })
}

/// What the instructions before a call put in r0–r3, found scanning back.
#[derive(Clone, Copy, Default)]
struct Regs {
    /// `movw` (low half), `movt` (high half), or a whole value.
    lo: [Option<u32>; 4],
    hi: [Option<u32>; 4],
    whole: [Option<u32>; 4],
    /// The register's value is decided (by a later instruction).
    written: [bool; 4],
}

impl Regs {
    fn value(&self, r: usize) -> Option<u32> {
        match (self.lo[r], self.hi[r], self.whole[r]) {
            (Some(l), h, _) => Some(l | h.unwrap_or(0) << 16),
            (None, _, w) => w,
        }
    }

    /// Accounts for `i`, met scanning back.
    fn step(&mut self, i: &Insn, image: &Elf) {
        let m = i.mnemonic.trim_end_matches(".w");
        // Instructions that write several core registers, or none.
        let several = [
            "ldrd", "ldm", "pop", "umull", "smull", "umlal", "smlal", "vmov",
        ]
        .iter()
        .any(|p| m.starts_with(p));
        let none = [
            "st", "push", "cmp", "cmn", "tst", "teq", "vst", "vcmp", "it", "nop",
        ]
        .iter()
        .any(|p| m.starts_with(p));
        if several {
            for t in i.operands.split(|c: char| !c.is_ascii_alphanumeric()) {
                if let Some(r) = t.strip_prefix('r').and_then(|r| r.parse::<usize>().ok()) {
                    if let Some(w) = self.written.get_mut(r) {
                        *w = true;
                    }
                }
            }
        }
        let mut ops = i.operands.split(',').map(str::trim);
        let Some(reg) = ops
            .next()
            .and_then(|r| r.strip_prefix('r'))
            .and_then(|r| r.parse::<usize>().ok())
            .filter(|&r| r < 4)
        else {
            return;
        };
        let imm = ops.next().and_then(immediate);
        match m {
            "movt" => {
                if !self.written[reg] && self.hi[reg].is_none() {
                    self.hi[reg] = imm;
                }
            }
            _ if self.written[reg] => {}
            "movw" => {
                self.lo[reg] = imm;
                self.written[reg] = true;
            }
            "mov" | "movs" => {
                self.whole[reg] = imm;
                self.written[reg] = true;
            }
            "ldr" => {
                // `ldr r2, [pc, #0x38]  @ 0x440 <…>`: the literal's address.
                self.whole[reg] = i
                    .operands
                    .split_once('@')
                    .and_then(|(_, a)| a.split_whitespace().next())
                    .and_then(|a| u32::from_str_radix(a.trim_start_matches("0x"), 16).ok())
                    .and_then(|a| image.u32_at(a));
                self.written[reg] = true;
            }
            _ if none || several => {}
            _ => self.written[reg] = true,
        }
    }

    /// The `Location` among r0–r3 (r3 first: it is the last argument).
    fn location(&self, image: &Elf) -> Option<String> {
        (0..4)
            .rev()
            .find_map(|r| self.value(r).and_then(|a| image.location(a)))
    }
}

/// The function's branch targets, each with the indices of the
/// instructions that branch there.
type Labels = BTreeMap<u32, Vec<usize>>;

/// Scans back from `insns[end]` (exclusive) to the start of its block,
/// at most `budget` instructions; a block shared by several paths (a
/// label) is followed into each predecessor, once. Collects the
/// `Location`s found (one per path).
fn scan_back(
    insns: &[Insn],
    end: usize,
    mut regs: Regs,
    labels: &Labels,
    follow: bool,
    image: &Elf,
    found: &mut BTreeSet<Option<String>>,
) {
    let mut k = end;
    while k > 0 && end - k < 16 {
        let i = &insns[k - 1];
        if ends_block(i) {
            break;
        }
        regs.step(i, image);
        k -= 1;
        if let Some(preds) = labels.get(&i.addr) {
            if regs.location(image).is_none() && follow {
                for &p in preds {
                    scan_back(insns, p, regs, labels, false, image, found);
                }
                // And the path falling through into the label.
                if k > 0 && !ends_block(&insns[k - 1]) {
                    scan_back(insns, k, regs, labels, false, image, found);
                }
                return;
            }
            break;
        }
    }
    found.insert(regs.location(image));
}

/// The `Location` the call `insns[n]` passes (`file:line:col`; several
/// joined with ` | ` when paths share the call), and its constant r0, r1
/// (index and length of a bounds check).
fn arguments(
    insns: &[Insn],
    n: usize,
    labels: &Labels,
    image: &Elf,
) -> (Option<String>, [Option<u32>; 2]) {
    let mut regs = Regs::default();
    let mut k = n;
    // The arguments: in the call's own block.
    while k > 0 && n - k < 16 {
        let i = &insns[k - 1];
        if ends_block(i) || labels.contains_key(&i.addr) {
            if !ends_block(i) {
                regs.step(i, image);
            }
            break;
        }
        regs.step(i, image);
        k -= 1;
    }
    let args = [regs.value(0), regs.value(1)];
    let mut found = BTreeSet::new();
    scan_back(insns, n, Regs::default(), labels, true, image, &mut found);
    let known: Vec<String> = found.iter().flatten().cloned().collect();
    let location = if known.is_empty() || found.contains(&None) {
        None
    } else {
        Some(known.join(" | "))
    };
    (location, args)
}

/// `#0x13f4`, `#64`
fn immediate(s: &str) -> Option<u32> {
    let s = s.strip_prefix('#')?;
    match s.strip_prefix("0x") {
        Some(h) => u32::from_str_radix(h, 16).ok(),
        None => s.parse::<i64>().ok().map(|v| v as u32),
    }
}

fn report(r: &Analysis, funcs: &[Func], sites: bool) {
    let by_function = r.by_function();
    let reachable = r.reachable_sites().count();
    println!(
        "panic call sites: {} in {} functions; reachable from the sample step ({}): {} in {} functions",
        r.sites.len(),
        by_function.len(),
        r.roots
            .iter()
            .map(|&k| funcs[k].name.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        reachable,
        by_function
            .keys()
            .filter(|f| r.reachable.contains(f))
            .count()
    );
    let mut rows: Vec<(usize, usize)> = by_function.into_iter().collect();
    rows.sort_by_key(|&(f, n)| (!r.reachable.contains(&f), std::cmp::Reverse(n), f));
    println!("reachable  sites  function");
    for (f, n) in rows {
        let mark = if r.reachable.contains(&f) { "*" } else { " " };
        println!("{mark:<9}  {n:>5}  {}", funcs[f].name);
    }
    for &(f, a) in &r.indirect {
        println!(
            "indirect call at {a:#010x} in {} (target unknown)",
            funcs[f].name
        );
    }
    for &(f, a) in &r.traps {
        println!("trap (udf) at {a:#010x} in {}", funcs[f].name);
    }
    if sites {
        println!("sites (reachable ones marked *):");
        let mut list: Vec<&Site> = r.sites.iter().collect();
        list.sort_by_key(|s| (!r.reachable.contains(&s.func), &s.location, s.addr));
        for s in list {
            let args = match (s.panic.as_str(), s.args) {
                ("panic_bounds_check", [i, n]) => format!(
                    " index {} len {}",
                    i.map_or("?".into(), |v| v.to_string()),
                    n.map_or("?".into(), |v| v.to_string())
                ),
                _ => String::new(),
            };
            let mark = if r.reachable.contains(&s.func) {
                '*'
            } else {
                ' '
            };
            println!(
                "{mark} {:#010x}  {:<20} {}{args}  in {}",
                s.addr,
                s.panic,
                s.location.as_deref().unwrap_or("(location unknown)"),
                funcs[s.func].name
            );
        }
    }
}
#[cfg(test)]
mod tests;

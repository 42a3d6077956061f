//! A stable-Rust fuzz and property harness (issue 21, "Fuzzing";
//! docs/fuzzing.md).
//!
//! Each [`Target`] runs one *case* from a seeded RNG: it generates an
//! arbitrary input (bytes of a CSV file, settings and a sample stream, a
//! window and estimator settings), runs the code under test on it and checks
//! its invariants. A case fails when the code panics (caught with
//! [`std::panic::catch_unwind`], the panic hook silenced while fuzzing) or
//! an invariant breaks (a published estimate that is not finite, a sample
//! lost, an error for valid input, an error message that does not name its
//! file, …). A case is replayed from `(target, seed, case)` alone:
//! [`case_rng`] derives its RNG from the three.
//!
//! The `fuzz` binary of this crate runs N cases per target and counts the
//! failures; `tests/tests/fuzz.rs` runs a fixed number from a fixed seed in
//! CI.

pub mod cell;
pub mod csv;
pub mod gen;
pub mod hammerstein;
pub mod pack;
pub mod settings;
pub mod snapshot;

use rand::SeedableRng;
use std::cell::{Cell, RefCell};
use std::collections::BTreeMap;
use std::panic::{self, AssertUnwindSafe};
use std::sync::Once;

/// The RNG every case draws from.
pub type Rng = rand_chacha::ChaCha8Rng;

/// What a case returns: `Err` describes a broken invariant.
pub type Outcome = Result<(), String>;

/// A fuzz target.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Target {
    /// `fracbms_host::io`'s CSV readers on arbitrary bytes ([`csv::case`]).
    Csv,
    /// The single-cell online estimator ([`cell::case`]).
    Cell,
    /// The pack estimator ([`pack::case`]).
    Pack,
    /// 2S-OP-GI, KT-2S-GI and the prediction-error refinement
    /// ([`hammerstein::case`]).
    Hammerstein,
    /// The restore of a pack's snapshot, mutated or not
    /// ([`snapshot::case`]).
    Snapshot,
}

impl Target {
    /// Every target, in the order the `fuzz` binary runs them.
    pub const ALL: [Target; 5] = [
        Target::Csv,
        Target::Cell,
        Target::Pack,
        Target::Hammerstein,
        Target::Snapshot,
    ];

    /// The target's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Target::Csv => "csv",
            Target::Cell => "cell",
            Target::Pack => "pack",
            Target::Hammerstein => "hammerstein",
            Target::Snapshot => "snapshot",
        }
    }

    /// The target of a name (`None` for an unknown one).
    pub fn parse(name: &str) -> Option<Target> {
        Target::ALL.into_iter().find(|t| t.name() == name)
    }

    /// Runs one case on `rng` (panics are not caught here: see
    /// [`run_case`]).
    pub fn case(self, rng: &mut Rng) -> Outcome {
        match self {
            Target::Csv => csv::case(rng),
            Target::Cell => cell::case(rng),
            Target::Pack => pack::case(rng),
            Target::Hammerstein => hammerstein::case(rng),
            Target::Snapshot => snapshot::case(rng),
        }
    }
}

/// When true (the default), the generators steer around the open issues
/// that the fuzzing found and that wait for a fix outside the tests crate
/// (each has an `#[ignore]`d regression test in `tests/tests/fuzz.rs`), so
/// that a run reports what is new. The `fuzz` binary's `--known-issues`
/// sets it false.
pub static AVOID_KNOWN_ISSUES: std::sync::atomic::AtomicBool =
    std::sync::atomic::AtomicBool::new(true);

/// True while the generators avoid the known open issues.
pub fn avoid_known_issues() -> bool {
    AVOID_KNOWN_ISSUES.load(std::sync::atomic::Ordering::Relaxed)
}

/// SplitMix64's finalizer: a bijective mix of 64 bits.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The RNG of case `case` of `target` in the run seeded `seed`: a case is
/// replayed from these three numbers alone, whatever ran before it.
pub fn case_rng(target: Target, seed: u64, case: u64) -> Rng {
    let t = target as u64 + 1;
    Rng::seed_from_u64(mix(mix(seed ^ t.wrapping_mul(0x5851_f42d_4c95_7f2d)) ^ case))
}

thread_local! {
    /// True while this thread runs a case: its panics are recorded, not
    /// printed.
    static FUZZING: Cell<bool> = const { Cell::new(false) };
    /// The message and location of the last panic on this thread while
    /// fuzzing.
    static LAST_PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

thread_local! {
    /// What the cases of this thread exercised ([`note`]).
    static NOTES: RefCell<BTreeMap<&'static str, u64>> = const { RefCell::new(BTreeMap::new()) };
}

/// Counts one occurrence of `what` (a path through the code under test,
/// e.g. "cell: an estimate published"): the `fuzz` binary's `--stats`
/// shows what the cases reached.
pub fn note(what: &'static str) {
    NOTES.with(|n| *n.borrow_mut().entry(what).or_default() += 1);
}

/// The counts of this thread's [`note`]s since the last call.
pub fn take_notes() -> BTreeMap<&'static str, u64> {
    NOTES.with(|n| std::mem::take(&mut *n.borrow_mut()))
}

/// Installs (once per process) a panic hook that records the panics of a
/// thread running a case instead of printing them; other panics go to the
/// hook that was there before (so a failing `#[test]` still reports).
pub fn install_panic_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if FUZZING.with(Cell::get) {
                LAST_PANIC.with(|p| *p.borrow_mut() = Some(info.to_string()));
            } else {
                previous(info);
            }
        }));
    });
}

/// Runs case `case` of `target` (run seed `seed`), catching a panic:
/// `Err` describes the failure (the panic message and location, or the
/// broken invariant).
pub fn run_case(target: Target, seed: u64, case: u64) -> Outcome {
    install_panic_hook();
    let mut rng = case_rng(target, seed, case);
    FUZZING.with(|f| f.set(true));
    let r = panic::catch_unwind(AssertUnwindSafe(|| target.case(&mut rng)));
    FUZZING.with(|f| f.set(false));
    match r {
        Ok(outcome) => outcome,
        Err(payload) => Err(LAST_PANIC
            .with(|p| p.borrow_mut().take())
            .unwrap_or_else(|| {
                let msg = payload
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| payload.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "(no message)".into());
                format!("panicked: {msg}")
            })),
    }
}

/// One failed case.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Failure {
    /// Its target.
    pub target: Target,
    /// The run's seed.
    pub seed: u64,
    /// The case index.
    pub case: u64,
    /// What went wrong.
    pub message: String,
}

impl Failure {
    /// `target:seed:case`, the `--replay` argument of the `fuzz` binary.
    pub fn replay(&self) -> String {
        format!("{}:{}:{}", self.target.name(), self.seed, self.case)
    }
}

/// What a run of cases did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Summary {
    /// Cases run.
    pub cases: u64,
    /// The failed ones.
    pub failures: Vec<Failure>,
    /// What the cases exercised ([`note`]).
    pub notes: BTreeMap<&'static str, u64>,
}

impl Summary {
    /// Adds another run's counts to this one.
    pub fn merge(&mut self, other: Summary) {
        self.cases += other.cases;
        self.failures.extend(other.failures);
        for (k, v) in other.notes {
            *self.notes.entry(k).or_default() += v;
        }
    }
}

/// Runs cases `cases` (a range of indices) of `target` with run seed
/// `seed` on this thread; `on_failure` hears each failure as it happens.
pub fn run_cases(
    target: Target,
    seed: u64,
    cases: std::ops::Range<u64>,
    mut on_failure: impl FnMut(&Failure),
) -> Summary {
    let mut s = Summary::default();
    for case in cases {
        s.cases += 1;
        if let Err(message) = run_case(target, seed, case) {
            let f = Failure {
                target,
                seed,
                case,
                message,
            };
            on_failure(&f);
            s.failures.push(f);
        }
    }
    s.notes = take_notes();
    s
}

/// Runs the first `n` cases of `target` from `seed` and panics with every
/// failure's replay and message when any failed (the CI tests' check).
pub fn assert_cases_pass(target: Target, seed: u64, n: u64) {
    let s = run_cases(target, seed, 0..n, |_| {});
    assert_eq!(s.cases, n);
    if !s.failures.is_empty() {
        let lines: Vec<String> = s
            .failures
            .iter()
            .take(10)
            .map(|f| format!("  --replay {}: {}", f.replay(), f.message))
            .collect();
        panic!(
            "{}: {} cases run, {} failed:\n{}",
            target.name(),
            s.cases,
            s.failures.len(),
            lines.join("\n")
        );
    }
}

//! The fuzz/property harness's command (docs/fuzzing.md).
//!
//! ```text
//! fuzz [--cases N | --seconds S] [--target csv|cell|pack|hammerstein|snapshot|all[,…]]
//!      [--seed S] [--start K] [--threads J] [--timeout SECS] [--stats]
//!      [--known-issues]
//! fuzz --replay TARGET:SEED:CASE
//! ```
//!
//! Runs cases `K … K+N−1` of each target (or as many as fit in `S` seconds
//! per target) from run seed `S`, prints one line `target: N cases run, F
//! failed` per target and a last line `N cases run, F failed`, and exits
//! with status 1 when any case failed (2 when a case runs longer than the
//! timeout, which it reports with its replay). Every failure is printed with
//! the `--replay` argument that runs it again alone, and the failures are
//! grouped by kind. `--stats` also prints what the cases exercised (the
//! harness's `note` counts: estimates published, errors returned, …).
//! `--known-issues` stops steering around the open issues the fuzzing
//! found ([`fuzz::AVOID_KNOWN_ISSUES`]), to check whether they are fixed.

use fracbms_tests::fuzz::{self, Failure, Summary, Target};
use std::process::ExitCode;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

const USAGE: &str =
    "usage: fuzz [--cases N | --seconds S] [--target csv|cell|pack|hammerstein|snapshot|all[,...]] \
[--seed S] [--start K] [--threads J] [--timeout SECS] [--stats] [--known-issues]\n       fuzz --replay TARGET:SEED:CASE";

/// Failures printed per target (all are counted).
const SHOWN: usize = 20;

struct Args {
    targets: Vec<Target>,
    cases: u64,
    seconds: Option<f64>,
    seed: u64,
    start: u64,
    threads: usize,
    timeout: u64,
    stats: bool,
    replay: Option<(Target, u64, u64)>,
}

fn parse() -> Result<Args, String> {
    let mut a = Args {
        targets: Target::ALL.to_vec(),
        cases: 1000,
        seconds: None,
        seed: 1,
        start: 0,
        threads: 1,
        timeout: 120,
        stats: false,
        replay: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "-h" || flag == "--help" {
            return Err(String::new());
        }
        if flag == "--stats" {
            a.stats = true;
            continue;
        }
        if flag == "--known-issues" {
            fuzz::AVOID_KNOWN_ISSUES.store(false, Ordering::Relaxed);
            continue;
        }
        let value = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let num = |v: &str| {
            v.replace('_', "")
                .parse::<u64>()
                .map_err(|_| format!("{flag}: `{v}` is not a whole number"))
        };
        match flag.as_str() {
            "--cases" => a.cases = num(&value)?,
            "--seconds" => {
                a.seconds = Some(
                    value
                        .parse()
                        .map_err(|_| format!("--seconds: `{value}` is not a number"))?,
                )
            }
            "--seed" => a.seed = num(&value)?,
            "--start" => a.start = num(&value)?,
            "--threads" => a.threads = (num(&value)? as usize).max(1),
            "--timeout" => a.timeout = num(&value)?.max(1),
            "--target" => {
                a.targets = Vec::new();
                for name in value.split(',') {
                    if name == "all" {
                        a.targets.extend(Target::ALL);
                    } else {
                        a.targets.push(
                            Target::parse(name)
                                .ok_or_else(|| format!("--target: unknown target `{name}`"))?,
                        );
                    }
                }
            }
            "--replay" => {
                let parts: Vec<&str> = value.split(':').collect();
                let [t, s, c] = parts[..] else {
                    return Err(format!("--replay: `{value}` is not TARGET:SEED:CASE"));
                };
                let t =
                    Target::parse(t).ok_or_else(|| format!("--replay: unknown target `{t}`"))?;
                a.replay = Some((t, num(s)?, num(c)?));
            }
            _ => return Err(format!("unknown option `{flag}`")),
        }
    }
    Ok(a)
}

/// What each worker is running: the case index + 1 (0: none) and when it
/// started (ms since the run's start).
struct Watch {
    case: Vec<AtomicU64>,
    since: Vec<AtomicU64>,
    t0: Instant,
}

fn main() -> ExitCode {
    let args = match parse() {
        Ok(a) => a,
        Err(e) => {
            if !e.is_empty() {
                eprintln!("fuzz: {e}");
            }
            eprintln!("{USAGE}");
            return ExitCode::from(if e.is_empty() { 0 } else { 2 });
        }
    };
    if let Some((t, seed, case)) = args.replay {
        let f = Failure {
            target: t,
            seed,
            case,
            message: String::new(),
        };
        return match fuzz::run_case(t, seed, case) {
            Ok(()) => {
                println!("{}: ok", f.replay());
                ExitCode::SUCCESS
            }
            Err(m) => {
                println!("{}: FAILED: {m}", f.replay());
                ExitCode::from(1)
            }
        };
    }
    fuzz::install_panic_hook();
    let mut total = Summary::default();
    let mut lines = Vec::new();
    for &target in &args.targets {
        let t0 = Instant::now();
        let s = run_target(&args, target);
        let secs = t0.elapsed().as_secs_f64();
        eprintln!(
            "{}: {:.1} s, {:.0} cases/s (seed {}, cases {}..{})",
            target.name(),
            secs,
            s.cases as f64 / secs.max(1e-9),
            args.seed,
            args.start,
            args.start + s.cases
        );
        let line = format!(
            "{}: {} cases run, {} failed",
            target.name(),
            s.cases,
            s.failures.len()
        );
        println!("{line}");
        print_kinds(&s.failures);
        if args.stats {
            for (k, v) in &s.notes {
                println!("  {v:>12}  {k}");
            }
        }
        lines.push(line);
        total.merge(s);
    }
    if args.targets.len() > 1 {
        for l in &lines {
            println!("{l}");
        }
    }
    println!("{} cases run, {} failed", total.cases, total.failures.len());
    if total.failures.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

/// A failure's kind: its first line with numbers and quoted text blanked
/// (so that failures of one cause group together).
fn kind(message: &str) -> String {
    let first = message.lines().next().unwrap_or("");
    let mut out = String::new();
    let mut quoted = false;
    for c in first.chars() {
        match c {
            '`' => {
                quoted = !quoted;
                out.push(c);
            }
            _ if quoted => {}
            '0'..='9' => {
                if !out.ends_with('#') {
                    out.push('#');
                }
            }
            _ => out.push(c),
        }
    }
    out.chars().take(160).collect()
}

/// Prints the failures grouped by [`kind`], with one replay each.
fn print_kinds(failures: &[Failure]) {
    let mut kinds: Vec<(String, usize, &Failure)> = Vec::new();
    for f in failures {
        let k = kind(&f.message);
        match kinds.iter_mut().find(|(kk, _, _)| *kk == k) {
            Some(e) => e.1 += 1,
            None => kinds.push((k, 1, f)),
        }
    }
    kinds.sort_by_key(|k| std::cmp::Reverse(k.1));
    for (k, n, f) in kinds {
        println!("  {n} × {k}  (e.g. --replay {})", f.replay());
    }
}

/// Runs one target's cases on `args.threads` threads.
fn run_target(args: &Args, target: Target) -> Summary {
    let threads = args.threads;
    let watch = Arc::new(Watch {
        case: (0..threads).map(|_| AtomicU64::new(0)).collect(),
        since: (0..threads).map(|_| AtomicU64::new(0)).collect(),
        t0: Instant::now(),
    });
    let deadline = args
        .seconds
        .map(|s| Instant::now() + Duration::from_secs_f64(s));
    let done = Arc::new(AtomicU64::new(0));
    let dog = {
        let (watch, done, timeout, seed) = (watch.clone(), done.clone(), args.timeout, args.seed);
        std::thread::spawn(move || {
            while done.load(Ordering::Relaxed) == 0 {
                std::thread::sleep(Duration::from_millis(200));
                let now = watch.t0.elapsed().as_millis() as u64;
                for (c, s) in watch.case.iter().zip(&watch.since) {
                    let case = c.load(Ordering::Relaxed);
                    if case > 0 && now.saturating_sub(s.load(Ordering::Relaxed)) > timeout * 1000 {
                        println!(
                            "HANG {} case {}: --replay {}:{}:{} ran more than {timeout} s",
                            target.name(),
                            case - 1,
                            target.name(),
                            seed,
                            case - 1
                        );
                        println!("1 cases run, 1 failed");
                        std::process::exit(2);
                    }
                }
            }
        })
    };
    let shown = AtomicU64::new(0);
    let summaries: Vec<Summary> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|j| {
                let (watch, shown) = (&watch, &shown);
                scope.spawn(move || {
                    let mut s = Summary::default();
                    let mut case = args.start + j as u64;
                    loop {
                        let more = match deadline {
                            Some(d) => Instant::now() < d,
                            None => case < args.start + args.cases,
                        };
                        if !more {
                            break;
                        }
                        watch.since[j]
                            .store(watch.t0.elapsed().as_millis() as u64, Ordering::Relaxed);
                        watch.case[j].store(case + 1, Ordering::Relaxed);
                        let r = fuzz::run_case(target, args.seed, case);
                        watch.case[j].store(0, Ordering::Relaxed);
                        s.cases += 1;
                        if let Err(message) = r {
                            let f = Failure {
                                target,
                                seed: args.seed,
                                case,
                                message,
                            };
                            if (shown.fetch_add(1, Ordering::Relaxed) as usize) < SHOWN {
                                println!("FAIL --replay {}: {}", f.replay(), f.message);
                            }
                            s.failures.push(f);
                        }
                        case += threads as u64;
                    }
                    s.notes = fuzz::take_notes();
                    s
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("a worker panicked"))
            .collect()
    });
    done.store(1, Ordering::Relaxed);
    let _ = dog.join();
    let mut all = Summary::default();
    for s in summaries {
        all.merge(s);
    }
    all.failures.sort_by_key(|f| f.case);
    all
}

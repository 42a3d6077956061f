//! MATLAB MAT-files (level 5, as `save -v7` writes them, compressed or
//! not): a struct of equal-length column vectors, as cycler logs saved
//! from MATLAB are (`meas.Time`, `meas.Current`, `meas.Voltage`, …).
//!
//! It owns finding the struct (the table) and its columns; the columns are
//! then chosen by their field names exactly as a CSV header's cells are
//! ([`super::headers::choose`]) and the rows go through the same
//! [`super::finish`]. Parsing is `matrw`'s; it must not touch the rows'
//! meaning.

use super::headers::{self, ColumnChoice};
use super::{finish, CyclerRecord, RawRows, RecordOptions};
use crate::error::Result;
use crate::{bail, err};
use matrw::{MatVariable, MatlabType};
use std::path::Path;

/// The first bytes of a level-5 MAT-file.
pub(super) const MAGIC: &[u8] = b"MATLAB 5.0 MAT-file";

/// How deep structs are searched for a table.
const MAX_DEPTH: usize = 8;

/// A struct whose fields include numeric vectors: its dot path and those
/// vectors (name, values).
struct Table {
    path: String,
    columns: Vec<(String, Vec<f64>)>,
}

/// The numbers of a numeric vector (`n×1` or `1×n`, n ≥ 2), as f64.
fn vector(v: &MatVariable) -> Option<Vec<f64>> {
    let MatVariable::NumericArray(a) = v else {
        return None;
    };
    if a.value_cmp.is_some() || a.dim.len() != 2 || a.dim.iter().min() != Some(&1) {
        return None;
    }
    let x: Vec<f64> = match &a.value {
        MatlabType::F64(x) => x.clone(),
        MatlabType::F32(x) => x.iter().map(|&v| f64::from(v)).collect(),
        MatlabType::U8(x) => x.iter().map(|&v| f64::from(v)).collect(),
        MatlabType::I8(x) => x.iter().map(|&v| f64::from(v)).collect(),
        MatlabType::U16(x) => x.iter().map(|&v| f64::from(v)).collect(),
        MatlabType::I16(x) => x.iter().map(|&v| f64::from(v)).collect(),
        MatlabType::U32(x) => x.iter().map(|&v| f64::from(v)).collect(),
        MatlabType::I32(x) => x.iter().map(|&v| f64::from(v)).collect(),
        MatlabType::U64(x) => x.iter().map(|&v| v as f64).collect(),
        MatlabType::I64(x) => x.iter().map(|&v| v as f64).collect(),
        // A char vector (Digatron's `Status`, one letter a row): the
        // letters' codes, read back as letters by the state column.
        MatlabType::UTF8(x) | MatlabType::UTF16(x) => {
            x.iter().map(|&c| f64::from(u32::from(c))).collect()
        }
        _ => return None,
    };
    (x.len() >= 2).then_some(x)
}

/// The named fields of a struct (or of the file's top level).
type Fields<'a> = [(String, &'a MatVariable)];

/// Calls `visit` with the dot path and the fields of the file's top level
/// (path `""`) and of every struct in it, each struct before those inside
/// it, down to [`MAX_DEPTH`] levels.
fn walk_structs<'a>(
    prefix: &str,
    fields: Vec<(String, &'a MatVariable)>,
    depth: usize,
    visit: &mut dyn FnMut(&str, &Fields<'a>),
) {
    visit(prefix, &fields);
    if depth >= MAX_DEPTH {
        return;
    }
    for (name, v) in fields {
        if let MatVariable::Structure(s) = v {
            let inner = s.value.iter().map(|(k, v)| (k.clone(), v)).collect();
            walk_structs(&dot_path(prefix, &name), inner, depth + 1, visit);
        }
    }
}

/// `prefix.name`, or `name` at the top level.
fn dot_path(prefix: &str, name: &str) -> String {
    if prefix.is_empty() {
        name.to_string()
    } else {
        format!("{prefix}.{name}")
    }
}

/// Every struct (and the file's top level) that holds numeric vectors.
fn tables(top: Vec<(String, &MatVariable)>) -> Vec<Table> {
    let mut out = vec![];
    walk_structs("", top, 0, &mut |prefix, fields| {
        let columns: Vec<(String, Vec<f64>)> = fields
            .iter()
            .filter_map(|(name, v)| vector(v).map(|x| (name.clone(), x)))
            .collect();
        if !columns.is_empty() {
            out.push(Table {
                path: if prefix.is_empty() {
                    "(top level)".to_string()
                } else {
                    prefix.to_string()
                },
                columns,
            });
        }
    });
    out
}

/// The step, state and charge columns of a table (those of another length
/// than the time are not read).
fn extra<'a>(
    c: &ColumnChoice,
    col: &dyn Fn(usize) -> &'a Vec<f64>,
    n: usize,
) -> super::steps::Extra {
    let take = |ch: &Option<headers::Chosen>| {
        ch.as_ref()
            .map(|ch| (ch, col(ch.index)))
            .filter(|(_, v)| v.len() == n)
            .map(|(ch, v)| v.iter().map(|&x| ch.unit.to_si(x)).collect::<Vec<f64>>())
    };
    super::steps::Extra {
        step: take(&c.step),
        step_time: take(&c.step_time),
        state: c
            .state
            .as_ref()
            .map(|ch| col(ch.index))
            .filter(|v| v.len() == n)
            .map(|v| {
                v.iter()
                    .map(|&x| char::from_u32(x as u32).map_or_else(String::new, |c| c.to_string()))
                    .collect()
            }),
        charge: take(&c.charge),
        discharge_charge: take(&c.discharge_charge),
    }
}

/// `s` as one short line: terminal escapes and box-drawing left out,
/// whitespace runs as one space, cut at `max` characters (the parser's
/// errors are drawn for a terminal, over several lines).
fn one_line(s: &str, max: usize) -> String {
    let mut out = String::new();
    let mut chars = s.chars().peekable();
    let mut space = false;
    while let Some(c) = chars.next() {
        if c == '\u{1b}' {
            // An escape sequence: `ESC [` then parameters up to a letter.
            if chars.next_if_eq(&'[').is_some() {
                while chars.next().is_some_and(|d| !d.is_ascii_alphabetic()) {}
            }
            continue;
        }
        if c.is_whitespace() || c.is_control() || ('\u{2500}'..='\u{257f}').contains(&c) {
            space = !out.is_empty();
            continue;
        }
        if space {
            out.push(' ');
            space = false;
        }
        out.push(c);
    }
    match out.char_indices().nth(max) {
        Some((k, _)) => format!("{}…", &out[..k]),
        None => out,
    }
}

/// Reads a MAT-file's table as [`super::read_record_from`] reads a CSV.
pub(super) fn read(bytes: &[u8], path: &Path, o: &RecordOptions) -> Result<CyclerRecord> {
    // A parser of a binary format must not take the process down with it.
    let parsed = std::panic::catch_unwind(|| matrw::load_matfile_from_u8(bytes));
    let file = match parsed {
        Ok(Ok(f)) => f,
        Ok(Err(matrw::MatrwError::MatFile73Error)) => bail!(
            Data,
            "{}: a MAT-file v7.3 (HDF5) is not read; save it with `save(…, '-v7')`",
            path.display()
        ),
        Ok(Err(e)) => bail!(
            Data,
            "{}: not a readable MAT-file ({})",
            path.display(),
            one_line(&e.to_string(), 120)
        ),
        Err(_) => bail!(Data, "{}: not a readable MAT-file", path.display()),
    };
    let top: Vec<(String, &MatVariable)> = file.iter().map(|(k, v)| (k.clone(), v)).collect();
    let found = tables(top);
    let wanted: Vec<&str> = o
        .table
        .as_deref()
        .map(|t| t.split(',').map(str::trim).collect())
        .unwrap_or_default();
    if wanted.len() > 1 {
        return joined(&found, &wanted, path, o);
    }
    let (table, choice) = pick(&found, o.table.as_deref(), path, o)?;
    let raw = rows_of(table, &choice, path, o)?;
    let mut r = finish(raw, 0, &choice, path, o)?;
    r.report.table = Some(table.path.clone());
    Ok(r)
}

/// The table `want` names (or, without a name, the one table whose fields
/// name a time, a current and a voltage) and its columns.
fn pick<'t>(
    found: &'t [Table],
    want: Option<&str>,
    path: &Path,
    o: &RecordOptions,
) -> Result<(&'t Table, ColumnChoice)> {
    let listed = |t: &[&Table]| {
        let mut s: Vec<String> = t.iter().take(6).map(|t| format!("`{}`", t.path)).collect();
        if t.len() > 6 {
            s.push(format!("… ({} in all)", t.len()));
        }
        s.join(", ")
    };
    let (table, choice) = match want {
        Some(want) => {
            let Some(t) = found.iter().find(|t| t.path == want) else {
                bail!(
                    Data,
                    "{}: no table `{want}` (tables of numeric vectors: {})",
                    path.display(),
                    listed(&found.iter().collect::<Vec<_>>())
                );
            };
            let names: Vec<String> = t.columns.iter().map(|c| c.0.clone()).collect();
            let c = headers::choose(&names, &o.columns).map_err(|e| {
                err!(
                    Data,
                    "{}: table `{}`: {e} (fields: {})",
                    path.display(),
                    t.path,
                    super::text::listed(&names)
                )
            })?;
            (t, c)
        }
        None => {
            let fits: Vec<(&Table, ColumnChoice)> = found
                .iter()
                .filter_map(|t| {
                    let names: Vec<String> = t.columns.iter().map(|c| c.0.clone()).collect();
                    headers::choose(&names, &o.columns).ok().map(|c| (t, c))
                })
                .collect();
            match fits.len() {
                1 => fits.into_iter().next().expect("one"),
                0 => {
                    let Some(first) = found.first() else {
                        bail!(
                            Data,
                            "{}: the MAT-file holds no numeric vectors",
                            path.display()
                        );
                    };
                    let names: Vec<String> = first.columns.iter().map(|c| c.0.clone()).collect();
                    let e = headers::choose(&names, &o.columns)
                        .err()
                        .map(|e| e.to_string());
                    bail!(
                        Data,
                        "{}: table `{}`: {} (fields: {}; other tables: {})",
                        path.display(),
                        first.path,
                        e.unwrap_or_default(),
                        super::text::listed(&names),
                        listed(&found.iter().skip(1).collect::<Vec<_>>())
                    )
                }
                n => bail!(
                    Data,
                    "{}: {n} tables fit: {}; name one with --table PATH",
                    path.display(),
                    listed(&fits.iter().map(|f| f.0).collect::<Vec<_>>())
                ),
            }
        }
    };
    Ok((table, choice))
}

/// The rows of `table`'s chosen columns, in SI units and the record's sign.
fn rows_of(
    table: &Table,
    choice: &ColumnChoice,
    path: &Path,
    o: &RecordOptions,
) -> Result<RawRows> {
    let col = |i: usize| &table.columns[i].1;
    let n = col(choice.time.index).len();
    for ch in [&choice.current, &choice.voltage] {
        if col(ch.index).len() != n {
            bail!(
                Data,
                "{}: table `{}`: `{}` has {} values, `{}` {n}",
                path.display(),
                table.path,
                ch.header,
                col(ch.index).len(),
                choice.time.header
            );
        }
    }
    let s = o.current_sign.factor();
    let si = |ch: &headers::Chosen, k: f64| ch.unit.to_si(k);
    let temperature = match &choice.temperature {
        Some(ch) if col(ch.index).len() == n => {
            Some(col(ch.index).iter().map(|&x| si(ch, x)).collect())
        }
        Some(ch) => bail!(
            Data,
            "{}: table `{}`: the temperature `{}` has {} values, the time {n}; name another with --columns temperature=COL, or temperature=none",
            path.display(),
            table.path,
            ch.header,
            col(ch.index).len()
        ),
        None => None,
    };
    let time: Vec<f64> = col(choice.time.index)
        .iter()
        .map(|&x| si(&choice.time, x))
        .collect();
    if let Some(k) = time.iter().position(|t| !t.is_finite()) {
        bail!(
            Data,
            "{}: table `{}`, row {}, column `{}`: `{}` is not finite",
            path.display(),
            table.path,
            k + 1,
            choice.time.header,
            time[k]
        );
    }
    let raw = RawRows {
        time,
        current: col(choice.current.index)
            .iter()
            .map(|&x| s * si(&choice.current, x))
            .collect(),
        voltage: col(choice.voltage.index)
            .iter()
            .map(|&x| si(&choice.voltage, x))
            .collect(),
        temperature,
        rows: (1..=n).collect(),
        clock_time: false,
        extra: extra(choice, &col, n),
    };
    Ok(raw)
}

/// The least time (s) between two joined tables: beyond the default
/// longest step that is not a gap (300 s), so the join is a gap.
pub(super) const JOIN_GAP_S: f64 = 600.0;

/// Several tables joined in the order named (`--table A,B,…`): each
/// starts [`JOIN_GAP_S`] (or twice `--max-gap`) after the one before
/// ended, a gap across which the SOC is read again from the rested voltage
/// (the pulse records of one test, each at its own SOC, whose discharges
/// between were not exported). Their columns must be the same. The
/// export's own charge is not carried across (it counts what the gap
/// leaves out).
fn joined(
    found: &[Table],
    wanted: &[&str],
    path: &Path,
    o: &RecordOptions,
) -> Result<CyclerRecord> {
    let gap = o.max_gap.map_or(JOIN_GAP_S, |g| (2.0 * g).max(JOIN_GAP_S));
    let mut all: Option<(RawRows, ColumnChoice)> = None;
    for want in wanted {
        let (table, choice) = pick(found, Some(want), path, o)?;
        let mut raw = rows_of(table, &choice, path, o)?;
        let Some((acc, first)) = all.as_mut() else {
            all = Some((raw, choice));
            continue;
        };
        if (
            &choice.time.header,
            &choice.current.header,
            &choice.voltage.header,
        ) != (
            &first.time.header,
            &first.current.header,
            &first.voltage.header,
        ) {
            bail!(
                Data,
                "{}: table `{}`: its columns are not those of `{}`; joined tables must share them",
                path.display(),
                table.path,
                wanted[0]
            );
        }
        let end = acc.time.last().copied().unwrap_or(0.0);
        let start = raw.time.first().copied().unwrap_or(0.0);
        let n0 = acc.rows.len();
        // A table that starts on a rested row (no current: a pulse
        // record's last row of the rest before its pulse) has rested
        // through the gap: its voltage is held over the last second of
        // the gap, where the SOC is read again (the pulse follows the row
        // within a period).
        if raw.current.first() == Some(&0.0) {
            acc.time.push(end + gap - 1.0);
            acc.current.push(0.0);
            acc.voltage.push(raw.voltage[0]);
            if let (Some(a), Some(b)) = (acc.temperature.as_mut(), raw.temperature.as_ref()) {
                a.push(b[0]);
            }
            acc.rows.push(n0 + 1);
            acc.extra.append(raw.extra.first_row());
        }
        acc.time
            .extend(raw.time.iter().map(|t| t - start + end + gap));
        acc.current.append(&mut raw.current);
        acc.voltage.append(&mut raw.voltage);
        acc.temperature = match (acc.temperature.take(), raw.temperature.take()) {
            (Some(mut a), Some(mut b)) => {
                a.append(&mut b);
                Some(a)
            }
            _ => None,
        };
        acc.rows.extend(raw.rows.iter().map(|r| r + n0));
        acc.extra.append(raw.extra);
    }
    let Some((mut raw, mut choice)) = all else {
        bail!(Data, "{}: --table names no table", path.display());
    };
    raw.extra.charge = None;
    raw.extra.discharge_charge = None;
    choice.charge = None;
    choice.discharge_charge = None;
    let mut r = finish(raw, 0, &choice, path, o)?;
    r.report.table = Some(wanted.join(","));
    Ok(r)
}

/// The text of a char array (one row: the first of a char matrix).
fn first_text(v: &MatVariable) -> Option<String> {
    let MatVariable::NumericArray(a) = v else {
        return None;
    };
    let (MatlabType::UTF8(x) | MatlabType::UTF16(x)) = &a.value else {
        return None;
    };
    let rows = a.dim.first().copied().unwrap_or(1).max(1);
    Some(
        x.iter()
            .step_by(rows)
            .filter_map(|&c| char::from_u32(u32::from(c)))
            .collect(),
    )
}

/// Every field named as an absolute time column
/// ([`super::date_time::absolute_time_rank`]) holding text (a cell array of
/// char rows, or a char matrix): its rank, dot path and first row.
fn absolute_times(top: Vec<(String, &MatVariable)>) -> Vec<(usize, String, String)> {
    let mut out = vec![];
    walk_structs("", top, 0, &mut |prefix, fields| {
        for (name, v) in fields {
            let Some(rank) = super::date_time::absolute_time_rank(name) else {
                continue;
            };
            let text = match v {
                MatVariable::CellArray(c) => c.value.first().and_then(first_text),
                other => first_text(other),
            };
            if let Some(text) = text {
                out.push((rank, dot_path(prefix, name), text));
            }
        }
    });
    out
}

/// The absolute time field of a MAT-file (its dot path) and its first
/// row's text, the best-ranked of them; `None` without one.
pub(super) fn first_absolute_time(bytes: &[u8], path: &Path) -> Result<Option<(String, String)>> {
    let parsed = std::panic::catch_unwind(|| matrw::load_matfile_from_u8(bytes));
    let Ok(Ok(file)) = parsed else {
        bail!(Data, "{}: not a readable MAT-file", path.display());
    };
    let top: Vec<(String, &MatVariable)> = file.iter().map(|(k, v)| (k.clone(), v)).collect();
    Ok(absolute_times(top)
        .into_iter()
        .min()
        .map(|(_, p, t)| (p, t)))
}

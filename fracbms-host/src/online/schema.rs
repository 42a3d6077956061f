//! The columns of the online tracks, one table per output: each column's
//! name and how its value is taken from a row ([`Column`], [`Value`]).
//! Owns the names and the order of `online battery`'s track
//! ([`TRACK_COLUMNS`]) and of `online pack`'s (`crate::pack`'s
//! `PACK_COLUMNS`, with these types), and how a value is written to the
//! CSV ([`Cell`]'s `Display`). The CLI's writers and Python's dicts and
//! arrays read these tables, so a column is added once, here. Must not
//! compute a value: a row's fields are the estimator's.

use super::power::{PowerRow, MAX_HORIZONS};
use super::soc::SOC_HEADER;
use super::TrackRow;
use std::fmt;

/// How a column takes its value from a row of type `R`.
pub enum Value<R> {
    /// Time (s), written as Rust writes an `f64` (`{}`).
    Time(fn(&R) -> f64),
    /// A count or an index (the pack's `cell`), written as an integer.
    Index(fn(&R) -> usize),
    /// A number, written `{:.9e}`; `None` is the CSV's empty cell.
    Number(fn(&R) -> Option<f64>),
    /// A yes/no, written `0` or `1`.
    Flag(fn(&R) -> bool),
    /// A word (a status, a reason); `None` is the CSV's empty cell.
    Word(fn(&R) -> Option<&'static str>),
    /// The state of power at each horizon `H` of the run: three columns
    /// per horizon, `{name}sop_discharge_a_{H}s`, `{name}sop_charge_a_{H}s`
    /// and `{name}pulse_v_{H}s` (the column's name is their prefix), each
    /// a [`Value::Number`], then `{name}sop_basis`, a [`Value::Word`]
    /// (`window`, `map`, `held`, `stale`:
    /// [`estimator_core::battery::power::SopBasis`]), then
    /// `{name}sop_uncertainty_v` (the longest horizon's pulse voltage's
    /// standard deviation) and `{name}sop_uncertainty_v_{H}s` per horizon,
    /// then `{name}pulse_ratio_{H}s` per horizon (the measured over
    /// predicted drop the pulse voltage was corrected by).
    Power(fn(&R) -> &[PowerRow; MAX_HORIZONS]),
}

impl<R> Clone for Value<R> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<R> Copy for Value<R> {}

/// One entry of a table: a column's name (a prefix for [`Value::Power`])
/// and how its value is taken from a row.
pub struct Column<R> {
    /// The CSV header's name, and the key of Python's dict.
    pub name: &'static str,
    /// How the value is taken from a row.
    pub value: Value<R>,
}

impl<R> Clone for Column<R> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<R> Copy for Column<R> {}

/// The value of one column in one row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cell {
    /// [`Value::Time`].
    Time(f64),
    /// [`Value::Index`].
    Index(usize),
    /// [`Value::Number`] (and the state of power).
    Number(Option<f64>),
    /// [`Value::Flag`].
    Flag(bool),
    /// [`Value::Word`].
    Word(Option<&'static str>),
}

impl Cell {
    /// The value as a number: a time or a number (`None` where empty), else
    /// `None`.
    pub fn number(self) -> Option<f64> {
        match self {
            Cell::Time(t) => Some(t),
            Cell::Number(x) => x,
            _ => None,
        }
    }
}

/// The CSV's cell.
impl fmt::Display for Cell {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Cell::Time(t) => write!(f, "{t}"),
            Cell::Index(k) => write!(f, "{k}"),
            Cell::Number(Some(x)) => write!(f, "{x:.9e}"),
            Cell::Number(None) => Ok(()),
            Cell::Flag(b) => write!(f, "{}", u8::from(b)),
            Cell::Word(w) => f.write_str(w.unwrap_or("")),
        }
    }
}

/// What a column holds, whatever the row: the variant of its [`Cell`]s.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// [`Cell::Time`].
    Time,
    /// [`Cell::Index`].
    Index,
    /// [`Cell::Number`].
    Number,
    /// [`Cell::Flag`].
    Flag,
    /// [`Cell::Word`].
    Word,
}

/// One horizon's value of the state of power: its discharge or charge
/// current, or its pulse voltage.
type PowerPart = fn(&PowerRow) -> Option<f64>;

/// How a [`Field`] takes its value.
enum Get<R> {
    /// As its table's column says (never [`Value::Power`]).
    Plain(Value<R>),
    /// Horizon `j`'s value of the state of power.
    Power(fn(&R) -> &[PowerRow; MAX_HORIZONS], usize, PowerPart),
    /// Where the state of power's parameters came from.
    Basis(fn(&R) -> &[PowerRow; MAX_HORIZONS]),
}

/// One column of an output with the run's horizons: a table's column, or
/// one of a [`Value::Power`] column's.
pub struct Field<R> {
    name: String,
    get: Get<R>,
}

impl<R> Field<R> {
    /// The column's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// What the column holds.
    pub fn kind(&self) -> Kind {
        match self.get {
            Get::Plain(Value::Time(_)) => Kind::Time,
            Get::Plain(Value::Index(_)) => Kind::Index,
            Get::Plain(Value::Flag(_)) => Kind::Flag,
            Get::Plain(Value::Word(_)) | Get::Basis(_) => Kind::Word,
            Get::Plain(Value::Number(_) | Value::Power(_)) | Get::Power(..) => Kind::Number,
        }
    }

    /// Whether the column holds times or numbers (a column of floats).
    pub fn is_number(&self) -> bool {
        matches!(self.kind(), Kind::Time | Kind::Number)
    }

    /// The column's value in row `r`.
    pub fn cell(&self, r: &R) -> Cell {
        match self.get {
            Get::Plain(Value::Time(f)) => Cell::Time(f(r)),
            Get::Plain(Value::Index(f)) => Cell::Index(f(r)),
            Get::Plain(Value::Number(f)) => Cell::Number(f(r)),
            Get::Plain(Value::Flag(f)) => Cell::Flag(f(r)),
            Get::Plain(Value::Word(f)) => Cell::Word(f(r)),
            Get::Plain(Value::Power(_)) => Cell::Number(None),
            Get::Power(rows, j, f) => Cell::Number(f(&rows(r)[j])),
            Get::Basis(rows) => Cell::Word(rows(r)[0].basis),
        }
    }
}

/// The columns of `table` with the state-of-power columns spelled out for
/// `horizons` (s), in the output's order.
pub fn fields<R>(table: &[Column<R>], horizons: &[f64]) -> Vec<Field<R>> {
    let parts: [(&str, PowerPart); 3] = [
        ("sop_discharge_a", |p| p.discharge_a),
        ("sop_charge_a", |p| p.charge_a),
        ("pulse_v", |p| p.pulse_v),
    ];
    let mut out = Vec::new();
    for c in table {
        match c.value {
            Value::Power(rows) => {
                for (j, h) in horizons.iter().enumerate().take(MAX_HORIZONS) {
                    out.extend(parts.map(|(part, f)| Field {
                        name: format!("{}{part}_{h}s", c.name),
                        get: Get::Power(rows, j, f),
                    }));
                }
                out.push(Field {
                    name: format!("{}sop_basis", c.name),
                    get: Get::Basis(rows),
                });
                // The pulse voltage's spread: the longest horizon's, then
                // each horizon's.
                let uncertainty: PowerPart = |p| p.uncertainty_v;
                let longest = (0..horizons.len().min(MAX_HORIZONS))
                    .max_by(|&a, &b| horizons[a].total_cmp(&horizons[b]))
                    .unwrap_or(0);
                out.push(Field {
                    name: format!("{}sop_uncertainty_v", c.name),
                    get: Get::Power(rows, longest, uncertainty),
                });
                for (j, h) in horizons.iter().enumerate().take(MAX_HORIZONS) {
                    out.push(Field {
                        name: format!("{}sop_uncertainty_v_{h}s", c.name),
                        get: Get::Power(rows, j, uncertainty),
                    });
                }
                // What each pulse voltage was corrected by.
                let ratio: PowerPart = |p| p.pulse_ratio;
                for (j, h) in horizons.iter().enumerate().take(MAX_HORIZONS) {
                    out.push(Field {
                        name: format!("{}pulse_ratio_{h}s", c.name),
                        get: Get::Power(rows, j, ratio),
                    });
                }
            }
            v => out.push(Field {
                name: c.name.to_string(),
                get: Get::Plain(v),
            }),
        }
    }
    out
}

/// The CSV header of `fields`: their names, comma-separated.
pub fn header<R>(fields: &[Field<R>]) -> String {
    let names: Vec<&str> = fields.iter().map(Field::name).collect();
    names.join(",")
}

/// Writes row `r` as a CSV line of `fields`.
///
/// # Errors
/// The writer's.
pub fn write_row<R, W: std::io::Write + ?Sized>(
    w: &mut W,
    fields: &[Field<R>],
    r: &R,
) -> std::io::Result<()> {
    for (k, f) in fields.iter().enumerate() {
        let sep = if k == 0 { "" } else { "," };
        write!(w, "{sep}{}", f.cell(r))?;
    }
    writeln!(w)
}

/// A table's entry (a `const fn`: the tables are constants).
pub const fn column<R>(name: &'static str, value: Value<R>) -> Column<R> {
    Column { name, value }
}

/// The estimate of a row when it has the Butler–Volmer term.
fn butler_volmer(r: &TrackRow) -> Option<estimator_core::battery::CellParameters<f64>> {
    r.estimate.filter(|p| p.is_butler_volmer())
}

/// The columns of the track `online battery` writes (`--out`), Python's
/// `OnlineCell.push` dict and `run` arrays (those without
/// [`TRACK_RESTORATION`]).
///
/// `r_i`, `r_ct`, `q` and `alpha` are the published values: each the last
/// window's that the data identified, empty before the first; its
/// `*_status` column says `identified`, `held`, `step`, `prior`,
/// `expired`, `restored` or `not_identified` (`PublishedParameters`).
/// `step_resistance_ohm` is the last precise current step's `ΔU/ΔI`;
/// `window_r_i`… are the last good window's fit, identified or not (what
/// the track's `r_i`… columns held before issue 35, and what the firmware
/// still logs). `soc` is the published SOC ([`super::soc::SocOptions`]);
/// `soc_coulomb` the estimator's count, and `current_bias_a`,
/// `capacity_ah`, `capacity_sigma_ah`, `soc_sigma`, `soc_ocv_weight` the
/// observer's ([`SOC_HEADER`]); `soh_r` the published R_i over
/// the prior's or map's; `capacity_status` whether the data identify
/// `capacity_ah`. Then the state-of-power columns at each horizon
/// ([`super::power::PowerOptions`]) and `rejected`: why the sample was
/// rejected and substituted (`non_finite`, `out_of_range`, `spike`,
/// `unobserved`), empty when it was accepted.
pub const TRACK_COLUMNS: [Column<TrackRow>; 31] = {
    use Value::{Number, Power, Time, Word};
    [
        column("time_s", Time(|r| r.t)),
        column("r_i", Number(|r| r.published.r_i.value)),
        column("r_ct", Number(|r| r.published.r_ct.value)),
        column("q", Number(|r| r.published.q.value)),
        column("alpha", Number(|r| r.published.alpha.value)),
        column("u_oc", Number(|r| r.estimate.map(|p| p.u_oc))),
        column("status", Word(|r| Some(r.status))),
        column("soc", Number(|r| r.soc)),
        column("ocv_offset_v", Number(|r| r.estimate.and(r.ocv_offset))),
        column("bv_a_v", Number(|r| butler_volmer(r).map(|p| p.bv_a))),
        column("bv_i0_a", Number(|r| butler_volmer(r).map(|p| p.bv_i0))),
        column("predicted_v", Number(|r| r.predicted)),
        column(
            "r_i_status",
            Word(|r| Some(r.published.r_i.status.as_str())),
        ),
        column(
            "r_ct_status",
            Word(|r| Some(r.published.r_ct.status.as_str())),
        ),
        column("q_status", Word(|r| Some(r.published.q.status.as_str()))),
        column(
            "alpha_status",
            Word(|r| Some(r.published.alpha.status.as_str())),
        ),
        column("step_resistance_ohm", Number(|r| r.step_resistance)),
        column("window_r_i", Number(|r| r.estimate.map(|p| p.r_i))),
        column("window_r_ct", Number(|r| r.estimate.map(|p| p.r_ct))),
        column("window_q", Number(|r| r.estimate.map(|p| p.q))),
        column("window_alpha", Number(|r| r.estimate.map(|p| p.alpha))),
        column(SOC_HEADER[0], Number(|r| r.soc_detail.columns()[0])),
        column(SOC_HEADER[1], Number(|r| r.soc_detail.columns()[1])),
        column(SOC_HEADER[2], Number(|r| r.soc_detail.columns()[2])),
        column(SOC_HEADER[3], Number(|r| r.soc_detail.columns()[3])),
        column(SOC_HEADER[4], Number(|r| r.soc_detail.columns()[4])),
        column(SOC_HEADER[5], Number(|r| r.soc_detail.columns()[5])),
        column("soh_r", Number(|r| r.soh_r)),
        column(
            "capacity_status",
            Word(|r| Some(r.soc_detail.capacity_status())),
        ),
        column("", Power(|r| &r.power)),
        column("rejected", Word(|r| r.rejected)),
    ]
};

/// The track's last column with `--state-in`: `restored`, `soc_reread`
/// (the stored SOC contradicted by the first rested voltage, read again
/// through the OCV table) or `clean` (the snapshot was rejected); the
/// published parameters' `*_status` is `restored` until a window
/// identifies them.
pub const TRACK_RESTORATION: Column<TrackRow> = Column {
    name: "restoration",
    value: Value::Word(|r| Some(r.restoration.as_str())),
};

/// The columns of `online battery`'s track at `horizons` (s), with
/// [`TRACK_RESTORATION`] when `restoration`.
pub fn track_fields(horizons: &[f64], restoration: bool) -> Vec<Field<TrackRow>> {
    let mut out = fields(&TRACK_COLUMNS, horizons);
    if restoration {
        out.extend(fields(&[TRACK_RESTORATION], horizons));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_track_header_is_the_table_s() {
        let h = header(&track_fields(&[10.0, 30.0], false));
        assert_eq!(
            h,
            "time_s,r_i,r_ct,q,alpha,u_oc,status,soc,ocv_offset_v,bv_a_v,bv_i0_a,predicted_v,r_i_status,r_ct_status,q_status,alpha_status,step_resistance_ohm,window_r_i,window_r_ct,window_q,window_alpha,soc_coulomb,current_bias_a,capacity_ah,capacity_sigma_ah,soc_sigma,soc_ocv_weight,soh_r,capacity_status,sop_discharge_a_10s,sop_charge_a_10s,pulse_v_10s,sop_discharge_a_30s,sop_charge_a_30s,pulse_v_30s,sop_basis,sop_uncertainty_v,sop_uncertainty_v_10s,sop_uncertainty_v_30s,pulse_ratio_10s,pulse_ratio_30s,rejected"
        );
        assert!(header(&track_fields(&[0.5], true)).ends_with(
            ",pulse_v_0.5s,sop_basis,sop_uncertainty_v,sop_uncertainty_v_0.5s,pulse_ratio_0.5s,rejected,restoration"
        ));
    }

    #[test]
    fn cells_are_written_as_the_csv_wrote_them() {
        let cells = [
            Cell::Time(1.5),
            Cell::Index(3),
            Cell::Number(Some(0.0125)),
            Cell::Number(None),
            Cell::Flag(true),
            Cell::Word(None),
            Cell::Word(Some("held")),
        ];
        let s: Vec<String> = cells.iter().map(ToString::to_string).collect();
        assert_eq!(s, ["1.5", "3", "1.250000000e-2", "", "1", "", "held"]);
    }
}

//! The names of the option enums, as every face spells them (`op`,
//! `butler-volmer`, `from-data`, …): one list per enum, for a face that
//! takes them as strings (Python's keywords, a JSON file). The CLI's flags
//! take the same names. This module owns only the names; what each option
//! means is documented where the enum lives.

use crate::cycler::{CurrentSign, StepsMode};
use crate::identify::{Algorithm, BatteryMethod, HammersteinMethod, ModelRequest};
use crate::map::MapMethod;
use crate::online::soc::SocMode;
use crate::online::Precision;
use crate::reproduce::ReproducePart;
use estimator_core::battery::Start;

/// An option enum with a name per value.
///
/// ```
/// use fracbms_host::choice::Choice;
/// use fracbms_host::identify::ModelRequest;
///
/// assert_eq!(ModelRequest::parse("butler-volmer"), Some(ModelRequest::ButlerVolmer));
/// assert_eq!(ModelRequest::names(), ["linear", "butler-volmer", "auto"]);
/// ```
pub trait Choice: Copy + Sized + 'static {
    /// Every value, in the order the help lists them.
    const ALL: &'static [Self];

    /// The value's name.
    fn name(self) -> &'static str;

    /// The value of a name (exact match).
    fn parse(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|v| v.name() == name)
    }

    /// Every name, in order.
    fn names() -> Vec<&'static str> {
        Self::ALL.iter().map(|v| v.name()).collect()
    }
}

macro_rules! choice {
    ($t:ty: $($v:expr),+) => {
        impl Choice for $t {
            const ALL: &'static [Self] = &[$($v),+];
            fn name(self) -> &'static str {
                self.as_str()
            }
        }
    };
}

choice!(Algorithm: Algorithm::Op, Algorithm::Kt);
choice!(HammersteinMethod: HammersteinMethod::Paper, HammersteinMethod::Refined);
choice!(BatteryMethod: BatteryMethod::Paper, BatteryMethod::Refined);
choice!(ModelRequest: ModelRequest::Linear, ModelRequest::ButlerVolmer, ModelRequest::Auto);
choice!(Precision: Precision::F32, Precision::F64);
choice!(SocMode: SocMode::Observer, SocMode::Coulomb);
choice!(
    CurrentSign: CurrentSign::ChargePositive,
    CurrentSign::DischargePositive,
    CurrentSign::FromState
);
choice!(StepsMode: StepsMode::Auto, StepsMode::Ignore, StepsMode::Count);
choice!(ReproducePart: ReproducePart::All, ReproducePart::Example1, ReproducePart::Battery);

impl Choice for MapMethod {
    const ALL: &'static [Self] = &[MapMethod::Joint, MapMethod::Levels];
    fn name(self) -> &'static str {
        match self {
            MapMethod::Joint => "joint",
            MapMethod::Levels => "levels",
        }
    }
}

impl Choice for Start {
    const ALL: &'static [Self] = &[Start::FromData, Start::AtRest];
    fn name(self) -> &'static str {
        match self {
            Start::FromData => "from-data",
            Start::AtRest => "at-rest",
        }
    }
}

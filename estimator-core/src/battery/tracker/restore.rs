//! What a cell keeps across a reset, the tracker's side of
//! [`crate::battery::snapshot`]: the values a snapshot holds of a cell
//! ([`CellSnapshot`]), how a cell started ([`Restoration`]), and
//! [`CellState`]'s taking of a checked snapshot. The bytes and their checks
//! are the snapshot module's; this one must not read or write bytes.

use super::fusion::{SlowFusion, SLOW_PARTS};
use super::*;
use crate::battery::soc::{ObserverParts, SocObserver};
use crate::battery::CellParameters;
use crate::real::Real;

/// Whether a cell started from a snapshot, and what its first sample said.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Restoration {
    /// Started clean (no snapshot restored).
    #[default]
    Clean,
    /// Started from a snapshot; its SOC stands (the first sample was not
    /// rested, or its voltage agreed with the stored SOC).
    Restored,
    /// Started from a snapshot whose SOC a rested first voltage
    /// contradicted: the SOC was read again through the OCV table.
    SocReread,
}

impl Restoration {
    /// A short lower-case name (host-sim's `restoration` column).
    pub fn as_str(&self) -> &'static str {
        match self {
            Restoration::Clean => "clean",
            Restoration::Restored => "restored",
            Restoration::SocReread => "soc_reread",
        }
    }
}

/// What a snapshot holds of one cell ([`crate::battery::snapshot`]), in
/// the cell's float type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CellSnapshot<T> {
    pub estimate: Option<CellParameters<T>>,
    pub published: PublishedParameters<T>,
    pub soc: Option<T>,
    pub observer: ObserverParts<T>,
    /// The slow part's mean ([`super::fusion`]), aged to the save, when
    /// the snapshot keeps it (`None`: it starts again at the first window
    /// that identifies each parameter).
    pub slow: Option<[T; SLOW_PARTS]>,
}

impl<T: Real> CellSnapshot<T> {
    /// Whether the SOC observer this snapshot holds publishes under `s`
    /// what an observer does: a finite state of charge with a spread of
    /// at most 1, a finite bias and capacity, and a finite capacity spread
    /// (finite bytes can still overflow them: a capacity factor of 5.4e-20,
    /// a flipped bit, makes an `f32` cell's capacity spread infinite).
    pub(crate) fn observer_publishes<const P: usize>(&self, s: &OnlineSettings<T, P>) -> bool {
        let spread = |x: T| x.is_finite() && x >= T::zero();
        SocObserver::from_parts(&self.observer, false)
            .estimate(&s.soc)
            .is_none_or(|e| {
                e.soc.is_finite()
                    && spread(e.sigma)
                    && e.sigma <= T::one()
                    && spread(e.capacity_sigma_ah)
                    && e.current_bias_a.is_finite()
                    && e.capacity_ah.is_finite()
            })
    }
}

impl<T: Real, const N: usize> CellState<T, N> {
    /// What a snapshot keeps of this cell ([`crate::battery::snapshot`]),
    /// the slow part's mean with `slow` (aged to this cell's last sample).
    pub(crate) fn snapshot<const P: usize>(
        &self,
        s: &OnlineSettings<T, P>,
        slow: bool,
    ) -> CellSnapshot<T> {
        CellSnapshot {
            estimate: self.estimate,
            published: self.published,
            soc: self.soc,
            observer: self.soc_observer.parts(),
            slow: slow.then(|| self.slow.parts(s, self.counts.samples)),
        }
    }

    /// Takes a checked snapshot into this new cell: the estimate the
    /// refinement starts from at the first sample ([`Self::take_start`]),
    /// the published values marked [`Identification::Restored`], the
    /// counted SOC (checked at the first good sample) and the SOC
    /// observer, resumed as after a gap when `gap` (the charge while the
    /// estimator was off is unknown), and the slow part's mean the snapshot
    /// kept, aged by `offline_s` (0 when the clocks do not say).
    pub(crate) fn restore<const MEM: usize, const P: usize>(
        &mut self,
        s: &OnlineSettings<T, P>,
        snap: &CellSnapshot<T>,
        gap: bool,
        offline_s: T,
    ) {
        *self = Self::new::<MEM, P>(s);
        self.estimate = snap.estimate;
        self.published = snap.published.restored();
        self.soc = snap.soc;
        self.soc_observer = SocObserver::from_parts(&snap.observer, gap);
        self.soc_check = s.ocv.is_some() && snap.soc.is_some();
        self.slow = snap
            .slow
            .and_then(|p| SlowFusion::from_parts(&p, s, offline_s))
            .unwrap_or(SlowFusion::EMPTY);
        self.restoration = Restoration::Restored;
    }

    /// How this cell started: clean, or from a snapshot (and whether its
    /// stored SOC stood against the first sample).
    pub fn restoration(&self) -> Restoration {
        self.restoration
    }
}

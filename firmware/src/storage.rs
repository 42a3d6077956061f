//! Where the estimator's snapshot lives across resets: a reserved flash
//! region, written through `sequential-storage`'s map (one key, the newest
//! value wins) over the `embedded-storage` NOR-flash traits, and the write
//! policy that says when to save.
//!
//! The snapshot's bytes are the core's
//! ([`estimator_core::battery::snapshot`]); this module only stores and
//! finds them. Wear levelling and power-fail safety are
//! `sequential-storage`'s: a save appends an item to the region and erases
//! a page only when the region is full; an item cut by a power loss fails
//! its CRC and the previous one is found instead (checked at every write
//! and erase step of a save by the power-fail test,
//! `storage::tests::a_cut_at_every_step_of_a_save_leaves_the_old_or_the_new_snapshot`).
//!
//! It must not judge a snapshot (the core's restore does) nor decide what
//! the task does at boot (the board's `run`).

use core::ops::Range;

use embedded_storage_async::nor_flash::NorFlash;
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage};

/// The one key of the map: the pack's snapshot.
const KEY: u8 = 0;

/// Why the store failed. Small and `Copy`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum StoreError {
    /// The region is not whole pages, or fewer than two.
    Region,
    /// The flash reported an error (a write or an erase failed).
    Flash,
    /// The region holds data it cannot read as a map (erase it).
    Corrupted,
    /// The scratch or output buffer is too small for the snapshot.
    Buffer,
    /// Anything else the storage crate reports.
    Storage,
}

impl<E> From<sequential_storage::Error<E>> for StoreError {
    fn from(e: sequential_storage::Error<E>) -> Self {
        match e {
            sequential_storage::Error::Storage { .. } => StoreError::Flash,
            sequential_storage::Error::Corrupted { .. } => StoreError::Corrupted,
            sequential_storage::Error::BufferTooSmall(_)
            | sequential_storage::Error::BufferTooBig
            | sequential_storage::Error::ItemTooBig => StoreError::Buffer,
            _ => StoreError::Storage,
        }
    }
}

/// The snapshot store over a flash `F`'s region.
pub struct SnapshotStore<F: NorFlash> {
    map: MapStorage<u8, F, Cache<Uncached, Uncached, Uncached, u8>>,
}

impl<F: NorFlash> SnapshotStore<F> {
    /// A store over `range` of `flash` (whole erase pages, at least two).
    ///
    /// # Errors
    /// [`StoreError::Region`] for a range that is not.
    pub fn new(flash: F, range: Range<u32>) -> Result<Self, StoreError> {
        let config = MapConfig::try_new(range).map_err(|_| StoreError::Region)?;
        Ok(Self {
            map: MapStorage::new(flash, config, Cache::new_uncached()),
        })
    }

    /// Saves `snapshot` as the newest. `scratch` holds the item while it is
    /// written: at least the snapshot's length plus one, rounded up to the
    /// flash's word.
    ///
    /// # Errors
    /// The flash's or the storage's failure; the previous snapshot stays.
    pub fn save(&mut self, snapshot: &[u8], scratch: &mut [u8]) -> Result<(), StoreError> {
        embassy_futures::block_on(self.map.store_item(scratch, &KEY, &snapshot))
            .map_err(StoreError::from)
    }

    /// The newest snapshot, copied into `buf` (`None`: none saved, or the
    /// region erased).
    ///
    /// # Errors
    /// The flash's or the storage's failure; [`StoreError::Buffer`] when
    /// `buf` is too small.
    pub fn load<'b>(&mut self, buf: &'b mut [u8]) -> Result<Option<&'b [u8]>, StoreError> {
        let found = embassy_futures::block_on(self.map.fetch_item::<&[u8]>(buf, &KEY))
            .map_err(StoreError::from)?;
        Ok(found)
    }

    /// The flash back (for a test or a board that shares it).
    pub fn into_flash(self) -> F {
        self.map.destroy().0
    }
}

/// A blocking `embedded-storage` NOR flash (a flash controller that
/// stalls the core while it programs, as the STM32L4's) as the async NOR
/// flash `sequential-storage` takes: every operation completes when it is
/// polled the first time.
pub struct BlockingFlash<F>(pub F);

impl<F: embedded_storage::nor_flash::ErrorType> embedded_storage_async::nor_flash::ErrorType
    for BlockingFlash<F>
{
    type Error = F::Error;
}

impl<F: embedded_storage::nor_flash::ReadNorFlash> embedded_storage_async::nor_flash::ReadNorFlash
    for BlockingFlash<F>
{
    const READ_SIZE: usize = F::READ_SIZE;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.0.read(offset, bytes)
    }

    fn capacity(&self) -> usize {
        self.0.capacity()
    }
}

impl<F: embedded_storage::nor_flash::NorFlash> NorFlash for BlockingFlash<F> {
    const WRITE_SIZE: usize = F::WRITE_SIZE;
    const ERASE_SIZE: usize = F::ERASE_SIZE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        self.0.erase(from, to)
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        self.0.write(offset, bytes)
    }
}

/// When the task saves its snapshot: a setting. Each save appends one item
/// (the snapshot, `20 + 124·cells + 4` B, plus `sequential-storage`'s
/// header) to the region; a page is erased once per page of items written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct SavePolicy {
    /// Save once the cell has rested this long (s; `None`: not at rests).
    /// A rest is where the SOC is read and the estimate is held: the best
    /// moment to keep it.
    pub at_rest_after_s: Option<u32>,
    /// Save at least this often while running (s; `None`: never on time
    /// alone).
    pub every_s: Option<u32>,
    /// Never save more often than this (s): what bounds the flash's wear.
    pub min_interval_s: u32,
}

impl Default for SavePolicy {
    /// At a rest of 5 min, every hour otherwise, at most every 10 min.
    fn default() -> Self {
        Self {
            at_rest_after_s: Some(300),
            every_s: Some(3600),
            min_interval_s: 600,
        }
    }
}

impl SavePolicy {
    /// Whether to save now: `since_save_s` since the last save (or boot),
    /// `rested_s` the rest so far (0 under load). A known shutdown saves
    /// regardless (the caller's decision, not the policy's).
    pub fn due(&self, since_save_s: u32, rested_s: u32) -> bool {
        if since_save_s < self.min_interval_s {
            return false;
        }
        let at_rest = self.at_rest_after_s.is_some_and(|r| rested_s >= r);
        let on_time = self.every_s.is_some_and(|e| since_save_s >= e);
        at_rest || on_time
    }

    /// The most saves a day this policy allows.
    pub fn max_saves_per_day(&self) -> u32 {
        86_400 / self.min_interval_s.max(1)
    }
}

/// The flash's life under a save rate: years until a page of the region
/// reaches `endurance` erase cycles, when `saves_per_day` snapshots of
/// `item_bytes` (with the storage's header) go to a region of `pages`
/// pages of `page_bytes` (wear levelled over the region by
/// `sequential-storage`).
pub fn flash_life_years(
    endurance: u32,
    pages: u32,
    page_bytes: u32,
    item_bytes: u32,
    saves_per_day: u32,
) -> f64 {
    // Items that fit in a page (an item never spans pages); a page is
    // erased once per that many saves, and the region's pages take turns.
    let per_page = (page_bytes / item_bytes.max(1)).max(1);
    let erases_per_day = f64::from(saves_per_day) / f64::from(per_page) / f64::from(pages.max(1));
    f64::from(endurance) / erases_per_day.max(f64::MIN_POSITIVE) / 365.0
}

pub mod ram_flash;

#[cfg(test)]
mod tests;

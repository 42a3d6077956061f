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

/// A flash region a snapshot store wears: its geometry and the erase
/// cycles its pages endure. What the save policy scales with
/// ([`SavePolicy::for_region`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct FlashRegion {
    /// Erase pages in the region (the store needs at least two).
    pub pages: u32,
    /// Bytes of an erase page.
    pub page_bytes: u32,
    /// The flash's write word (B): items and page markers are whole words.
    pub word_bytes: u32,
    /// Erase cycles a page is specified to endure.
    pub endurance: u32,
}

/// `sequential-storage`'s item header (B), before the word rounding.
const ITEM_HEADER_BYTES: u32 = 8;

impl FlashRegion {
    /// The STM32L452's snapshot region, the last 16 KiB of its flash
    /// (`boards/stm32l452.x`): 8 pages of 2 KiB, programmed in 8-byte
    /// double words, 10 000 erase cycles a page (the STM32L4 datasheet's
    /// endurance). QEMU's NOR model has the same geometry.
    pub const STM32L452: Self = Self {
        pages: 8,
        page_bytes: 2048,
        word_bytes: 8,
        endurance: 10_000,
    };

    /// What a snapshot of `snapshot_bytes` takes in the region: the item
    /// header (8 B), then the key (1 B) and the snapshot, each rounded up
    /// to the word (160 B for one cell's 148 B, 2024 B for 16 cells' 2008 B
    /// with 8-byte words).
    pub const fn item_bytes(&self, snapshot_bytes: u32) -> u32 {
        let w = if self.word_bytes == 0 {
            1
        } else {
            self.word_bytes
        };
        ITEM_HEADER_BYTES.div_ceil(w) * w + (snapshot_bytes + 1).div_ceil(w) * w
    }

    /// Snapshots of `snapshot_bytes` a page holds: the page less its two
    /// state words, over [`item_bytes`](Self::item_bytes) (0 when none
    /// fits: the store then refuses to save).
    pub const fn items_per_page(&self, snapshot_bytes: u32) -> u32 {
        let usable = self.page_bytes.saturating_sub(2 * self.word_bytes);
        usable / self.item_bytes(snapshot_bytes)
    }
}

/// The flash's life (years) when `saves_per_day` snapshots of
/// `snapshot_bytes` go to `region`: until a page reaches its endurance.
/// `sequential-storage` appends every save and erases a page only when
/// the region is full, the pages in turn: a page is erased once every
/// [`FlashRegion::items_per_page`] saves, and the erases go round the
/// region's pages. Infinite without saves; 0 when a snapshot does not fit a
/// page. (The power-fail test's store counts its erases; test
/// `storage::tests::the_scaled_policy_keeps_the_stm32l452_region_10_years_for_1_to_16_cells`
/// checks this against them.)
pub fn flash_life_years(region: &FlashRegion, snapshot_bytes: u32, saves_per_day: f64) -> f64 {
    // Saves the region takes before a page reaches its endurance, over
    // the saves a year.
    saves_to_wear_out(region, snapshot_bytes) / (saves_per_day * 365.0)
}

/// Saves `region` takes before its pages reach their endurance: endurance
/// × pages × items a page (0 when a snapshot does not fit a page).
fn saves_to_wear_out(region: &FlashRegion, snapshot_bytes: u32) -> f64 {
    let per_page = region.items_per_page(snapshot_bytes);
    f64::from(region.endurance) * f64::from(region.pages) * f64::from(per_page)
}

/// When the task saves its snapshot: a setting. Each save appends one item
/// (the snapshot, `20 + 124·cells + 4` B, plus `sequential-storage`'s
/// header: [`FlashRegion::item_bytes`]) to the region; a page is erased
/// once per page of items written.
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
    /// At a rest of 5 min, every hour otherwise, at most every 10 min,
    /// whatever the flash: [`SavePolicy::for_region`] scales it to one.
    fn default() -> Self {
        Self {
            at_rest_after_s: Some(300),
            every_s: Some(3600),
            min_interval_s: 600,
        }
    }
}

impl SavePolicy {
    /// The default policy with its minimum interval raised as far as
    /// `region` needs to last `years` under its most frequent saves (one
    /// every `min_interval_s`) of snapshots of `snapshot_bytes`:
    ///
    /// `min_interval_s = max(600, ⌈86 400 · 365 · years / (endurance ·
    /// pages · items_per_page)⌉)`,
    ///
    /// and the hourly save no more often than that. The interval grows
    /// with the snapshot (fewer items a page) and shrinks with the pages:
    /// on the STM32L452's region for 10 years, 600 s for 1 and 2 cells,
    /// 986 s for 3, 3942 s (66 min) from 8 cells on, where one snapshot
    /// fills a page (docs/persistence.md). A snapshot that fits no page is
    /// given the interval of one a page (the store refuses it anyway).
    pub fn for_region(region: &FlashRegion, snapshot_bytes: u32, years: u32) -> Self {
        let d = Self::default();
        let items = u64::from(region.items_per_page(snapshot_bytes).max(1));
        let wear = u64::from(region.endurance.max(1)) * u64::from(region.pages.max(1)) * items;
        let need = (86_400 * 365 * u64::from(years)).div_ceil(wear);
        let min_interval_s = d
            .min_interval_s
            .max(u32::try_from(need).unwrap_or(u32::MAX));
        Self {
            at_rest_after_s: d.at_rest_after_s,
            every_s: d.every_s.map(|e| e.max(min_interval_s)),
            min_interval_s,
        }
    }

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

    /// The most saves a whole day this policy allows.
    pub fn max_saves_per_day(&self) -> u32 {
        86_400 / self.min_interval_s.max(1)
    }

    /// The life (years) of `region` when this policy saves as often as it
    /// may, `86 400 / min_interval_s` snapshots of `snapshot_bytes` a day
    /// (the long-run rate, a fraction): [`flash_life_years`]. Saves at a
    /// known shutdown come on top.
    pub fn flash_life_years(&self, region: &FlashRegion, snapshot_bytes: u32) -> f64 {
        // As `flash_life_years` at 86 400 / min_interval_s saves a day,
        // without rounding that rate (a whole number of seconds comes out
        // whole: 10 years, not 9.999…).
        saves_to_wear_out(region, snapshot_bytes) * f64::from(self.min_interval_s.max(1))
            / (86_400.0 * 365.0)
    }
}

pub mod ram_flash;

#[cfg(test)]
mod tests;

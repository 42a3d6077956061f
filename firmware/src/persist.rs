//! The snapshot on the board (docs/persistence.md): restored at boot with
//! the core's judgement, saved by the write policy
//! ([`firmware::storage::SavePolicy`], scaled to the board's region and
//! this image's snapshot for [`FLASH_LIFE_YEARS`]) and, under QEMU, saved
//! before the reset `FRACBMS_RESET_AT` asks for.
//!
//! It owns when to save and what to log; the bytes and their checks are
//! the core's, the store is `firmware::storage`'s, the region the board's.

use crate::board::BoardApi;
use estimator_core::battery::snapshot::snapshot_bytes_with;
use firmware::storage::{SavePolicy, SnapshotStore};
use firmware::{config, ConfiguredTask};

/// This image's snapshot size (B): with each cell's slow part when the
/// image carries one across windows (`FRACBMS_SLOW_MEMORY_S` above 0).
const SNAPSHOT: usize = snapshot_bytes_with(config::CELLS, config::SLOW_MEMORY_S > 0.0);
/// The store's scratch: the snapshot, its key, rounded up to a word.
const SCRATCH: usize = SNAPSHOT + 16;
/// The snapshot region's life the save policy keeps (years).
const FLASH_LIFE_YEARS: u32 = 10;

/// What the snapshot did in this run, for the final `PERSIST` line.
pub struct Persistence<F: embedded_storage_async::nor_flash::NorFlash> {
    store: Option<SnapshotStore<F>>,
    policy: SavePolicy,
    /// Periods since the last save (or boot), and of rest so far.
    since_save: u32,
    rested: u32,
    saves: u32,
    failed_saves: u32,
    save_clocks_max: u64,
    restore_clocks: u64,
}

impl<F: embedded_storage_async::nor_flash::NorFlash> Persistence<F> {
    /// Restores the task from the board's store, if it holds a snapshot
    /// the core takes; logs `RESTORE status=… clocks=…`.
    pub fn boot<B: BoardApi<SnapshotFlash = F>>(
        b: &mut B,
        s: &firmware::task::TaskSettings,
        task: &mut ConfiguredTask,
    ) -> Self {
        let mut p = Self {
            store: b.snapshot_store(),
            policy: SavePolicy::for_region(&B::SNAPSHOT_REGION, SNAPSHOT as u32, FLASH_LIFE_YEARS),
            since_save: 0,
            rested: 0,
            saves: 0,
            failed_saves: 0,
            save_clocks_max: 0,
            restore_clocks: 0,
        };
        let Some(store) = p.store.as_mut() else {
            defmt::println!("RESTORE status=no_store");
            return p;
        };
        let t0 = b.clocks();
        let restored = restore(store, s, task);
        p.restore_clocks = b.clocks() - t0;
        match restored {
            Ok(true) => defmt::println!(
                "RESTORE status=restored resumed_at={=u32} bytes={=usize} clocks={=u64}",
                b.resumed_at(),
                SNAPSHOT,
                p.restore_clocks
            ),
            Ok(false) => defmt::println!("RESTORE status=none clocks={=u64}", p.restore_clocks),
            Err(why) => defmt::println!(
                "RESTORE status=rejected reason={=str} clocks={=u64}",
                why,
                p.restore_clocks
            ),
        }
        p
    }

    /// After a period: saves when the policy says so (`current_a`, the
    /// period's current, tells a rest). Logs failures only.
    pub fn after_period<B: BoardApi>(
        &mut self,
        b: &B,
        s: &firmware::task::TaskSettings,
        task: &ConfiguredTask,
        current_a: f32,
    ) {
        let h = config::SAMPLE_PERIOD_S;
        self.since_save += 1;
        let rest_a = config::CAPACITY_AH.max(1.0) / 100.0;
        self.rested = if current_a.abs() <= rest_a {
            self.rested + 1
        } else {
            0
        };
        let secs = |n: u32| (n as f32 * h) as u32;
        if self.policy.due(secs(self.since_save), secs(self.rested)) {
            self.save(b, s, task);
        }
    }

    /// Saves now (a reset or a known shutdown is coming, or the policy).
    pub fn save<B: BoardApi>(
        &mut self,
        b: &B,
        s: &firmware::task::TaskSettings,
        task: &ConfiguredTask,
    ) {
        let Some(store) = self.store.as_mut() else {
            return;
        };
        let t0 = b.clocks();
        let ok = save(store, s, task);
        let dt = b.clocks() - t0;
        self.since_save = 0;
        if ok {
            self.saves += 1;
            self.save_clocks_max = self.save_clocks_max.max(dt);
            defmt::println!("SAVED bytes={=usize} clocks={=u64}", SNAPSHOT, dt);
        } else {
            self.failed_saves += 1;
            defmt::warn!("snapshot save failed");
        }
    }

    /// The run's `PERSIST` line (with the policy's shortest interval
    /// between saves).
    pub fn report(&self) {
        defmt::println!(
            "PERSIST bytes={=usize} saves={=u32} failed_saves={=u32} save_clocks_max={=u64} restore_clocks={=u64} min_interval_s={=u32}",
            SNAPSHOT,
            self.saves,
            self.failed_saves,
            self.save_clocks_max,
            self.restore_clocks,
            self.policy.min_interval_s
        );
    }
}

/// Loads and restores; `Ok(false)` when the store holds none, `Err` with
/// why the store or the core refused it. Never inlined: its buffer lives
/// in this frame only.
#[inline(never)]
fn restore<F: embedded_storage_async::nor_flash::NorFlash>(
    store: &mut SnapshotStore<F>,
    s: &firmware::task::TaskSettings,
    task: &mut ConfiguredTask,
) -> Result<bool, &'static str> {
    let mut buf = [0u8; SCRATCH];
    match store.load(&mut buf) {
        Ok(None) => Ok(false),
        Ok(Some(bytes)) => task
            .restore(s, bytes)
            .map(|()| true)
            .map_err(|e| e.as_str()),
        Err(_) => Err("store"),
    }
}

/// Saves the task's snapshot; whether it was written. Never inlined: its
/// buffers live in this frame only.
#[inline(never)]
fn save<F: embedded_storage_async::nor_flash::NorFlash>(
    store: &mut SnapshotStore<F>,
    s: &firmware::task::TaskSettings,
    task: &ConfiguredTask,
) -> bool {
    let mut bytes = [0u8; SNAPSHOT];
    let mut scratch = [0u8; SCRATCH];
    match task.save(s, &mut bytes) {
        Ok(n) => store
            .save(bytes.get(..n).unwrap_or(&[]), &mut scratch)
            .is_ok(),
        Err(_) => false,
    }
}

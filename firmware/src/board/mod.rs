//! Boards: what differs between the QEMU machine and a real BMS MCU.
//!
//! A board supplies a [`PackSampler`], a periodic sample tick from a
//! hardware timer, a timer-based cycle count for cost measurements, the
//! stack high-water mark, the store of the estimator's snapshot over its
//! reserved flash region (docs/persistence.md), a reset, and a way to stop.

use firmware::sampler::PackSampler;
use firmware::storage::{FlashRegion, SnapshotStore};

#[cfg(feature = "board-qemu")]
pub mod qemu;
#[cfg(feature = "board-qemu")]
pub use qemu::{init, Qemu as Board};

#[cfg(feature = "board-stm32l452")]
pub mod stm32l452;
#[cfg(feature = "board-stm32l452")]
pub use stm32l452::{init, Stm32l452 as Board};

#[cfg(not(any(feature = "board-qemu", feature = "board-stm32l452")))]
compile_error!(
    "choose a board feature: board-qemu (the default) or board-stm32l452 (with --no-default-features)"
);
#[cfg(all(feature = "board-qemu", feature = "board-stm32l452"))]
compile_error!(
    "board-qemu and board-stm32l452 exclude each other: build the STM32 board with --no-default-features --features board-stm32l452"
);

/// What the application needs from a board.
pub trait BoardApi {
    /// The sampler of this board.
    type Sampler: PackSampler;
    /// The sampler.
    fn sampler(&mut self) -> &mut Self::Sampler;
    /// Blocks until the next sample tick; returns how many ticks were
    /// missed since the last call (an overrun: the previous update took
    /// longer than a sample period).
    fn wait_for_tick(&mut self) -> u32;
    /// Timer clocks since boot (free running).
    fn clocks(&self) -> u64;
    /// Timer clock frequency (Hz).
    const CLOCK_HZ: u32;
    /// Deepest stack use so far (bytes), from the painted stack.
    fn stack_high_water(&self) -> u32;
    /// Stops: on QEMU exits with status 0 (`ok`) or 1; on hardware parks.
    fn finish(&mut self, ok: bool) -> !;
    /// The NOR flash the snapshot is kept in.
    type SnapshotFlash: embedded_storage_async::nor_flash::NorFlash;
    /// The snapshot region's geometry and endurance: what the save policy
    /// is scaled to ([`firmware::storage::SavePolicy::for_region`]).
    const SNAPSHOT_REGION: FlashRegion;
    /// The snapshot's store over the board's reserved region (`None`: the
    /// board keeps none yet). Called once, at boot.
    fn snapshot_store(&mut self) -> Option<SnapshotStore<Self::SnapshotFlash>>;
    /// The sample period a replay resumes at after [`reset`](Self::reset)
    /// (0 after power-on).
    fn resumed_at(&self) -> u32;
    /// Resets the MCU as a watchdog or a brown-out would, the replay to
    /// resume at period `at` (`FRACBMS_RESET_AT`, under QEMU).
    fn reset(&mut self, at: u32) -> !;
}

/// Stack painting: fills the free RAM between the end of static data and
/// the current stack pointer with a pattern at boot; the lowest overwritten
/// word later gives the deepest stack use.
pub mod stack {
    const PAINT: u32 = 0xCCCC_CCCC;

    extern "C" {
        static mut __sheap: u32;
        static mut _stack_start: u32;
    }

    fn bounds() -> (*mut u32, *mut u32) {
        // Only the addresses of the linker symbols are taken.
        (
            core::ptr::addr_of_mut!(__sheap),
            core::ptr::addr_of_mut!(_stack_start),
        )
    }

    /// Paints from the end of static data up to 256 bytes below the
    /// current stack pointer. Call once, first thing in `main`.
    pub fn paint() {
        let (lo, _) = bounds();
        let sp = cortex_m::register::msp::read() as usize - 256;
        let mut p = lo;
        while (p as usize) < sp {
            // SAFETY: [__sheap, sp) is RAM that no object occupies (the
            // stack grows down from above sp; there is no heap).
            unsafe { core::ptr::write_volatile(p, PAINT) };
            p = p.wrapping_add(1);
        }
    }

    /// Deepest stack use since [`paint`] (bytes).
    pub fn high_water() -> u32 {
        let (lo, hi) = bounds();
        let mut p = lo;
        // SAFETY: reads within the painted RAM region below the stack top.
        while (p as usize) < hi as usize && unsafe { core::ptr::read_volatile(p) } == PAINT {
            p = p.wrapping_add(1);
        }
        (hi as usize - p as usize) as u32
    }
}

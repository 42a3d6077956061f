//! QEMU `mps2-an386` (Cortex-M4F, 25 MHz): replays the record built into the
//! image, ticks from SysTick, logs through `defmt-semihosting`, exits
//! through semihosting (status 0 on success, 1 on a failed check, a panic
//! or a HardFault).
//!
//! SysTick runs from the 25 MHz core clock with a 1 ms period, so the
//! replay is paced by the emulator, not by the record's sample period: an
//! update longer than 1 ms shows as an overrun, and the next replayed
//! sample follows at once (a replay loses no sample). Under
//! `qemu-system-arm -icount shift=0` one instruction takes 1 ns of virtual
//! time, so a timer clock at 25 MHz is 40 instructions.
//!
//! The snapshot's "flash" is RAM: the board has no flash controller to
//! program, so a NOR model ([`RamFlash`], 8 pages of 2 KiB) lives in the
//! `.snapshot` section at the top of RAM (`boards/mps2-an386.x`), which is
//! NOLOAD: neither the boot code nor QEMU's system reset
//! (`SCB::sys_reset`) clears it. It is erased (`0xFF`) at power-on, when
//! the reset record's magic is not there.

use super::{stack, BoardApi};
use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SCB;
use cortex_m_rt::{exception, ExceptionFrame};
use cortex_m_semihosting::debug;
use defmt_semihosting as _;
use firmware::sampler::ReplaySampler;
use firmware::storage::ram_flash::RamFlash;
use firmware::storage::{FlashRegion, SnapshotStore};

/// The NOR model's geometry: the STM32L452 region's (8-byte words, 8
/// pages of 2 KiB).
const WORD: usize = FlashRegion::STM32L452.word_bytes as usize;
const PAGE: usize = FlashRegion::STM32L452.page_bytes as usize;
const PAGES: usize = FlashRegion::STM32L452.pages as usize;

/// What survives a system reset: the reset record and the NOR model.
#[repr(C, align(8))]
struct Persist {
    /// [`PERSIST_MAGIC`] once the region was erased at power-on.
    magic: u32,
    /// The period the replay resumes at after [`BoardApi::reset`].
    resume_at: u32,
    flash: [u8; PAGES * PAGE],
}

/// "FBRS".
const PERSIST_MAGIC: u32 = 0x4642_5253;

#[link_section = ".snapshot"]
static mut PERSIST: core::mem::MaybeUninit<Persist> = core::mem::MaybeUninit::uninit();

/// The region, erased at power-on (the magic absent), and the period the
/// replay resumes at (0 at power-on). Called once, from [`init`].
fn persist() -> (&'static mut [u8; PAGES * PAGE], u32) {
    let p = (&raw mut PERSIST).cast::<Persist>();
    // SAFETY: `init` runs once, so this is the only reference to PERSIST;
    // the region is RAM of the `.snapshot` section, every bit pattern is a
    // valid `u32` or byte, and it is written before it is read at
    // power-on.
    unsafe {
        let magic = core::ptr::addr_of!((*p).magic).read_volatile();
        let resume_at = if magic == PERSIST_MAGIC {
            core::ptr::addr_of!((*p).resume_at).read_volatile()
        } else {
            core::ptr::addr_of_mut!((*p).flash).write_bytes(0xFF, 1);
            core::ptr::addr_of_mut!((*p).magic).write_volatile(PERSIST_MAGIC);
            0
        };
        core::ptr::addr_of_mut!((*p).resume_at).write_volatile(0);
        (&mut *core::ptr::addr_of_mut!((*p).flash), resume_at)
    }
}

/// SysTick reload: 1 ms at 25 MHz.
const RELOAD: u32 = 25_000 - 1;

static TICKS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    TICKS.fetch_add(1, Ordering::Relaxed);
}

/// Exits QEMU with status 1.
fn fail() -> ! {
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}

#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    defmt::error!("HardFault at pc = {=u32:#x}", ef.pc());
    fail()
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    if let Some(l) = info.location() {
        defmt::error!("panic at {=str}:{=u32}", l.file(), l.line());
    } else {
        defmt::error!("panic");
    }
    fail()
}

/// The QEMU board.
pub struct Qemu {
    _syst: cortex_m::peripheral::SYST,
    sampler: ReplaySampler<'static>,
    handled: u32,
    /// The NOR model's bytes (taken by `snapshot_store`).
    flash: Option<&'static mut [u8; PAGES * PAGE]>,
    resumed_at: u32,
}

/// Paints the stack, starts SysTick, opens the replay stream.
pub fn init() -> Qemu {
    stack::paint();
    let Some(cp) = cortex_m::Peripherals::take() else {
        defmt::error!("core peripherals taken twice");
        fail()
    };
    let mut syst = cp.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(RELOAD);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
    let (flash, resumed_at) = persist();
    let mut sampler = ReplaySampler::with_cells(firmware::REPLAY, firmware::config::REPLAY_CELLS);
    // After a reset the replay goes on where it stopped.
    sampler.skip(resumed_at as usize);
    Qemu {
        _syst: syst,
        sampler,
        handled: 0,
        flash: Some(flash),
        resumed_at,
    }
}

impl BoardApi for Qemu {
    type Sampler = ReplaySampler<'static>;
    const CLOCK_HZ: u32 = 25_000_000;

    fn sampler(&mut self) -> &mut Self::Sampler {
        &mut self.sampler
    }

    fn wait_for_tick(&mut self) -> u32 {
        while TICKS.load(Ordering::Relaxed) == self.handled {
            cortex_m::asm::wfi();
        }
        let now = TICKS.load(Ordering::Relaxed);
        let missed = now.wrapping_sub(self.handled).saturating_sub(1);
        self.handled = now;
        missed
    }

    fn clocks(&self) -> u64 {
        // The counter may have wrapped while its interrupt is still pending
        // (QEMU takes interrupts only between translated blocks): then the
        // period is not yet in TICKS and is added here. Without this, a read
        // could go a period back: on a 4-cell pack record the total lost
        // 4 400 periods and the longest update wrapped to 2⁶⁴ − 21 795.
        loop {
            let t1 = TICKS.load(Ordering::Relaxed);
            let p1 = SCB::is_pendst_pending();
            let v = cortex_m::peripheral::SYST::get_current();
            let p2 = SCB::is_pendst_pending();
            let t2 = TICKS.load(Ordering::Relaxed);
            if t1 == t2 && p1 == p2 {
                let periods = u64::from(t1) + u64::from(p1);
                return periods * u64::from(RELOAD + 1) + u64::from(RELOAD - v);
            }
        }
    }

    fn stack_high_water(&self) -> u32 {
        stack::high_water()
    }

    type SnapshotFlash = RamFlash<'static, WORD, PAGE>;
    /// The model wears nothing, but the policy is the one of the flash it
    /// models.
    const SNAPSHOT_REGION: FlashRegion = FlashRegion::STM32L452;

    fn snapshot_store(&mut self) -> Option<SnapshotStore<Self::SnapshotFlash>> {
        let flash = self.flash.take()?;
        SnapshotStore::new(RamFlash::new(flash), 0..(PAGES * PAGE) as u32).ok()
    }

    fn resumed_at(&self) -> u32 {
        self.resumed_at
    }

    fn reset(&mut self, at: u32) -> ! {
        let p = (&raw mut PERSIST).cast::<Persist>();
        // SAFETY: a volatile write of one field of the region `persist`
        // set up; nothing else writes it.
        unsafe { core::ptr::addr_of_mut!((*p).resume_at).write_volatile(at) };
        cortex_m::peripheral::SCB::sys_reset()
    }

    fn finish(&mut self, ok: bool) -> ! {
        debug::exit(if ok {
            debug::EXIT_SUCCESS
        } else {
            debug::EXIT_FAILURE
        });
        loop {
            cortex_m::asm::bkpt();
        }
    }
}

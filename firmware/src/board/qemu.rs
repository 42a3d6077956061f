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

use super::{stack, BoardApi};
use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{exception, ExceptionFrame};
use cortex_m_semihosting::debug;
use defmt_semihosting as _;
use firmware::sampler::ReplaySampler;

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
    Qemu {
        _syst: syst,
        sampler: ReplaySampler::with_cells(firmware::REPLAY, firmware::config::REPLAY_CELLS),
        handled: 0,
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
        loop {
            let t1 = TICKS.load(Ordering::Relaxed);
            let v = cortex_m::peripheral::SYST::get_current();
            let t2 = TICKS.load(Ordering::Relaxed);
            if t1 == t2 {
                return u64::from(t1) * u64::from(RELOAD + 1) + u64::from(RELOAD - v);
            }
        }
    }

    fn stack_high_water(&self) -> u32 {
        stack::high_water()
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

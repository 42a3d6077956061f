//! STM32L452RE (Cortex-M4F, 80 MHz, 512 KiB flash, 160 KiB RAM) through
//! `embassy-stm32`: ADC1 samples the cell, TIM2 paces the sample periods,
//! defmt logs over RTT, `panic-probe` reports panics to the probe.
//!
//! Nobody on the project has flashed this board: it is built in CI, not
//! run. `README.md` has the probe-rs command.
//!
//! ## Analog front end (edit `analog::FrontEnd` for your board)
//!
//! | signal      | pin | ADC1 channel | default conversion                               |
//! |-------------|-----|--------------|--------------------------------------------------|
//! | pack current| PA0 | IN5          | shunt amplifier, 1.65 V at 0 A, 25 mV/A (±66 A)  |
//! | cell voltage| PA1 | IN6          | 1:2 divider (0–6.6 V)                            |
//! | temperature | PA4 | IN9          | MCP9700-type sensor, 500 mV at 0 °C, 10 mV/°C    |
//!
//! All three use a 3.3 V reference and 12-bit conversions with the longest
//! sampling time (247.5 ADC clocks), for high-impedance dividers.
//!
//! ## Cell monitor instead (feature `stm32l452-bq769x0`)
//!
//! With `--features stm32l452-bq769x0` the sampler is a TI bq769x0 on I2C1
//! (SCL PB6, SDA PB7, 100 kHz, address 0x08, no CRC, cell 1, 1 mΩ shunt,
//! 10 kΩ NTC on TS1): see [`firmware::bq769x0`] and `monitor::BQ769X0`.
//!
//! ## Timing
//!
//! TIM2 (32 bits) counts microseconds from boot. Each sample period is a
//! compare on channel 1; the core sleeps in `WFE` until it matches (the
//! compare interrupt is enabled in the timer but not in the NVIC, and
//! `SEVONPEND` turns its pending state into a wake-up event, so no
//! handler is needed). The sample period is `config::SAMPLE_PERIOD_S`
//! (`FRACBMS_PERIOD_S`, default the replay record's period).

use super::{stack, BoardApi};
use core::cell::Cell;
use cortex_m::peripheral::NVIC;
use defmt_rtt as _;
use embassy_stm32::interrupt;
use embassy_stm32::peripherals::TIM2;
use embassy_stm32::time::Hertz;
use embassy_stm32::timer::low_level::Timer;
use embassy_stm32::Config;
use firmware::config;
use firmware::storage::{BlockingFlash, FlashRegion, SnapshotStore};
use panic_probe as _;

#[cfg(not(feature = "stm32l452-bq769x0"))]
pub mod analog;
#[cfg(not(feature = "stm32l452-bq769x0"))]
use analog::{make_sampler, Stm32Sampler};
#[cfg(feature = "stm32l452-bq769x0")]
pub mod monitor;
#[cfg(feature = "stm32l452-bq769x0")]
use monitor::{make_sampler, Stm32Sampler};

/// The STM32L452 board.
pub struct Stm32l452 {
    sampler: Stm32Sampler,
    /// The flash controller (taken by `snapshot_store`).
    flash: Option<Flash>,
    timer: Timer<'static, TIM2>,
    /// Sample period in timer clocks (µs).
    period: u32,
    /// Counter value of the current sample tick.
    deadline: u32,
    /// Last counter value read and the clocks before it (for a 64-bit count).
    extended: Cell<(u32, u64)>,
}

/// Halts: under a debugger (probe-rs) a breakpoint ends the session;
/// standalone the core sleeps.
fn halt() -> ! {
    loop {
        if cortex_m::peripheral::DCB::is_debugger_attached() {
            cortex_m::asm::bkpt();
        }
        cortex_m::asm::wfi();
    }
}

/// Clocks (80 MHz from HSI16 through the PLL), ADC1 on three pins, TIM2 at
/// 1 MHz.
pub fn init() -> Stm32l452 {
    stack::paint();
    let mut cfg = Config::default();
    {
        use embassy_stm32::rcc::*;
        cfg.rcc.hsi = true;
        cfg.rcc.pll = Some(Pll {
            source: PllSource::HSI,
            prediv: PllPreDiv::DIV1,
            mul: PllMul::MUL10,
            divp: None,
            divq: None,
            // 16 MHz × 10 / 2 = 80 MHz.
            divr: Some(PllRDiv::DIV2),
        });
        cfg.rcc.sys = Sysclk::PLL1_R;
        cfg.rcc.mux.adcsel = mux::Adcsel::SYS;
    }
    let p = embassy_stm32::init(cfg);

    let (sampler, tim2, flash) = make_sampler(p);

    let mut timer = Timer::new(tim2);
    timer.set_tick_freq(Hertz(1_000_000));
    timer.set_max_compare_value(u32::MAX);
    // Compare match on channel 1 sets CC1IF; with CC1IE the interrupt goes
    // pending (never taken: not enabled in the NVIC) and wakes WFE.
    timer.regs_gp32().dier().modify(|w| w.set_ccie(0, true));
    if let Some(mut cp) = cortex_m::Peripherals::take() {
        cp.SCB.set_sevonpend();
    }
    timer.start();
    let period = (config::SAMPLE_PERIOD_S * 1e6) as u32;
    let deadline = timer.regs_gp32().cnt().read();
    Stm32l452 {
        sampler,
        flash: Some(embassy_stm32::flash::Flash::new_blocking(flash)),
        timer,
        period: period.max(1),
        deadline,
        extended: Cell::new((deadline, u64::from(deadline))),
    }
}

impl Stm32l452 {
    fn counter(&self) -> u32 {
        self.timer.regs_gp32().cnt().read()
    }
}

/// The driver's flash (offsets from the flash base).
type Flash = embassy_stm32::flash::Flash<'static, embassy_stm32::flash::Blocking>;

/// The snapshot's region, as offsets from the flash base, from the linker
/// symbols of `boards/stm32l452.x`.
fn snapshot_region() -> core::ops::Range<u32> {
    extern "C" {
        static __snapshot_start: u8;
        static __snapshot_end: u8;
    }
    // Only the symbols' addresses are taken.
    let (start, end) = (
        core::ptr::addr_of!(__snapshot_start) as u32,
        core::ptr::addr_of!(__snapshot_end) as u32,
    );
    let base = embassy_stm32::flash::FLASH_BASE as u32;
    start.wrapping_sub(base)..end.wrapping_sub(base)
}

/// `a` is at or after `b` on the wrapping 32-bit counter.
fn reached(a: u32, b: u32) -> bool {
    a.wrapping_sub(b) < 0x8000_0000
}

impl BoardApi for Stm32l452 {
    type Sampler = Stm32Sampler;
    const CLOCK_HZ: u32 = 1_000_000;

    /// The internal flash through `embassy-stm32`'s blocking driver
    /// (8-byte words, 2 KiB pages), over the region `boards/stm32l452.x`
    /// reserves (the last 16 KiB). Not run on hardware yet: built in CI.
    type SnapshotFlash = BlockingFlash<Flash>;
    /// `boards/stm32l452.x`'s 16 KiB: 8 pages of 2 KiB.
    const SNAPSHOT_REGION: FlashRegion = FlashRegion::STM32L452;

    fn snapshot_store(&mut self) -> Option<SnapshotStore<Self::SnapshotFlash>> {
        let flash = self.flash.take()?;
        SnapshotStore::new(BlockingFlash(flash), snapshot_region()).ok()
    }

    fn resumed_at(&self) -> u32 {
        0
    }

    fn reset(&mut self, _at: u32) -> ! {
        cortex_m::peripheral::SCB::sys_reset()
    }

    fn sampler(&mut self) -> &mut Self::Sampler {
        &mut self.sampler
    }

    fn wait_for_tick(&mut self) -> u32 {
        let regs = self.timer.regs_gp32();
        let now = self.counter();
        let mut next = self.deadline.wrapping_add(self.period);
        let mut missed = 0;
        while reached(now, next) {
            next = next.wrapping_add(self.period);
            missed += 1;
        }
        if missed > 0 {
            // The last update overran: this tick is now, the next ones
            // stay on the period grid.
            self.deadline = next.wrapping_sub(self.period);
            return missed - 1;
        }
        regs.ccr(0).write_value(next);
        regs.sr().modify(|w| w.set_ccif(0, false));
        NVIC::unpend(interrupt::TIM2);
        while !regs.sr().read().ccif(0) && !reached(self.counter(), next) {
            cortex_m::asm::wfe();
        }
        regs.sr().modify(|w| w.set_ccif(0, false));
        NVIC::unpend(interrupt::TIM2);
        self.deadline = next;
        0
    }

    fn clocks(&self) -> u64 {
        let now = self.counter();
        let (last, total) = self.extended.get();
        let total = total + u64::from(now.wrapping_sub(last));
        self.extended.set((now, total));
        total
    }

    fn stack_high_water(&self) -> u32 {
        stack::high_water()
    }

    fn finish(&mut self, ok: bool) -> ! {
        if ok {
            defmt::info!("finished");
        } else {
            defmt::error!("stopped on a failed check");
        }
        halt()
    }
}

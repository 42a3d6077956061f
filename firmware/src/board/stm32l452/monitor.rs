//! A TI bq769x0 cell monitor on I2C1 (feature `stm32l452-bq769x0`).

use super::halt;
use embassy_stm32::peripherals::TIM2;
use embassy_stm32::time::Hertz;

/// The sampler of this board: a bq769x0 cell monitor on I2C1.
pub type Stm32Sampler = firmware::bq769x0::Bq769x0<
    embassy_stm32::i2c::I2c<'static, embassy_stm32::mode::Blocking, embassy_stm32::i2c::Master>,
>;

// One bq769x0 has at most 15 cell inputs (bq76940).
const _: () = assert!(
    firmware::config::CELLS <= firmware::bq769x0::MAX_CELLS,
    "FRACBMS_CELLS: one bq769x0 reads at most 15 cells (a bq76940)"
);

/// Settings of the bq769x0 (edit for your board): the firmware's cells
/// (`FRACBMS_CELLS`, 15 for a bq76940) on inputs VC1…VCn.
pub const BQ769X0: firmware::bq769x0::Bq769x0Config = firmware::bq769x0::Bq769x0Config {
    address: 0x08,
    crc: false,
    cell: 1,
    cells: firmware::config::CELLS as u8,
    sense_ohm: 0.001,
    thermistor: firmware::bq769x0::Thermistor::NTC_10K_3435,
};

/// The bq769x0 on I2C1 (PB6, PB7); gives TIM2 back.
pub(super) fn make_sampler(
    p: embassy_stm32::Peripherals,
) -> (
    Stm32Sampler,
    embassy_stm32::Peri<'static, TIM2>,
    embassy_stm32::Peri<'static, embassy_stm32::peripherals::FLASH>,
) {
    let mut c = embassy_stm32::i2c::Config::default();
    c.frequency = Hertz(100_000);
    let i2c = embassy_stm32::i2c::I2c::new_blocking(p.I2C1, p.PB6, p.PB7, c);
    match firmware::bq769x0::Bq769x0::new(i2c, BQ769X0) {
        Ok(d) => (d, p.TIM2, p.FLASH),
        Err(e) => {
            defmt::error!("bq769x0 start-up failed: {}", e);
            halt()
        }
    }
}

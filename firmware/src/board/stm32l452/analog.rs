//! The analog front end on ADC1 (the default sampler of the board).

use super::halt;
use core::cell::RefCell;
use embassy_stm32::adc::{Adc, AdcChannel as _, AnyAdcChannel, SampleTime};
use embassy_stm32::peripherals::{ADC1, TIM2};
use firmware::sampler::{AdcChannel, AdcSampler, Calibration, SingleCell};

/// Full scale of a 12-bit conversion.
const FULL_SCALE: u16 = 4095;
/// Volts per ADC count with the 3.3 V reference.
const VOLTS_PER_COUNT: f32 = 3.3 / 4095.0;

/// Conversions of the analog front end (see the module docs).
pub struct FrontEnd;

impl FrontEnd {
    /// Pack current (A, positive when charging, as in the core): (V − 1.65 V) / 25 mV/A.
    pub const CURRENT: Calibration = Calibration {
        gain: VOLTS_PER_COUNT / 0.025,
        offset: -1.65 / 0.025,
    };
    /// Cell voltage (V) behind a 1:2 divider.
    pub const VOLTAGE: Calibration = Calibration {
        gain: VOLTS_PER_COUNT * 2.0,
        offset: 0.0,
    };
    /// Temperature (°C) of a linear sensor: (V − 0.5 V) / 10 mV/°C.
    pub const TEMPERATURE: Calibration = Calibration {
        gain: VOLTS_PER_COUNT / 0.010,
        offset: -0.5 / 0.010,
    };
}

/// The ADC is shared by the three channels of the sampler.
type SharedAdc = RefCell<Adc<'static, ADC1>>;

/// The ADC is already converting for another channel (cannot happen in
/// this single-threaded firmware; reported as [`SampleError::Adc`]).
///
/// [`SampleError::Adc`]: firmware::sampler::SampleError::Adc
#[derive(Clone, Copy, Debug, defmt::Format)]
pub struct AdcBusy;

/// One ADC1 input: our [`AdcChannel`] over embassy's blocking read.
pub struct Stm32Channel {
    adc: &'static SharedAdc,
    input: AnyAdcChannel<'static, ADC1>,
}

impl AdcChannel for Stm32Channel {
    type Error = AdcBusy;
    const FULL_SCALE: u16 = FULL_SCALE;

    fn read_raw(&mut self) -> Result<u16, AdcBusy> {
        let mut adc = self.adc.try_borrow_mut().map_err(|_| AdcBusy)?;
        Ok(adc.blocking_read(&mut self.input, SampleTime::CYCLES247_5))
    }
}

/// The sampler of this board: ADC1 through the analog front end (one cell).
pub type Stm32Sampler = SingleCell<AdcSampler<Stm32Channel, Stm32Channel, Stm32Channel>>;

/// ADC1 on PA0, PA1, PA4; gives TIM2 back.
pub(super) fn make_sampler(
    p: embassy_stm32::Peripherals,
) -> (
    Stm32Sampler,
    embassy_stm32::Peri<'static, TIM2>,
    embassy_stm32::Peri<'static, embassy_stm32::peripherals::FLASH>,
) {
    let Some(adc) = cortex_m::singleton!(: SharedAdc = RefCell::new(Adc::new(p.ADC1))) else {
        defmt::error!("ADC taken twice");
        halt()
    };
    let adc: &'static SharedAdc = adc;
    let sampler = SingleCell(AdcSampler {
        current: (
            Stm32Channel {
                adc,
                input: p.PA0.degrade_adc(),
            },
            FrontEnd::CURRENT,
        ),
        voltage: (
            Stm32Channel {
                adc,
                input: p.PA1.degrade_adc(),
            },
            FrontEnd::VOLTAGE,
        ),
        temperature: (
            Stm32Channel {
                adc,
                input: p.PA4.degrade_adc(),
            },
            FrontEnd::TEMPERATURE,
        ),
    });
    (sampler, p.TIM2, p.FLASH)
}

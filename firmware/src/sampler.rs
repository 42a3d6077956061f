//! What a BMS samples each period, and where it comes from.
//!
//! embedded-hal 1.0 has no ADC trait, so this module defines two small ones:
//!
//! * [`AdcChannel`]: one raw conversion of one analog channel (implement it
//!   over your HAL's ADC, see `board::stm32l452`).
//! * [`CellSampler`]: one calibrated [`Sample`] (pack current, cell voltage,
//!   temperature) per sample period, or a typed [`SampleError`].
//!
//! Two samplers implement [`CellSampler`]: [`AdcSampler`] (three raw
//! channels with a [`Calibration`] each, detecting saturation) and
//! [`ReplaySampler`] (a recorded stream, used on QEMU and in host tests).

/// One calibrated measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Pack current (A), positive when charging.
    pub current_a: f32,
    /// Cell terminal voltage (V).
    pub voltage_v: f32,
    /// Cell temperature (°C).
    pub temperature_c: f32,
}

/// Why no valid sample is available this period.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum SampleError {
    /// The converter reported an error (bus, timeout, overrun).
    Adc,
    /// A raw reading sat at the end of the converter's range.
    Saturated,
    /// The sample of this period is missing (a gap in a record, a missed
    /// conversion).
    Dropped,
    /// The replayed record has ended.
    EndOfStream,
}

/// One raw conversion of one analog channel.
pub trait AdcChannel {
    /// The converter's own error.
    type Error;
    /// Full-scale raw value (e.g. 4095 for 12 bits).
    const FULL_SCALE: u16;
    /// Converts once.
    fn read_raw(&mut self) -> Result<u16, Self::Error>;
}

/// Linear calibration `value = gain · raw + offset` in engineering units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calibration {
    /// Units per LSB.
    pub gain: f32,
    /// Units at raw 0.
    pub offset: f32,
}

impl Calibration {
    /// Applies the calibration.
    pub fn apply(&self, raw: u16) -> f32 {
        self.gain * f32::from(raw) + self.offset
    }
}

/// A source of one [`Sample`] per sample period.
pub trait CellSampler {
    /// Takes this period's sample.
    fn sample(&mut self) -> Result<Sample, SampleError>;
}

/// Current, voltage and temperature from three raw ADC channels.
///
/// A raw reading of 0 or full scale on the current or voltage channel is
/// reported as [`SampleError::Saturated`]: the true value is outside the
/// converter's range.
pub struct AdcSampler<I, V, T> {
    /// Current channel (e.g. a shunt amplifier).
    pub current: (I, Calibration),
    /// Cell voltage channel (e.g. a divider).
    pub voltage: (V, Calibration),
    /// Temperature channel (e.g. an NTC, linearised around 25 °C).
    pub temperature: (T, Calibration),
}

fn raw<C: AdcChannel>(c: &mut C) -> Result<u16, SampleError> {
    c.read_raw().map_err(|_| SampleError::Adc)
}

impl<I: AdcChannel, V: AdcChannel, T: AdcChannel> CellSampler for AdcSampler<I, V, T> {
    fn sample(&mut self) -> Result<Sample, SampleError> {
        let ri = raw(&mut self.current.0)?;
        let rv = raw(&mut self.voltage.0)?;
        let rt = raw(&mut self.temperature.0)?;
        if ri == 0 || ri >= I::FULL_SCALE || rv == 0 || rv >= V::FULL_SCALE {
            return Err(SampleError::Saturated);
        }
        Ok(Sample {
            current_a: self.current.1.apply(ri),
            voltage_v: self.voltage.1.apply(rv),
            temperature_c: self.temperature.1.apply(rt),
        })
    }
}

/// Bytes per record of a replay stream (see `build.rs`): `u32` flags, then
/// current, voltage, temperature as little-endian `f32`.
pub const REPLAY_RECORD: usize = 16;

/// Plays a recorded stream, one record per sample period.
///
/// Record flag 1 marks a missing row ([`SampleError::Dropped`]); after the
/// last record every call returns [`SampleError::EndOfStream`].
///
/// ```
/// use firmware::sampler::{CellSampler, ReplaySampler, SampleError};
/// let mut rec = [0u8; 32];
/// rec[4..8].copy_from_slice(&1.5f32.to_le_bytes());
/// rec[8..12].copy_from_slice(&3.7f32.to_le_bytes());
/// rec[16..20].copy_from_slice(&1u32.to_le_bytes()); // a dropped row
/// let mut r = ReplaySampler::new(&rec);
/// assert_eq!(r.sample().unwrap().voltage_v, 3.7);
/// assert_eq!(r.sample(), Err(SampleError::Dropped));
/// assert_eq!(r.sample(), Err(SampleError::EndOfStream));
/// ```
pub struct ReplaySampler<'a> {
    records: core::slice::ChunksExact<'a, u8>,
}

impl<'a> ReplaySampler<'a> {
    /// Plays `bytes` (a whole number of [`REPLAY_RECORD`]-byte records; a
    /// trailing partial record is ignored).
    pub fn new(bytes: &'a [u8]) -> Self {
        Self {
            records: bytes.chunks_exact(REPLAY_RECORD),
        }
    }

    /// Records not yet played.
    pub fn remaining(&self) -> usize {
        self.records.len()
    }
}

fn word(r: &[u8], at: usize) -> [u8; 4] {
    let mut w = [0; 4];
    w.copy_from_slice(&r[at..at + 4]);
    w
}

impl CellSampler for ReplaySampler<'_> {
    fn sample(&mut self) -> Result<Sample, SampleError> {
        let r = self.records.next().ok_or(SampleError::EndOfStream)?;
        if u32::from_le_bytes(word(r, 0)) & 1 != 0 {
            return Err(SampleError::Dropped);
        }
        Ok(Sample {
            current_a: f32::from_le_bytes(word(r, 4)),
            voltage_v: f32::from_le_bytes(word(r, 8)),
            temperature_c: f32::from_le_bytes(word(r, 12)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Fixed(u16, bool);
    impl AdcChannel for Fixed {
        type Error = ();
        const FULL_SCALE: u16 = 4095;
        fn read_raw(&mut self) -> Result<u16, ()> {
            if self.1 {
                Err(())
            } else {
                Ok(self.0)
            }
        }
    }

    fn adc(i: u16, v: u16, fail: bool) -> AdcSampler<Fixed, Fixed, Fixed> {
        AdcSampler {
            current: (
                Fixed(i, false),
                Calibration {
                    gain: 0.01,
                    offset: -20.48,
                },
            ),
            voltage: (
                Fixed(v, fail),
                Calibration {
                    gain: 0.001,
                    offset: 0.0,
                },
            ),
            temperature: (
                Fixed(2048, false),
                Calibration {
                    gain: 0.0,
                    offset: 25.0,
                },
            ),
        }
    }

    #[test]
    fn adc_sampler_calibrates() {
        let s = adc(2548, 3700, false).sample().unwrap();
        assert!((s.current_a - 5.0).abs() < 1e-4, "{}", s.current_a);
        assert!((s.voltage_v - 3.7).abs() < 1e-6);
        assert_eq!(s.temperature_c, 25.0);
    }

    #[test]
    fn adc_sampler_reports_saturation_and_errors() {
        assert_eq!(adc(0, 3700, false).sample(), Err(SampleError::Saturated));
        assert_eq!(adc(100, 4095, false).sample(), Err(SampleError::Saturated));
        assert_eq!(adc(100, 3700, true).sample(), Err(SampleError::Adc));
    }
}

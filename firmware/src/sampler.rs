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
//!
//! * [`PackSampler`]: every series cell's voltage with the pack current and
//!   a temperature, per sample period ([`crate::bq769x0`] reads them in one
//!   bus transaction; [`ReplaySampler`] plays a pack record). A cell whose
//!   own reading is bad (saturated) comes back as NaN, so that only that
//!   cell's sample is rejected.

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

/// What a pack sampler returns besides the cell voltages.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PackReading {
    /// Pack current (A), positive when charging.
    pub current_a: f32,
    /// Pack temperature (°C).
    pub temperature_c: f32,
}

/// A source of one sample of every series cell per sample period.
pub trait PackSampler {
    /// Cells this sampler reads.
    fn cells(&self) -> usize;
    /// Takes this period's sample: every cell's terminal voltage (V, cell 1
    /// first) into `volts[..cells]` (a cell whose reading is bad gets NaN),
    /// the current and temperature returned. An error is the whole
    /// period's (bus, converter, a dropped row).
    fn sample_pack(&mut self, volts: &mut [f32]) -> Result<PackReading, SampleError>;
}

/// A one-cell [`PackSampler`] over a [`CellSampler`] (e.g. an
/// [`AdcSampler`] of one cell).
pub struct SingleCell<S>(pub S);

impl<S: CellSampler> PackSampler for SingleCell<S> {
    fn cells(&self) -> usize {
        1
    }

    fn sample_pack(&mut self, volts: &mut [f32]) -> Result<PackReading, SampleError> {
        let x = self.0.sample()?;
        if let Some(v) = volts.first_mut() {
            *v = x.voltage_v;
        }
        Ok(PackReading {
            current_a: x.current_a,
            temperature_c: x.temperature_c,
        })
    }
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

/// Bytes per record of a one-cell replay stream (see `build.rs`): `u32`
/// flags, then current, voltage, temperature as little-endian `f32`. A pack
/// record of `C` cells has the `C` voltages in the voltage's place:
/// [`replay_record`]`(C)` bytes.
pub const REPLAY_RECORD: usize = 16;

/// Bytes per record of a replay stream of `cells` cells.
pub const fn replay_record(cells: usize) -> usize {
    12 + 4 * cells
}

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
    cells: usize,
}

impl<'a> ReplaySampler<'a> {
    /// Plays `bytes` of a one-cell stream (a whole number of
    /// [`REPLAY_RECORD`]-byte records; a trailing partial record is
    /// ignored).
    pub fn new(bytes: &'a [u8]) -> Self {
        Self::with_cells(bytes, 1)
    }

    /// Plays `bytes` of a stream of `cells` cells (at least 1).
    pub fn with_cells(bytes: &'a [u8], cells: usize) -> Self {
        let cells = cells.max(1);
        Self {
            records: bytes.chunks_exact(replay_record(cells)),
            cells,
        }
    }

    /// Records not yet played.
    pub fn remaining(&self) -> usize {
        self.records.len()
    }

    /// Skips `n` records (a replay resumed after a reset, at the period it
    /// stopped).
    pub fn skip(&mut self, n: usize) {
        for _ in 0..n {
            if self.records.next().is_none() {
                break;
            }
        }
    }
}

fn word(r: &[u8], at: usize) -> [u8; 4] {
    let mut w = [0; 4];
    w.copy_from_slice(&r[at..at + 4]);
    w
}

impl CellSampler for ReplaySampler<'_> {
    /// Cell 1 of the stream.
    fn sample(&mut self) -> Result<Sample, SampleError> {
        let cells = self.cells;
        let r = self.records.next().ok_or(SampleError::EndOfStream)?;
        if u32::from_le_bytes(word(r, 0)) & 1 != 0 {
            return Err(SampleError::Dropped);
        }
        Ok(Sample {
            current_a: f32::from_le_bytes(word(r, 4)),
            voltage_v: f32::from_le_bytes(word(r, 8)),
            temperature_c: f32::from_le_bytes(word(r, 8 + 4 * cells)),
        })
    }
}

impl PackSampler for ReplaySampler<'_> {
    fn cells(&self) -> usize {
        self.cells
    }

    fn sample_pack(&mut self, volts: &mut [f32]) -> Result<PackReading, SampleError> {
        let cells = self.cells;
        let r = self.records.next().ok_or(SampleError::EndOfStream)?;
        if u32::from_le_bytes(word(r, 0)) & 1 != 0 {
            return Err(SampleError::Dropped);
        }
        for (k, v) in volts.iter_mut().take(cells).enumerate() {
            *v = f32::from_le_bytes(word(r, 8 + 4 * k));
        }
        Ok(PackReading {
            current_a: f32::from_le_bytes(word(r, 4)),
            temperature_c: f32::from_le_bytes(word(r, 8 + 4 * cells)),
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
    fn a_pack_stream_plays_every_cell() {
        let mut rec = vec![0u8; 2 * replay_record(3)];
        let put = |r: &mut [u8], at: usize, x: f32| r[at..at + 4].copy_from_slice(&x.to_le_bytes());
        put(&mut rec, 4, -2.0);
        for k in 0..3 {
            put(&mut rec, 8 + 4 * k, [3.6, 3.7, 3.8][k]);
        }
        put(&mut rec, 20, 31.0);
        rec[24..28].copy_from_slice(&1u32.to_le_bytes());
        let mut r = ReplaySampler::with_cells(&rec, 3);
        assert_eq!(r.cells(), 3);
        let mut v = [0.0f32; 3];
        let p = r.sample_pack(&mut v).unwrap();
        assert_eq!((p.current_a, p.temperature_c), (-2.0, 31.0));
        assert_eq!(v, [3.6, 3.7, 3.8]);
        assert_eq!(r.sample_pack(&mut v), Err(SampleError::Dropped));
        assert_eq!(r.sample_pack(&mut v), Err(SampleError::EndOfStream));
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

//! TI bq769x0 (bq76920/30/40) cell monitor over embedded-hal 1.0 [`I2c`]:
//! one cell's voltage, the pack current from the coulomb counter and one
//! thermistor, as a [`CellSampler`].
//!
//! The chip converts cell voltages every 50 ms (14 bits, a factory gain
//! and offset in its EEPROM) and, with `CC_EN`, integrates the shunt voltage
//! over 250 ms windows (16 bits, 8.44 µV per count). [`Bq769x0::new`] reads
//! the factory calibration, sets `CC_CFG` to `0x19` as the datasheet
//! requires, and enables the ADC, the external thermistor input and the
//! continuous coulomb counter without touching the FET bits.
//!
//! Parts with a CRC (the `…03`/`…06` variants) are read and written with
//! CRC-8 (polynomial 0x07): set [`Bq769x0Config::crc`].
//!
//! Signs: the coulomb counter is positive when charging, as the core's
//! current (`estimator_core::battery`).

use crate::sampler::{CellSampler, Sample, SampleError};
use embedded_hal::i2c::I2c;

/// Registers used by the driver.
mod reg {
    pub const SYS_STAT: u8 = 0x00;
    pub const SYS_CTRL1: u8 = 0x04;
    pub const SYS_CTRL2: u8 = 0x05;
    pub const CC_CFG: u8 = 0x0B;
    pub const VC1_HI: u8 = 0x0C;
    pub const TS1_HI: u8 = 0x2C;
    pub const CC_HI: u8 = 0x32;
    pub const ADCGAIN1: u8 = 0x50;
    pub const ADCOFFSET: u8 = 0x51;
    pub const ADCGAIN2: u8 = 0x59;
}

/// `SYS_STAT`: a coulomb-counter reading is ready (write 1 to clear).
const CC_READY: u8 = 1 << 7;
/// `SYS_STAT`: an internal chip fault.
const DEVICE_XREADY: u8 = 1 << 5;
/// `SYS_CTRL1`: ADC on; thermistor inputs read external thermistors.
const ADC_EN: u8 = 1 << 4;
const TEMP_SEL: u8 = 1 << 3;
/// `SYS_CTRL2`: coulomb counter always on.
const CC_EN: u8 = 1 << 6;
/// The value `CC_CFG` must hold (datasheet, register description).
const CC_CFG_VALUE: u8 = 0x19;
/// Coulomb-counter volts per count.
const CC_VOLTS_PER_COUNT: f32 = 8.44e-6;
/// Thermistor-input volts per count.
const TS_VOLTS_PER_COUNT: f32 = 382e-6;
/// Largest 14-bit conversion.
const ADC14_FULL_SCALE: u16 = 0x3FFF;

/// A 10 kΩ-pull-up NTC thermistor on TS1 (β equation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Thermistor {
    /// Resistance at 25 °C (Ω).
    pub r25: f32,
    /// β (K).
    pub beta: f32,
}

impl Thermistor {
    /// A 10 kΩ, β = 3435 K NTC (the common 103AT type).
    pub const NTC_10K_3435: Self = Self {
        r25: 10_000.0,
        beta: 3435.0,
    };

    /// Temperature (°C) from the TS1 voltage, with the chip's internal
    /// 10 kΩ pull-up to 3.3 V.
    pub fn celsius(&self, v_ts: f32) -> f32 {
        let r = 10_000.0 * v_ts / (3.3 - v_ts);
        let inv_t = 1.0 / 298.15 + libm::logf(r / self.r25) / self.beta;
        1.0 / inv_t - 273.15
    }
}

/// Settings of the driver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bq769x0Config {
    /// 7-bit I²C address: 0x08 or 0x18 depending on the part number.
    pub address: u8,
    /// The part checks and sends CRC-8 bytes.
    pub crc: bool,
    /// Which cell input (1–15) is the estimated cell.
    pub cell: u8,
    /// Current-sense resistor (Ω).
    pub sense_ohm: f32,
    /// The thermistor on TS1.
    pub thermistor: Thermistor,
}

impl Default for Bq769x0Config {
    fn default() -> Self {
        Self {
            address: 0x08,
            crc: false,
            cell: 1,
            sense_ohm: 0.001,
            thermistor: Thermistor::NTC_10K_3435,
        }
    }
}

/// What can go wrong talking to the chip.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Bq769x0Error<E> {
    /// The bus failed.
    I2c(E),
    /// A byte arrived with a wrong CRC.
    Crc,
    /// The chip reports an internal fault (`DEVICE_XREADY`).
    DeviceFault,
    /// [`Bq769x0Config`] is invalid (cell outside 1–15, sense resistor not
    /// positive, address not 7-bit).
    Config,
}

impl<E> From<E> for Bq769x0Error<E> {
    fn from(e: E) -> Self {
        Self::I2c(e)
    }
}

/// CRC-8, polynomial x⁸ + x² + x + 1 (0x07), initial value 0.
pub fn crc8(bytes: &[u8]) -> u8 {
    let mut crc = 0u8;
    for &b in bytes {
        crc ^= b;
        for _ in 0..8 {
            crc = if crc & 0x80 != 0 {
                (crc << 1) ^ 0x07
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// The cell monitor.
pub struct Bq769x0<I> {
    i2c: I,
    cfg: Bq769x0Config,
    /// Factory ADC gain (V per count).
    gain: f32,
    /// Factory ADC offset (V).
    offset: f32,
}

impl<I: I2c> Bq769x0<I> {
    /// Reads the factory calibration and turns on the ADC, the external
    /// thermistor and the continuous coulomb counter.
    pub fn new(i2c: I, cfg: Bq769x0Config) -> Result<Self, Bq769x0Error<I::Error>> {
        if !(1..=15).contains(&cfg.cell)
            || cfg.sense_ohm.partial_cmp(&0.0) != Some(core::cmp::Ordering::Greater)
            || cfg.address > 0x7F
        {
            return Err(Bq769x0Error::Config);
        }
        let mut d = Self {
            i2c,
            cfg,
            gain: 0.0,
            offset: 0.0,
        };
        let mut g1 = [0];
        d.read(reg::ADCGAIN1, &mut g1)?;
        let mut g2 = [0];
        d.read(reg::ADCGAIN2, &mut g2)?;
        let mut off = [0];
        d.read(reg::ADCOFFSET, &mut off)?;
        // GAIN = 365 µV + ADCGAIN<4:0>, with bits 4:3 in ADCGAIN1<3:2> and
        // bits 2:0 in ADCGAIN2<7:5>.
        let code = ((g1[0] & 0x0C) << 1) | ((g2[0] & 0xE0) >> 5);
        d.gain = (365.0 + f32::from(code)) * 1e-6;
        d.offset = f32::from(off[0] as i8) * 1e-3;
        d.write(reg::CC_CFG, CC_CFG_VALUE)?;
        let mut c1 = [0];
        d.read(reg::SYS_CTRL1, &mut c1)?;
        d.write(reg::SYS_CTRL1, c1[0] | ADC_EN | TEMP_SEL)?;
        let mut c2 = [0];
        d.read(reg::SYS_CTRL2, &mut c2)?;
        d.write(reg::SYS_CTRL2, c2[0] | CC_EN)?;
        Ok(d)
    }

    /// Factory ADC gain (V per count) and offset (V).
    pub fn calibration(&self) -> (f32, f32) {
        (self.gain, self.offset)
    }

    /// Gives the bus back.
    pub fn release(self) -> I {
        self.i2c
    }

    /// Reads `buf.len()` registers from `first` (checking each CRC).
    fn read(&mut self, first: u8, buf: &mut [u8]) -> Result<(), Bq769x0Error<I::Error>> {
        let a = self.cfg.address;
        if !self.cfg.crc {
            self.i2c.write_read(a, &[first], buf)?;
            return Ok(());
        }
        // Each data byte is followed by its CRC; the first CRC also covers
        // the address byte of the read.
        let mut raw = [0u8; 4];
        for (k, chunk) in buf.chunks_mut(2).enumerate() {
            let n = 2 * chunk.len();
            let reg = first.wrapping_add(2 * k as u8);
            self.i2c.write_read(a, &[reg], &mut raw[..n])?;
            for (j, out) in chunk.iter_mut().enumerate() {
                let (b, c) = (raw[2 * j], raw[2 * j + 1]);
                let crc = if j == 0 {
                    crc8(&[(a << 1) | 1, b])
                } else {
                    crc8(&[b])
                };
                if crc != c {
                    return Err(Bq769x0Error::Crc);
                }
                *out = b;
            }
        }
        Ok(())
    }

    fn write(&mut self, r: u8, v: u8) -> Result<(), Bq769x0Error<I::Error>> {
        let a = self.cfg.address;
        if self.cfg.crc {
            let c = crc8(&[a << 1, r, v]);
            self.i2c.write(a, &[r, v, c])?;
        } else {
            self.i2c.write(a, &[r, v])?;
        }
        Ok(())
    }

    fn read14(&mut self, hi: u8) -> Result<u16, Bq769x0Error<I::Error>> {
        let mut b = [0; 2];
        self.read(hi, &mut b)?;
        Ok((u16::from(b[0] & 0x3F) << 8) | u16::from(b[1]))
    }

    /// One reading: the cell's voltage, the last coulomb-counter current
    /// and the TS1 temperature. A cell conversion at 0 or full scale is
    /// `Ok(None)` (saturated).
    pub fn read_sample(&mut self) -> Result<Option<Sample>, Bq769x0Error<I::Error>> {
        let mut stat = [0];
        self.read(reg::SYS_STAT, &mut stat)?;
        if stat[0] & DEVICE_XREADY != 0 {
            return Err(Bq769x0Error::DeviceFault);
        }
        let vc = self.read14(reg::VC1_HI + 2 * (self.cfg.cell - 1))?;
        let mut cc = [0; 2];
        self.read(reg::CC_HI, &mut cc)?;
        if stat[0] & CC_READY != 0 {
            self.write(reg::SYS_STAT, CC_READY)?;
        }
        let ts = self.read14(reg::TS1_HI)?;
        if vc == 0 || vc >= ADC14_FULL_SCALE {
            return Ok(None);
        }
        let counts = i16::from_be_bytes(cc);
        Ok(Some(Sample {
            current_a: f32::from(counts) * CC_VOLTS_PER_COUNT / self.cfg.sense_ohm,
            voltage_v: self.gain * f32::from(vc) + self.offset,
            temperature_c: self
                .cfg
                .thermistor
                .celsius(f32::from(ts) * TS_VOLTS_PER_COUNT),
        }))
    }
}

impl<I: I2c> CellSampler for Bq769x0<I> {
    fn sample(&mut self) -> Result<Sample, SampleError> {
        match self.read_sample() {
            Ok(Some(s)) => Ok(s),
            Ok(None) => Err(SampleError::Saturated),
            Err(_) => Err(SampleError::Adc),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};

    const A: u8 = 0x08;

    /// Start-up transactions: gain code 0b10_101 = 21 → 386 µV, offset
    /// −3 mV; SYS_CTRL2 keeps its FET bits (0b11).
    fn startup() -> Vec<T> {
        vec![
            T::write_read(A, vec![0x50], vec![0b0000_1000]),
            T::write_read(A, vec![0x59], vec![0b1010_0000]),
            T::write_read(A, vec![0x51], vec![(-3i8) as u8]),
            T::write(A, vec![0x0B, 0x19]),
            T::write_read(A, vec![0x04], vec![0x00]),
            T::write(A, vec![0x04, 0x18]),
            T::write_read(A, vec![0x05], vec![0x03]),
            T::write(A, vec![0x05, 0x43]),
        ]
    }

    fn cfg() -> Bq769x0Config {
        Bq769x0Config {
            cell: 2,
            sense_ohm: 0.001,
            ..Default::default()
        }
    }

    #[test]
    fn reads_calibration_and_converts_one_sample() {
        let vc: u16 = 9590; // 386 µV × 9590 − 3 mV = 3.69874 V
        let ts: u16 = 4320; // 1.65 V: the thermistor equals its 10 kΩ pull-up → 25 °C
        let cc: i16 = -2370; // −2370 × 8.44 µV / 1 mΩ = −20.0 A (discharging)
        let mut t = startup();
        t.extend([
            T::write_read(A, vec![0x00], vec![CC_READY]),
            T::write_read(A, vec![0x0E], vec![(vc >> 8) as u8, vc as u8]),
            T::write_read(A, vec![0x32], cc.to_be_bytes().to_vec()),
            T::write(A, vec![0x00, CC_READY]),
            T::write_read(A, vec![0x2C], vec![(ts >> 8) as u8, ts as u8]),
        ]);
        let mut bus = Mock::new(&t);
        let mut d = Bq769x0::new(bus.clone(), cfg()).unwrap();
        let (g, o) = d.calibration();
        assert!(
            (g - 386e-6).abs() < 1e-12 && (o + 3e-3).abs() < 1e-9,
            "{g} {o}"
        );
        let s = d.sample().unwrap();
        assert!((s.voltage_v - 3.698_74).abs() < 1e-5, "{}", s.voltage_v);
        assert!((s.current_a + 20.0028).abs() < 1e-3, "{}", s.current_a);
        assert!((s.temperature_c - 25.0).abs() < 0.1, "{}", s.temperature_c);
        bus.done();
    }

    #[test]
    fn saturated_cell_and_chip_fault_are_reported() {
        let mut t = startup();
        t.extend([
            T::write_read(A, vec![0x00], vec![0]),
            T::write_read(A, vec![0x0E], vec![0x3F, 0xFF]),
            T::write_read(A, vec![0x32], vec![0, 0]),
            T::write_read(A, vec![0x2C], vec![0x10, 0xE0]),
            T::write_read(A, vec![0x00], vec![DEVICE_XREADY]),
        ]);
        let mut bus = Mock::new(&t);
        let mut d = Bq769x0::new(bus.clone(), cfg()).unwrap();
        assert_eq!(d.sample(), Err(SampleError::Saturated));
        assert_eq!(d.read_sample(), Err(Bq769x0Error::DeviceFault));
        bus.done();
    }

    #[test]
    fn crc_frames_are_checked_both_ways() {
        // The CRC-8/SMBUS check value: CRC-8 of "123456789" is 0xF4.
        assert_eq!(crc8(b"123456789"), 0xF4);
        let c = |b: &[u8]| crc8(b);
        let rd = (A << 1) | 1;
        let cfg = Bq769x0Config { crc: true, ..cfg() };
        let t = vec![
            T::write_read(A, vec![0x50], vec![0x08, c(&[rd, 0x08])]),
            T::write_read(A, vec![0x59], vec![0xA0, c(&[rd, 0xA0])]),
            T::write_read(A, vec![0x51], vec![0xFD, c(&[rd, 0xFD]) ^ 1]),
        ];
        let mut bus = Mock::new(&t);
        assert_eq!(
            Bq769x0::new(bus.clone(), cfg).err(),
            Some(Bq769x0Error::Crc)
        );
        bus.done();
        let w = vec![
            T::write_read(A, vec![0x50], vec![0x08, c(&[rd, 0x08])]),
            T::write_read(A, vec![0x59], vec![0xA0, c(&[rd, 0xA0])]),
            T::write_read(A, vec![0x51], vec![0xFD, c(&[rd, 0xFD])]),
            T::write(A, vec![0x0B, 0x19, c(&[A << 1, 0x0B, 0x19])]),
            T::write_read(A, vec![0x04], vec![0x00, c(&[rd, 0x00])]),
            T::write(A, vec![0x04, 0x18, c(&[A << 1, 0x04, 0x18])]),
            T::write_read(A, vec![0x05], vec![0x00, c(&[rd, 0x00])]),
            T::write(A, vec![0x05, 0x40, c(&[A << 1, 0x05, 0x40])]),
        ];
        let mut bus = Mock::new(&w);
        assert!(Bq769x0::new(bus.clone(), cfg).is_ok());
        bus.done();
    }

    #[test]
    fn bad_settings_are_refused_before_any_bus_traffic() {
        for bad in [
            Bq769x0Config { cell: 0, ..cfg() },
            Bq769x0Config { cell: 16, ..cfg() },
            Bq769x0Config {
                sense_ohm: f32::NAN,
                ..cfg()
            },
            Bq769x0Config {
                address: 0x80,
                ..cfg()
            },
        ] {
            let mut bus = Mock::new(&[]);
            assert_eq!(
                Bq769x0::new(bus.clone(), bad).err(),
                Some(Bq769x0Error::Config)
            );
            bus.done();
        }
    }
}

//! TI bq769x0 (bq76920/30/40) cell monitor over embedded-hal 1.0 [`I2c`]:
//! every connected cell's voltage (5/10/15 inputs) in one bus transaction,
//! the pack current from the coulomb counter and one thermistor, as a
//! [`PackSampler`] (and one cell of them as a [`CellSampler`]).
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

use crate::sampler::{CellSampler, PackReading, PackSampler, Sample, SampleError};
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
/// Cell inputs of the largest part (bq76940).
pub const MAX_CELLS: usize = 15;

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
    /// Which cell input (1–15) is the estimated cell of the one-cell
    /// [`CellSampler`].
    pub cell: u8,
    /// Connected cells read by the [`PackSampler`], inputs VC1…VCn (1–15:
    /// up to 5 on a bq76920, 10 on a bq76930, 15 on a bq76940).
    pub cells: u8,
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
            cells: 1,
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
    /// [`Bq769x0Config`] is invalid (cell or cell count outside 1–15, sense
    /// resistor not positive, address not 7-bit), or a read asked for more
    /// cells than configured.
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
            || !(1..=15).contains(&cfg.cells)
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

    /// Reads `buf.len()` registers from `first` in one transaction
    /// (checking each CRC; at most `2·MAX_CELLS` registers).
    fn read(&mut self, first: u8, buf: &mut [u8]) -> Result<(), Bq769x0Error<I::Error>> {
        let a = self.cfg.address;
        if !self.cfg.crc {
            self.i2c.write_read(a, &[first], buf)?;
            return Ok(());
        }
        // Each data byte is followed by its CRC; the first CRC also covers
        // the address byte of the read.
        let mut raw = [0u8; 4 * MAX_CELLS];
        let n = 2 * buf.len();
        if n > raw.len() {
            return Err(Bq769x0Error::Config);
        }
        self.i2c.write_read(a, &[first], &mut raw[..n])?;
        for (j, out) in buf.iter_mut().enumerate() {
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

impl<I: I2c> Bq769x0<I> {
    /// One reading of the pack: the voltages of cells 1…`cells` of the
    /// configuration into `volts` (one transaction over VC1_HI…VCn_LO; a
    /// conversion at 0 or full scale is NaN: that cell's sample is
    /// rejected), the last coulomb-counter current and the TS1 temperature.
    ///
    /// # Errors
    /// Bus and CRC errors, a chip fault; [`Bq769x0Error::Config`] when
    /// `volts` is shorter than the configured cells.
    pub fn read_cells(&mut self, volts: &mut [f32]) -> Result<PackReading, Bq769x0Error<I::Error>> {
        let cells = usize::from(self.cfg.cells);
        if volts.len() < cells {
            return Err(Bq769x0Error::Config);
        }
        let mut stat = [0];
        self.read(reg::SYS_STAT, &mut stat)?;
        if stat[0] & DEVICE_XREADY != 0 {
            return Err(Bq769x0Error::DeviceFault);
        }
        let mut vc = [0u8; 2 * MAX_CELLS];
        self.read(reg::VC1_HI, &mut vc[..2 * cells])?;
        let mut cc = [0; 2];
        self.read(reg::CC_HI, &mut cc)?;
        if stat[0] & CC_READY != 0 {
            self.write(reg::SYS_STAT, CC_READY)?;
        }
        let ts = self.read14(reg::TS1_HI)?;
        for (v, pair) in volts.iter_mut().zip(vc[..2 * cells].chunks_exact(2)) {
            let raw = (u16::from(pair[0] & 0x3F) << 8) | u16::from(pair[1]);
            *v = if raw == 0 || raw >= ADC14_FULL_SCALE {
                f32::NAN
            } else {
                self.gain * f32::from(raw) + self.offset
            };
        }
        Ok(PackReading {
            current_a: f32::from(i16::from_be_bytes(cc)) * CC_VOLTS_PER_COUNT / self.cfg.sense_ohm,
            temperature_c: self
                .cfg
                .thermistor
                .celsius(f32::from(ts) * TS_VOLTS_PER_COUNT),
        })
    }
}

impl<I: I2c> PackSampler for Bq769x0<I> {
    fn cells(&self) -> usize {
        usize::from(self.cfg.cells)
    }

    fn sample_pack(&mut self, volts: &mut [f32]) -> Result<PackReading, SampleError> {
        self.read_cells(volts).map_err(|_| SampleError::Adc)
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
    fn reads_every_cell_in_one_transaction() {
        // A bq76940 with 15 cells: one write_read of 30 bytes from VC1_HI.
        let codes: Vec<u16> = (0..15).map(|k| 9500 + 10 * k).collect();
        let mut bytes: Vec<u8> = codes.iter().flat_map(|c| c.to_be_bytes()).collect();
        bytes[2 * 6] = 0x3F; // cell 7 saturated
        bytes[2 * 6 + 1] = 0xFF;
        let mut t = startup();
        t.extend([
            T::write_read(A, vec![0x00], vec![0]),
            T::write_read(A, vec![0x0C], bytes),
            T::write_read(A, vec![0x32], 2370i16.to_be_bytes().to_vec()),
            T::write_read(A, vec![0x2C], vec![0x10, 0xE0]),
        ]);
        let mut bus = Mock::new(&t);
        let cfg = Bq769x0Config { cells: 15, ..cfg() };
        let mut d = Bq769x0::new(bus.clone(), cfg).unwrap();
        assert_eq!(PackSampler::cells(&d), 15);
        let mut v = [0.0f32; 15];
        let p = d.sample_pack(&mut v).unwrap();
        assert!((p.current_a - 20.0028).abs() < 1e-3, "{p:?}");
        for (k, &x) in v.iter().enumerate() {
            if k == 6 {
                assert!(x.is_nan(), "the saturated cell alone is NaN");
            } else {
                let want = 386e-6 * f32::from(codes[k]) - 3e-3;
                assert!((x - want).abs() < 1e-5, "cell {}: {x} {want}", k + 1);
            }
        }
        // Fewer slots than cells: a typed error before any traffic.
        assert_eq!(
            d.read_cells(&mut [0.0; 3]).err(),
            Some(Bq769x0Error::Config)
        );
        bus.done();
    }

    #[test]
    fn crc_block_read_checks_every_byte() {
        let c = |b: &[u8]| crc8(b);
        let rd = (A << 1) | 1;
        let mut t: Vec<T> = vec![
            T::write_read(A, vec![0x50], vec![0x08, c(&[rd, 0x08])]),
            T::write_read(A, vec![0x59], vec![0xA0, c(&[rd, 0xA0])]),
            T::write_read(A, vec![0x51], vec![0xFD, c(&[rd, 0xFD])]),
            T::write(A, vec![0x0B, 0x19, c(&[A << 1, 0x0B, 0x19])]),
            T::write_read(A, vec![0x04], vec![0x00, c(&[rd, 0x00])]),
            T::write(A, vec![0x04, 0x18, c(&[A << 1, 0x04, 0x18])]),
            T::write_read(A, vec![0x05], vec![0x00, c(&[rd, 0x00])]),
            T::write(A, vec![0x05, 0x40, c(&[A << 1, 0x05, 0x40])]),
            T::write_read(A, vec![0x00], vec![0x00, c(&[rd, 0x00])]),
        ];
        // Three cells, six data bytes, the fourth CRC wrong.
        let data = [0x25u8, 0x76, 0x25, 0x80, 0x25, 0x8A];
        let mut framed = Vec::new();
        for (j, &b) in data.iter().enumerate() {
            framed.push(b);
            let crc = if j == 0 { c(&[rd, b]) } else { c(&[b]) };
            framed.push(if j == 3 { crc ^ 1 } else { crc });
        }
        t.push(T::write_read(A, vec![0x0C], framed));
        let mut bus = Mock::new(&t);
        let cfg = Bq769x0Config {
            crc: true,
            cells: 3,
            ..cfg()
        };
        let mut d = Bq769x0::new(bus.clone(), cfg).unwrap();
        assert_eq!(d.read_cells(&mut [0.0; 3]).err(), Some(Bq769x0Error::Crc));
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
            Bq769x0Config { cells: 0, ..cfg() },
            Bq769x0Config { cells: 16, ..cfg() },
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

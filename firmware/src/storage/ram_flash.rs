//! A NOR flash in RAM: what the QEMU board stores its snapshot in (the
//! mps2-an386 has no flash controller to program), and what the power-fail
//! test cuts. It keeps NOR's rules: an erase sets a page to `0xFF`, a write
//! only clears bits (it ANDs), writes are whole words, erases whole pages.
//!
//! A power cut can be armed ([`RamFlash::cut_at`]): the write or erase
//! step with that number is torn (its first half applied, the rest not) and
//! every step after it fails, as when the supply drops mid-operation.

use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// A flash error of the RAM model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RamFlashError {
    /// Outside the memory, or not aligned to a word or a page.
    Bounds,
    /// The power was cut.
    PowerCut,
}

impl NorFlashError for RamFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            RamFlashError::Bounds => NorFlashErrorKind::OutOfBounds,
            RamFlashError::PowerCut => NorFlashErrorKind::Other,
        }
    }
}

/// NOR flash over a byte slice: words of `WORD` bytes, pages of `PAGE`.
pub struct RamFlash<'a, const WORD: usize, const PAGE: usize> {
    memory: &'a mut [u8],
    /// Write and erase steps so far.
    steps: usize,
    /// The step that is torn by a power cut (`None`: no cut armed).
    cut: Option<usize>,
    /// Pages erased whole since [`RamFlash::new`].
    erased: usize,
}

impl<'a, const WORD: usize, const PAGE: usize> RamFlash<'a, WORD, PAGE> {
    /// A flash over `memory` (its contents are the flash's; a new part is
    /// erased: fill it with `0xFF`).
    pub fn new(memory: &'a mut [u8]) -> Self {
        Self {
            memory,
            steps: 0,
            cut: None,
            erased: 0,
        }
    }

    /// Pages erased whole since [`new`](Self::new) (the wear).
    pub fn pages_erased(&self) -> usize {
        self.erased
    }

    /// Tears step `step` (0-based, counting writes and erases from now)
    /// and fails every step after it.
    pub fn cut_at(&mut self, step: usize) {
        self.steps = 0;
        self.cut = Some(step);
    }

    /// Write and erase steps since the start or the last [`cut_at`](Self::cut_at).
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Whether the power is cut (a step at or after the armed one ran).
    pub fn is_cut(&self) -> bool {
        self.cut.is_some_and(|c| self.steps > c)
    }

    /// Counts a step: `Ok(true)` to apply it whole, `Ok(false)` to tear it,
    /// `Err` when the power is already cut.
    fn step(&mut self) -> Result<bool, RamFlashError> {
        let k = self.steps;
        self.steps += 1;
        match self.cut {
            Some(c) if k > c => Err(RamFlashError::PowerCut),
            Some(c) if k == c => Ok(false),
            _ => Ok(true),
        }
    }

    fn range(&mut self, from: u32, len: usize) -> Result<&mut [u8], RamFlashError> {
        let from = from as usize;
        self.memory
            .get_mut(from..from.saturating_add(len))
            .ok_or(RamFlashError::Bounds)
    }
}

impl<const WORD: usize, const PAGE: usize> ErrorType for RamFlash<'_, WORD, PAGE> {
    type Error = RamFlashError;
}

impl<const WORD: usize, const PAGE: usize> ReadNorFlash for RamFlash<'_, WORD, PAGE> {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        if self.is_cut() {
            return Err(RamFlashError::PowerCut);
        }
        let src = self.range(offset, bytes.len())?;
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.memory.len()
    }
}

impl<const WORD: usize, const PAGE: usize> NorFlash for RamFlash<'_, WORD, PAGE> {
    const WRITE_SIZE: usize = WORD;
    const ERASE_SIZE: usize = PAGE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        if !(from as usize).is_multiple_of(PAGE) || !(to as usize).is_multiple_of(PAGE) || to < from
        {
            return Err(RamFlashError::Bounds);
        }
        self.range(from, (to - from) as usize)?;
        // One step per page, as a flash controller erases them.
        for page in (from..to).step_by(PAGE) {
            let whole = self.step()?;
            let p = self.range(page, PAGE)?;
            let n = if whole { PAGE } else { PAGE / 2 };
            p[..n].fill(0xFF);
            if !whole {
                return Err(RamFlashError::PowerCut);
            }
            self.erased += 1;
        }
        Ok(())
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        if !(offset as usize).is_multiple_of(WORD) || !bytes.len().is_multiple_of(WORD) {
            return Err(RamFlashError::Bounds);
        }
        self.range(offset, bytes.len())?;
        let whole = self.step()?;
        let words = bytes.len() / WORD;
        let n = if whole { words } else { words / 2 } * WORD;
        let dst = self.range(offset, bytes.len())?;
        for (d, s) in dst.iter_mut().zip(bytes).take(n) {
            *d &= *s;
        }
        if whole {
            Ok(())
        } else {
            Err(RamFlashError::PowerCut)
        }
    }
}

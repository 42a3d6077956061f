//! The loaded sections of an ELF image (to read the constants the code
//! loads: panic locations).

/// The loaded sections of an ELF32 little-endian image.
pub(super) struct Elf<'a> {
    /// (address, bytes) of every section with contents in memory.
    pub(super) sections: Vec<(u32, &'a [u8])>,
}

impl<'a> Elf<'a> {
    pub(super) fn parse(b: &'a [u8]) -> Option<Self> {
        if b.get(..6)? != b"\x7fELF\x01\x01" {
            return None;
        }
        let u16_at = |o: usize| Some(u16::from_le_bytes(b.get(o..o + 2)?.try_into().ok()?));
        let u32_at = |o: usize| Some(u32::from_le_bytes(b.get(o..o + 4)?.try_into().ok()?));
        let (shoff, size, count) = (
            u32_at(0x20)? as usize,
            u16_at(0x2e)? as usize,
            u16_at(0x30)? as usize,
        );
        let mut sections = Vec::new();
        for k in 0..count {
            let h = shoff + k * size;
            // SHT_PROGBITS with SHF_ALLOC.
            if u32_at(h + 4)? == 1 && u32_at(h + 8)? & 2 != 0 {
                let (addr, off, len) = (u32_at(h + 12)?, u32_at(h + 16)?, u32_at(h + 20)?);
                sections.push((addr, b.get(off as usize..(off + len) as usize)?));
            }
        }
        Some(Self { sections })
    }

    pub(super) fn bytes(&self, addr: u32, len: usize) -> Option<&'a [u8]> {
        self.sections.iter().find_map(|&(a, d)| {
            let o = addr.checked_sub(a)? as usize;
            d.get(o..o.checked_add(len)?)
        })
    }

    pub(super) fn u32_at(&self, addr: u32) -> Option<u32> {
        Some(u32::from_le_bytes(self.bytes(addr, 4)?.try_into().ok()?))
    }

    /// `core::panic::Location` at `addr` (file pointer and length, line,
    /// column) as `file:line:col`, if it looks like one.
    pub(super) fn location(&self, addr: u32) -> Option<String> {
        let at = |o: u32| self.u32_at(addr.checked_add(o)?);
        let (ptr, len, line, col) = (at(0)?, at(4)?, at(8)?, at(12)?);
        if !(1..=4096).contains(&len) || line == 0 {
            return None;
        }
        let file = std::str::from_utf8(self.bytes(ptr, len as usize)?).ok()?;
        file.ends_with(".rs")
            .then(|| format!("{file}:{line}:{col}"))
    }
}

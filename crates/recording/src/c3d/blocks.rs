//! The C3D format's building blocks that both the reader and the writer need: the block
//! size, the key byte and the processor types with their byte orders.

/// C3D files are laid out in blocks of this many bytes.
pub(super) const BLOCK: usize = 512;
/// Second byte of a C3D header and of its parameter section.
pub(super) const KEY: u8 = 0x50;
/// Processor type byte of an Intel (little-endian, IEEE float) file.
pub(super) const INTEL: u8 = 0x54;

/// Byte order and float format of a file (the processor type of its parameter section).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Cpu {
    Intel,
    Dec,
    Mips,
}

impl Cpu {
    pub(super) fn from_byte(byte: u8) -> Option<Self> {
        match byte {
            0x54 => Some(Self::Intel),
            0x55 => Some(Self::Dec),
            0x56 => Some(Self::Mips),
            _ => None,
        }
    }

    pub(super) fn u16(self, b: [u8; 2]) -> u16 {
        match self {
            Self::Intel | Self::Dec => u16::from_le_bytes(b),
            Self::Mips => u16::from_be_bytes(b),
        }
    }

    pub(super) fn u16_bytes(self, v: u16) -> [u8; 2] {
        match self {
            Self::Intel | Self::Dec => v.to_le_bytes(),
            Self::Mips => v.to_be_bytes(),
        }
    }

    /// A float as c3dio 0.8 decodes it (DEC: words swapped, exponent lowered by 2).
    pub(super) fn f32(self, b: [u8; 4]) -> f32 {
        match self {
            Self::Intel => f32::from_le_bytes(b),
            Self::Mips => f32::from_be_bytes(b),
            Self::Dec => {
                let high = if b[1] == 0 { 0 } else { b[1] - 1 };
                f32::from_le_bytes([b[2], b[3], b[0], high])
            }
        }
    }
}

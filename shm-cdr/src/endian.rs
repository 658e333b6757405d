//! Byte order of the wire: chosen at compile time for writers and readers so the
//! per-primitive branch disappears.

mod sealed {
    pub trait Sealed {}
}

/// A CDR byte order. Implemented only by [`LittleEndian`] and [`BigEndian`].
pub trait ByteOrder: sealed::Sealed + Copy + Send + Sync + 'static {
    /// `true` for little-endian.
    const LITTLE: bool;
    /// `true` when this order equals the host's, so arrays of primitives can be
    /// copied in bulk.
    const NATIVE: bool = Self::LITTLE == cfg!(target_endian = "little");
    /// The run-time value of this order.
    const ENDIANNESS: Endianness;
}

/// Little-endian CDR (encapsulation `00 01`), what ROS 2 writes on every common host.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LittleEndian;

/// Big-endian CDR (encapsulation `00 00`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BigEndian;

impl sealed::Sealed for LittleEndian {}
impl sealed::Sealed for BigEndian {}

impl ByteOrder for LittleEndian {
    const LITTLE: bool = true;
    const ENDIANNESS: Endianness = Endianness::Little;
}

impl ByteOrder for BigEndian {
    const LITTLE: bool = false;
    const ENDIANNESS: Endianness = Endianness::Big;
}

/// A byte order chosen at run time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Endianness {
    /// Little-endian, encapsulation `00 01 00 00`. The default, as in ROS 2.
    #[default]
    Little,
    /// Big-endian, encapsulation `00 00 00 00`.
    Big,
}

impl Endianness {
    /// The 4-byte encapsulation header that starts a message in this byte order.
    pub const fn header(self) -> [u8; 4] {
        match self {
            Self::Little => [0x00, 0x01, 0x00, 0x00],
            Self::Big => [0x00, 0x00, 0x00, 0x00],
        }
    }
}

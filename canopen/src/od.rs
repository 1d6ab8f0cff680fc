//! The object dictionary: objects by 16-bit index, their entries by 8-bit sub-index (CiA 301
//! 7.4), each with a data type (Table 44), an access type, optional limits and a value kept as the
//! little-endian bytes SDO carries (7.1.2). Reads and writes are checked as an SDO server must
//! check them, and fail with the abort code CiA 301 Table 22 names.

use std::collections::BTreeMap;

use crate::sdo::Abort;

/// The static data types of CiA 301 Table 44 that devices use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DataType {
    /// 0x0001, one byte 0 or 1.
    Boolean,
    /// 0x0002, 0x0003, 0x0010, 0x0004, 0x0015: signed integers of this many bytes.
    Integer(usize),
    /// 0x0005, 0x0006, 0x0016, 0x0007, 0x001B: unsigned integers of this many bytes.
    Unsigned(usize),
    /// 0x0008.
    Real32,
    /// 0x0011.
    Real64,
    /// 0x0009.
    VisibleString,
    /// 0x000A.
    OctetString,
    /// 0x000F.
    Domain,
}

impl DataType {
    /// The type of a CiA 301 data type index, if it is one of ours.
    pub fn from_index(index: u16) -> Option<DataType> {
        Some(match index {
            0x0001 => DataType::Boolean,
            0x0002 => DataType::Integer(1),
            0x0003 => DataType::Integer(2),
            0x0010 => DataType::Integer(3),
            0x0004 => DataType::Integer(4),
            0x0015 => DataType::Integer(8),
            0x0005 => DataType::Unsigned(1),
            0x0006 => DataType::Unsigned(2),
            0x0016 => DataType::Unsigned(3),
            0x0007 => DataType::Unsigned(4),
            0x001B => DataType::Unsigned(8),
            0x0008 => DataType::Real32,
            0x0011 => DataType::Real64,
            0x0009 => DataType::VisibleString,
            0x000A => DataType::OctetString,
            0x000F => DataType::Domain,
            _ => return None,
        })
    }

    /// Its index in CiA 301 Table 44 (the EDS DataType).
    pub fn index(self) -> u16 {
        match self {
            DataType::Boolean => 0x0001,
            DataType::Integer(1) => 0x0002,
            DataType::Integer(2) => 0x0003,
            DataType::Integer(3) => 0x0010,
            DataType::Integer(4) => 0x0004,
            DataType::Integer(_) => 0x0015,
            DataType::Unsigned(1) => 0x0005,
            DataType::Unsigned(2) => 0x0006,
            DataType::Unsigned(3) => 0x0016,
            DataType::Unsigned(4) => 0x0007,
            DataType::Unsigned(_) => 0x001B,
            DataType::Real32 => 0x0008,
            DataType::Real64 => 0x0011,
            DataType::VisibleString => 0x0009,
            DataType::OctetString => 0x000A,
            DataType::Domain => 0x000F,
        }
    }

    /// Its length in bytes, for the types of fixed length.
    pub fn size(self) -> Option<usize> {
        match self {
            DataType::Boolean => Some(1),
            DataType::Integer(n) | DataType::Unsigned(n) => Some(n),
            DataType::Real32 => Some(4),
            DataType::Real64 => Some(8),
            DataType::VisibleString | DataType::OctetString | DataType::Domain => None,
        }
    }

    /// `bytes` (little endian) as a number, for the integer types.
    pub fn number(self, bytes: &[u8]) -> Option<i128> {
        let integer = matches!(
            self,
            DataType::Boolean | DataType::Integer(_) | DataType::Unsigned(_)
        );
        if !integer || bytes.len() > 16 {
            return None;
        }
        let mut raw = [0u8; 16];
        raw[..bytes.len()].copy_from_slice(bytes);
        let unsigned = u128::from_le_bytes(raw);
        match self {
            DataType::Boolean | DataType::Unsigned(_) => Some(unsigned as i128),
            DataType::Integer(n) => {
                let shift = 128 - 8 * n as u32;
                Some(((unsigned << shift) as i128) >> shift)
            }
            _ => None,
        }
    }

    /// `value` in this integer type's bytes, if it fits.
    pub fn encode(self, value: i128) -> Option<Vec<u8>> {
        let n = self.size()?;
        let bits = 8 * n as u32;
        let fits = match self {
            DataType::Boolean => (0..=1).contains(&value),
            DataType::Unsigned(_) => value >= 0 && (bits == 128 || value < 1i128 << bits),
            DataType::Integer(_) => {
                let half = 1i128 << (bits - 1);
                (-half..half).contains(&value)
            }
            _ => return None,
        };
        fits.then(|| value.to_le_bytes()[..n].to_vec())
    }
}

/// Who may read and write an entry (CiA 306 AccessType).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Read only; the device may change it.
    ReadOnly,
    /// Write only.
    WriteOnly,
    /// Read and write (`rw`, `rwr`, `rww`).
    ReadWrite,
    /// Read only and never changes.
    Const,
}

impl Access {
    /// Whether an SDO client may read it.
    pub fn readable(self) -> bool {
        self != Access::WriteOnly
    }

    /// Whether an SDO client may write it.
    pub fn writable(self) -> bool {
        matches!(self, Access::WriteOnly | Access::ReadWrite)
    }
}

/// One entry: a sub-index of an object (or the object itself, sub-index 0 of a VAR).
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// ParameterName.
    pub name: String,
    /// Its data type.
    pub data_type: DataType,
    /// Its access type.
    pub access: Access,
    /// Its value, in the bytes SDO carries.
    pub value: Vec<u8>,
    /// LowLimit and HighLimit, for integers.
    pub limits: (Option<i128>, Option<i128>),
    /// Whether a PDO may map it.
    pub pdo_mappable: bool,
}

/// What an object is (CiA 301 Table 42).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjectKind {
    /// A single value (0x7).
    Var,
    /// Entries of one type (0x8).
    Array,
    /// Entries of several types (0x9).
    Record,
}

/// An object: its entries by sub-index.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// ParameterName.
    pub name: String,
    /// Its kind.
    pub kind: ObjectKind,
    /// Its entries (a VAR has sub-index 0 only).
    pub entries: BTreeMap<u8, Entry>,
}

/// The object dictionary of a device.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectDictionary {
    /// Objects by index.
    pub objects: BTreeMap<u16, Object>,
}

impl ObjectDictionary {
    /// Entry `index`:`sub`, or the abort code for a missing object (0602 0000) or sub-index
    /// (0609 0011).
    pub fn entry(&self, index: u16, sub: u8) -> Result<&Entry, Abort> {
        let object = self.objects.get(&index).ok_or(Abort::NO_OBJECT)?;
        object.entries.get(&sub).ok_or(Abort::NO_SUB_INDEX)
    }

    fn entry_mut(&mut self, index: u16, sub: u8) -> Result<&mut Entry, Abort> {
        let object = self.objects.get_mut(&index).ok_or(Abort::NO_OBJECT)?;
        object.entries.get_mut(&sub).ok_or(Abort::NO_SUB_INDEX)
    }

    /// An SDO client reads `index`:`sub`.
    pub fn read(&self, index: u16, sub: u8) -> Result<Vec<u8>, Abort> {
        let entry = self.entry(index, sub)?;
        if !entry.access.readable() {
            return Err(Abort::WRITE_ONLY);
        }
        Ok(entry.value.clone())
    }

    /// An SDO client writes `bytes` to `index`:`sub`: the entry must exist and be writable, the
    /// length must be the type's, and a number must be within the limits.
    pub fn write(&mut self, index: u16, sub: u8, bytes: &[u8]) -> Result<(), Abort> {
        let entry = self.entry_mut(index, sub)?;
        if !entry.access.writable() {
            return Err(Abort::READ_ONLY);
        }
        let data_type = entry.data_type;
        if let Some(size) = data_type.size() {
            match bytes.len().cmp(&size) {
                std::cmp::Ordering::Greater => return Err(Abort::LENGTH_TOO_HIGH),
                std::cmp::Ordering::Less => return Err(Abort::LENGTH_TOO_LOW),
                std::cmp::Ordering::Equal => {}
            }
        }
        if let Some(value) = data_type.number(bytes) {
            if data_type == DataType::Boolean && value > 1 {
                return Err(Abort::VALUE_RANGE);
            }
            if entry.limits.1.is_some_and(|high| value > high) {
                return Err(Abort::VALUE_TOO_HIGH);
            }
            if entry.limits.0.is_some_and(|low| value < low) {
                return Err(Abort::VALUE_TOO_LOW);
            }
        }
        if sub == 0 && crate::pdo::is_mapping(index) {
            let count = data_type.number(bytes).unwrap_or(0) as u64;
            crate::pdo::check_mapping(self, index, count)?;
        }
        self.set(index, sub, bytes);
        Ok(())
    }

    /// The device sets `index`:`sub` itself (no access check), if it exists.
    pub fn set(&mut self, index: u16, sub: u8, bytes: &[u8]) {
        if let Ok(entry) = self.entry_mut(index, sub) {
            entry.value = bytes.to_vec();
        }
    }

    /// `index`:`sub` as an unsigned number (0 if it does not exist or is no integer).
    pub fn unsigned(&self, index: u16, sub: u8) -> u64 {
        self.entry(index, sub)
            .ok()
            .and_then(|e| e.data_type.number(&e.value))
            .map_or(0, |v| v as u64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dictionary() -> ObjectDictionary {
        let entry = |access, limits| Entry {
            name: "x".into(),
            data_type: DataType::Integer(2),
            access,
            value: vec![0, 0],
            limits,
            pdo_mappable: false,
        };
        let mut objects = BTreeMap::new();
        for (index, access, limits) in [
            (0x2000, Access::ReadWrite, (Some(-100), Some(100))),
            (0x2001, Access::ReadOnly, (None, None)),
            (0x2002, Access::WriteOnly, (None, None)),
        ] {
            objects.insert(
                index,
                Object {
                    name: "x".into(),
                    kind: ObjectKind::Var,
                    entries: BTreeMap::from([(0, entry(access, limits))]),
                },
            );
        }
        ObjectDictionary { objects }
    }

    #[test]
    fn integers_round_trip_in_little_endian_and_sign_extend() {
        let i16 = DataType::Integer(2);
        assert_eq!(i16.encode(-2), Some(vec![0xFE, 0xFF]));
        assert_eq!(i16.number(&[0xFE, 0xFF]), Some(-2));
        assert_eq!(i16.encode(40_000), None);
        let u24 = DataType::Unsigned(3);
        assert_eq!(u24.encode(0x123456), Some(vec![0x56, 0x34, 0x12]));
        assert_eq!(DataType::Unsigned(8).encode(-1), None);
        assert_eq!(
            DataType::VisibleString.number(&[b'x'; 40]),
            None,
            "no number, no panic"
        );
    }

    #[test]
    fn access_and_limits_give_the_abort_codes_of_cia_301_table_22() {
        let mut od = dictionary();
        assert_eq!(od.write(0x2000, 0, &[50, 0]), Ok(()));
        assert_eq!(od.read(0x2000, 0), Ok(vec![50, 0]));
        assert_eq!(od.write(0x2000, 0, &[101, 0]), Err(Abort(0x0609_0031)));
        assert_eq!(od.write(0x2000, 0, &[0x9B, 0xFF]), Err(Abort(0x0609_0032)));
        assert_eq!(od.write(0x2000, 0, &[1, 0, 0]), Err(Abort(0x0607_0012)));
        assert_eq!(od.write(0x2000, 0, &[1]), Err(Abort(0x0607_0013)));
        assert_eq!(od.write(0x2001, 0, &[1, 0]), Err(Abort(0x0601_0002)));
        assert_eq!(od.read(0x2002, 0), Err(Abort(0x0601_0001)));
        assert_eq!(od.read(0x2003, 0), Err(Abort(0x0602_0000)));
        assert_eq!(od.read(0x2000, 1), Err(Abort(0x0609_0011)));
    }
}

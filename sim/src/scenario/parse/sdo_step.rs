//! The SDO steps of the master's script (`read = "1008:00"`, `write = "1017:00"`): the object's
//! address, its type from the target's EDS, the value to write and what the read must give.

use std::ops::Range;

use ::canopen::master::Action;
use ::canopen::od::DataType;
use ::canopen::sdo::Abort;
use toml::{Spanned, Value};

use super::canopen::StepToml;
use super::Builder;
use crate::scenario::canopen_master::Expect;
use crate::scenario::ScenarioError;

impl Builder<'_> {
    /// A read or write step: the action, what it expects, the object's type and name.
    pub(super) fn sdo(
        &self,
        s: &StepToml,
        address: &Spanned<String>,
        whole: Range<usize>,
    ) -> Result<(Action, Expect, Option<DataType>, String), ScenarioError> {
        let node = self.target(s, whole.clone(), false)?;
        let (index, sub) =
            object_address(address.get_ref()).map_err(|m| self.error(address.span(), m))?;
        let expect_abort = s
            .expect_abort
            .as_ref()
            .map(|a| abort_code(a.get_ref()).map_err(|m| self.error(a.span(), m)))
            .transpose()?;
        let entry = match self.dictionary(node) {
            Some(od) => match od.entry(index, sub) {
                Ok(entry) => Some(entry),
                Err(_) if expect_abort.is_some() => None,
                Err(_) => {
                    return Err(self.error(
                        address.span(),
                        format!(
                            "{index:04X}h:{sub:02X} is not in node {node}'s dictionary (its EDS); \
                             to test the abort, add expect_abort = \"0602 0000\""
                        ),
                    ))
                }
            },
            None => None,
        };
        let data_type = entry.map(|e| e.data_type);
        let name = entry.map_or(String::new(), |e| format!(" ({})", e.name));
        let block = s.block.unwrap_or(false);
        let action = if s.read.is_some() {
            Action::Read {
                node,
                index,
                sub,
                block,
            }
        } else {
            Action::Write {
                node,
                index,
                sub,
                data: self.write_data(s, data_type, whole.clone())?,
                block,
            }
        };
        let expect = match (expect_abort, &s.expect, &s.expect_data) {
            (Some(abort), None, None) => Expect::Abort(abort),
            (None, Some(value), None) => Expect::Data(self.encode(value, data_type)?),
            (None, None, Some(hex)) => Expect::Data(self.hex(hex)?),
            (None, None, None) => Expect::Success,
            _ => {
                return Err(self.source.table_error(
                    whole,
                    "a step expects one of: expect, expect_data, expect_abort",
                ))
            }
        };
        Ok((action, expect, data_type, name))
    }

    fn write_data(
        &self,
        s: &StepToml,
        data_type: Option<DataType>,
        whole: Range<usize>,
    ) -> Result<Vec<u8>, ScenarioError> {
        match (&s.value, &s.data) {
            (Some(value), None) => self.encode(value, data_type),
            (None, Some(hex)) => self.hex(hex),
            _ => Err(self.source.table_error(
                whole,
                "a write needs value = … (typed by the EDS) or data = \"hex bytes\"",
            )),
        }
    }

    /// `value` in the bytes of `data_type`.
    fn encode(
        &self,
        value: &Spanned<Value>,
        data_type: Option<DataType>,
    ) -> Result<Vec<u8>, ScenarioError> {
        let error = |m: String| self.error(value.span(), m);
        let Some(data_type) = data_type else {
            return Err(error(
                "the node's dictionary is not known here (no EDS): give the bytes as hex \
                 (data = or expect_data =)"
                    .to_string(),
            ));
        };
        match (value.get_ref(), data_type) {
            (
                Value::String(text),
                DataType::VisibleString | DataType::OctetString | DataType::Domain,
            ) => Ok(text.as_bytes().to_vec()),
            (Value::Boolean(b), DataType::Boolean) => Ok(vec![u8::from(*b)]),
            (Value::Integer(n), _) => data_type.encode(i128::from(*n)).ok_or_else(|| {
                error(format!(
                    "{n} is not a value of the object's type {data_type:?}"
                ))
            }),
            (Value::Float(x), DataType::Real32) => Ok((*x as f32).to_le_bytes().to_vec()),
            (Value::Float(x), DataType::Real64) => Ok(x.to_le_bytes().to_vec()),
            (other, _) => Err(error(format!(
                "{other} is not a value of the object's type {data_type:?}"
            ))),
        }
    }

    fn hex(&self, text: &Spanned<String>) -> Result<Vec<u8>, ScenarioError> {
        hex_bytes(text.get_ref()).map_err(|m| self.error(text.span(), m))
    }
}

/// `1008:00`, `1008h:0` or `1008` (sub-index 0): hexadecimal index and sub-index.
fn object_address(text: &str) -> Result<(u16, u8), String> {
    let bad = || format!("\"{text}\" is not an object: expected INDEX:SUB in hex, e.g. 1017:00");
    let (index, sub) = text.split_once(':').unwrap_or((text, "0"));
    let index = index.trim().trim_end_matches(['h', 'H']);
    let sub = sub.trim().trim_end_matches(['h', 'H']);
    let index = u16::from_str_radix(index.trim_start_matches("0x"), 16).map_err(|_| bad())?;
    let sub = u8::from_str_radix(sub.trim_start_matches("0x"), 16).map_err(|_| bad())?;
    Ok((index, sub))
}

/// `0602 0000` or `06020000`: an abort code, as CiA 301 Table 22 writes it.
fn abort_code(text: &str) -> Result<Abort, String> {
    let digits: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    u32::from_str_radix(digits.trim_start_matches("0x"), 16)
        .ok()
        .filter(|_| digits.trim_start_matches("0x").len() == 8)
        .map(Abort)
        .ok_or_else(|| format!("\"{text}\" is not an abort code: 8 hex digits, e.g. \"0602 0000\""))
}

/// `0A 00` or `0A00`: bytes in hex.
fn hex_bytes(text: &str) -> Result<Vec<u8>, String> {
    let digits: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    let bad = || format!("\"{text}\" is not hex bytes (e.g. \"0A 00\")");
    if !digits.len().is_multiple_of(2) {
        return Err(bad());
    }
    (0..digits.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&digits[i..i + 2], 16).map_err(|_| bad()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_abort_codes_and_hex_as_people_write_them() {
        assert_eq!(object_address("1017:00"), Ok((0x1017, 0)));
        assert_eq!(object_address("1A00h:02"), Ok((0x1A00, 2)));
        assert_eq!(object_address("2001"), Ok((0x2001, 0)));
        assert!(object_address("10170:0").is_err());
        assert!(object_address("x:1").is_err());
        assert_eq!(abort_code("0602 0000"), Ok(Abort(0x0602_0000)));
        assert_eq!(abort_code("05040000"), Ok(Abort(0x0504_0000)));
        assert!(abort_code("0602").is_err());
        assert_eq!(hex_bytes("0A 00"), Ok(vec![0x0A, 0x00]));
        assert_eq!(hex_bytes(""), Ok(vec![]));
        assert!(hex_bytes("ABC").is_err());
    }
}

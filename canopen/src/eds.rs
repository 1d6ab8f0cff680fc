//! Electronic data sheets (CiA 306): the INI-style file that describes a device's object
//! dictionary, read into an [`ObjectDictionary`].
//!
//! The objects are those the sections `[MandatoryObjects]`, `[OptionalObjects]` and
//! `[ManufacturerObjects]` list (`SupportedObjects=n`, then `1=0x1000` …); each has a section named
//! by its index in hex (`[1018]`), and an ARRAY or RECORD one more per sub-index (`[1018sub1]`).
//! An entry has `ParameterName`, `DataType` (a CiA 301 Table 44 index), `AccessType` (`ro`, `wo`,
//! `rw`, `rwr`, `rww`, `const`), and optionally `DefaultValue` (decimal, `0x` hex, or
//! `$NODEID+…` for values that depend on the node-ID), `LowLimit`, `HighLimit` and `PDOMapping`.
//! Keys and section names are case-insensitive; `;` starts a comment. Every error names the file
//! and line.

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::path::{Path, PathBuf};

use crate::od::{Access, DataType, Entry, Object, ObjectDictionary, ObjectKind};

/// The sections that list the objects of the dictionary.
const OBJECT_LISTS: [&str; 3] = ["mandatoryobjects", "optionalobjects", "manufacturerobjects"];
/// The value a `$NODEID` default stands for.
const NODE_ID_VARIABLE: &str = "$nodeid";

/// What is wrong with an EDS file, and where.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EdsError {
    /// The file.
    pub path: PathBuf,
    /// The 1-based line, when the error is about one.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for EdsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{line}: {}", self.path.display(), self.message),
            None => write!(f, "{}: {}", self.path.display(), self.message),
        }
    }
}

impl std::error::Error for EdsError {}

/// A key's value and its line.
type Value = (String, usize);

struct Section {
    line: usize,
    keys: HashMap<String, Value>,
}

struct Parser<'p> {
    path: &'p Path,
    sections: HashMap<String, Section>,
    node_id: u8,
}

/// Reads the EDS file at `path` for a device with `node_id`.
pub fn load(path: &Path, node_id: u8) -> Result<ObjectDictionary, EdsError> {
    let text = std::fs::read_to_string(path).map_err(|e| EdsError {
        path: path.to_path_buf(),
        line: None,
        message: format!("cannot read the EDS: {e}"),
    })?;
    parse(&text, path, node_id)
}

/// Reads EDS `text` (from `path`, named in errors) for a device with `node_id`.
pub fn parse(text: &str, path: &Path, node_id: u8) -> Result<ObjectDictionary, EdsError> {
    let parser = Parser {
        path,
        sections: sections(text, path)?,
        node_id,
    };
    parser.dictionary()
}

fn error(path: &Path, line: Option<usize>, message: impl Into<String>) -> EdsError {
    EdsError {
        path: path.to_path_buf(),
        line,
        message: message.into(),
    }
}

/// The sections of `text`, by lower-case name, with their keys.
fn sections(text: &str, path: &Path) -> Result<HashMap<String, Section>, EdsError> {
    let mut sections: HashMap<String, Section> = HashMap::new();
    let mut current: Option<String> = None;
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let content = raw.split(';').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        if let Some(name) = content.strip_prefix('[').and_then(|c| c.strip_suffix(']')) {
            let name = name.trim().to_ascii_lowercase();
            if let Some(first) = sections.get(&name) {
                let message = format!("section [{name}] again (first at line {})", first.line);
                return Err(error(path, Some(line), message));
            }
            sections.insert(
                name.clone(),
                Section {
                    line,
                    keys: HashMap::new(),
                },
            );
            current = Some(name);
            continue;
        }
        let Some((key, value)) = content.split_once('=') else {
            return Err(error(path, Some(line), "expected [section] or key=value"));
        };
        let Some(section) = current.as_ref().and_then(|name| sections.get_mut(name)) else {
            return Err(error(path, Some(line), "a key before the first [section]"));
        };
        let key = key.trim().to_ascii_lowercase();
        section.keys.insert(key, (value.trim().to_string(), line));
    }
    Ok(sections)
}

impl Parser<'_> {
    fn error(&self, line: usize, message: impl Into<String>) -> EdsError {
        error(self.path, Some(line), message)
    }

    fn dictionary(&self) -> Result<ObjectDictionary, EdsError> {
        let mut objects = BTreeMap::new();
        for list in OBJECT_LISTS {
            let Some(section) = self.sections.get(list) else {
                continue;
            };
            for index in self.listed(section)? {
                let (index, line) = index;
                if objects.contains_key(&index) {
                    return Err(self.error(line, format!("object {index:04X} is listed twice")));
                }
                objects.insert(index, self.object(index, line)?);
            }
        }
        if objects.is_empty() {
            return Err(error(
                self.path,
                None,
                "no objects: an EDS lists them in [MandatoryObjects] (1000, 1001, 1018 at least)",
            ));
        }
        Ok(ObjectDictionary { objects })
    }

    /// The indices an object list names, with their lines.
    fn listed(&self, section: &Section) -> Result<Vec<(u16, usize)>, EdsError> {
        let (count, line) = section
            .keys
            .get("supportedobjects")
            .ok_or_else(|| self.error(section.line, "the list has no SupportedObjects="))?;
        let count =
            number(count).ok_or_else(|| self.error(*line, "SupportedObjects is no number"))?;
        (1..=count)
            .map(|k| {
                let (value, line) = section.keys.get(&k.to_string()).ok_or_else(|| {
                    self.error(
                        section.line,
                        format!("the list has no entry {k}= (of {count})"),
                    )
                })?;
                let index = number(value)
                    .and_then(|n| u16::try_from(n).ok())
                    .ok_or_else(|| {
                        self.error(*line, format!("'{value}' is not an object index"))
                    })?;
                Ok((index, *line))
            })
            .collect()
    }

    fn object(&self, index: u16, listed_at: usize) -> Result<Object, EdsError> {
        let name = format!("{index:04x}");
        let section = self.sections.get(&name).ok_or_else(|| {
            self.error(
                listed_at,
                format!("object {index:04X} has no section [{index:04X}]"),
            )
        })?;
        let kind = match self.optional_number(section, "objecttype")?.unwrap_or(0x7) {
            0x7 => ObjectKind::Var,
            0x8 => ObjectKind::Array,
            0x9 => ObjectKind::Record,
            other => {
                let line = section.keys["objecttype"].1;
                return Err(self.error(
                    line,
                    format!("ObjectType {other:#X} is not VAR (0x7), ARRAY (0x8) or RECORD (0x9)"),
                ));
            }
        };
        let mut entries = BTreeMap::new();
        if kind == ObjectKind::Var {
            entries.insert(0, self.entry(section)?);
        } else {
            for sub in 0..=u8::MAX {
                if let Some(sub_section) = self.sections.get(&format!("{name}sub{sub:x}")) {
                    entries.insert(sub, self.entry(sub_section)?);
                }
            }
            if !entries.contains_key(&0) {
                return Err(self.error(
                    section.line,
                    format!("[{index:04X}] needs [{index:04X}sub0] (its number of entries)"),
                ));
            }
        }
        Ok(Object {
            name: self.text(section, "parametername")?,
            kind,
            entries,
        })
    }

    fn entry(&self, section: &Section) -> Result<Entry, EdsError> {
        let type_index = self.required_number(section, "datatype")?;
        let type_line = section.keys["datatype"].1;
        let data_type = u16::try_from(type_index)
            .ok()
            .and_then(DataType::from_index)
            .ok_or_else(|| {
                self.error(
                    type_line,
                    format!("DataType {type_index:#06X} is not supported"),
                )
            })?;
        let (access_text, access_line) = self.required(section, "accesstype")?;
        let access = match access_text.to_ascii_lowercase().as_str() {
            "ro" => Access::ReadOnly,
            "wo" => Access::WriteOnly,
            "rw" | "rwr" | "rww" => Access::ReadWrite,
            "const" => Access::Const,
            other => {
                return Err(self.error(
                    access_line,
                    format!("AccessType '{other}' is not ro, wo, rw, rwr, rww or const"),
                ))
            }
        };
        let value = match section.keys.get("defaultvalue") {
            Some((text, line)) => self.value(data_type, text, *line)?,
            None => vec![0; data_type.size().unwrap_or(0)],
        };
        let limit = |key: &str| -> Result<Option<i128>, EdsError> {
            let Some((text, line)) = section.keys.get(key) else {
                return Ok(None);
            };
            let bytes = self.value(data_type, text, *line)?;
            Ok(data_type.number(&bytes))
        };
        Ok(Entry {
            name: self.text(section, "parametername")?,
            data_type,
            access,
            value,
            limits: (limit("lowlimit")?, limit("highlimit")?),
            pdo_mappable: self.optional_number(section, "pdomapping")?.unwrap_or(0) != 0,
        })
    }

    /// A value of `data_type` written as `text` at `line`.
    fn value(&self, data_type: DataType, text: &str, line: usize) -> Result<Vec<u8>, EdsError> {
        match data_type {
            DataType::VisibleString | DataType::OctetString | DataType::Domain => {
                Ok(text.as_bytes().to_vec())
            }
            DataType::Real32 => text
                .parse::<f32>()
                .map(|v| v.to_le_bytes().to_vec())
                .map_err(|_| self.error(line, format!("'{text}' is not a REAL32"))),
            DataType::Real64 => text
                .parse::<f64>()
                .map(|v| v.to_le_bytes().to_vec())
                .map_err(|_| self.error(line, format!("'{text}' is not a REAL64"))),
            _ => {
                let value = self.integer(text).ok_or_else(|| {
                    self.error(
                        line,
                        format!("'{text}' is not a number (decimal, 0x hex or $NODEID+…)"),
                    )
                })?;
                data_type.encode(value).ok_or_else(|| {
                    self.error(
                        line,
                        format!("{text} does not fit the data type {data_type:?}"),
                    )
                })
            }
        }
    }

    /// An integer: decimal, `0x` hex, negative, or `$NODEID` plus or minus one.
    fn integer(&self, text: &str) -> Option<i128> {
        let compact: String = text.split_whitespace().collect();
        let lower = compact.to_ascii_lowercase();
        if let Some(rest) = lower.strip_prefix(NODE_ID_VARIABLE) {
            let node = i128::from(self.node_id);
            return match rest.chars().next() {
                None => Some(node),
                Some('+') => Some(node + signed(&rest[1..])?),
                Some('-') => Some(node - signed(&rest[1..])?),
                _ => None,
            };
        }
        if let Some(head) = lower.strip_suffix(&format!("+{NODE_ID_VARIABLE}")) {
            return Some(signed(head)? + i128::from(self.node_id));
        }
        signed(&lower)
    }

    fn required<'s>(&self, section: &'s Section, key: &str) -> Result<(&'s str, usize), EdsError> {
        section
            .keys
            .get(key)
            .map(|(v, l)| (v.as_str(), *l))
            .ok_or_else(|| self.error(section.line, format!("the section has no {key}=")))
    }

    fn text(&self, section: &Section, key: &str) -> Result<String, EdsError> {
        self.required(section, key).map(|(v, _)| v.to_string())
    }

    fn required_number(&self, section: &Section, key: &str) -> Result<i128, EdsError> {
        let (text, line) = self.required(section, key)?;
        number(text).ok_or_else(|| self.error(line, format!("{key} '{text}' is not a number")))
    }

    fn optional_number(&self, section: &Section, key: &str) -> Result<Option<i128>, EdsError> {
        let Some((text, line)) = section.keys.get(key) else {
            return Ok(None);
        };
        number(text)
            .map(Some)
            .ok_or_else(|| self.error(*line, format!("{key} '{text}' is not a number")))
    }
}

/// A non-negative decimal or `0x` hex number.
fn number(text: &str) -> Option<i128> {
    let text = text.trim().to_ascii_lowercase();
    match text.strip_prefix("0x") {
        Some(hex) => i128::from_str_radix(hex, 16).ok(),
        None => text.parse().ok().filter(|n: &i128| *n >= 0),
    }
}

/// A decimal or `0x` hex number with an optional sign.
fn signed(text: &str) -> Option<i128> {
    match text.strip_prefix('-') {
        Some(rest) => number(rest).map(|n| -n),
        None => number(text.strip_prefix('+').unwrap_or(text)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = "\
[FileInfo]
FileName=test.eds
[MandatoryObjects]
SupportedObjects=2
1=0x1000
2=0x1018
[OptionalObjects]
SupportedObjects=1
1=0x1400
[1000]
ParameterName=Device type
ObjectType=0x7
DataType=0x0007
AccessType=ro
DefaultValue=0x00000191
PDOMapping=0
[1018]
ParameterName=Identity object
ObjectType=0x9
SubNumber=2
[1018sub0]
ParameterName=Number of entries
DataType=0x0005
AccessType=ro
DefaultValue=1
[1018sub1]
ParameterName=Vendor-ID
DataType=0x0007
AccessType=ro
DefaultValue=0x0000ABCD
[1400]
ParameterName=RPDO1 communication parameter
ObjectType=0x9
[1400sub0]
ParameterName=Highest sub-index supported
DataType=0x0005
AccessType=const
DefaultValue=2
[1400sub1]
ParameterName=COB-ID used by RPDO
DataType=0x0007
AccessType=rw
DefaultValue=$NODEID+0x200
";

    fn parse_text(text: &str) -> Result<ObjectDictionary, EdsError> {
        parse(text, Path::new("test.eds"), 5)
    }

    #[test]
    fn objects_entries_and_node_id_defaults() {
        let od = parse_text(MINIMAL).unwrap();
        assert_eq!(od.read(0x1000, 0), Ok(vec![0x91, 0x01, 0, 0]));
        assert_eq!(od.unsigned(0x1018, 1), 0xABCD);
        assert_eq!(od.unsigned(0x1400, 1), 0x205, "$NODEID+0x200 for node 5");
        assert_eq!(od.objects[&0x1018].kind, ObjectKind::Record);
        assert_eq!(od.entry(0x1400, 0).unwrap().access, Access::Const);
    }

    #[test]
    fn a_malformed_eds_names_its_line() {
        for (change, expected) in [
            (
                (
                    "DataType=0x0007\nAccessType=ro\nDefaultValue=0x00000191",
                    "DataType=0x0007\nAccessType=rx\nDefaultValue=0x00000191",
                ),
                "test.eds:14: AccessType 'rx' is not",
            ),
            (
                ("DefaultValue=0x00000191", "DefaultValue=abc"),
                "test.eds:15: 'abc' is not a number",
            ),
            (
                ("DefaultValue=1\n[1018sub1]", "DefaultValue=300\n[1018sub1]"),
                "test.eds:25: 300 does not fit",
            ),
            (
                ("2=0x1018", "2=0x1019"),
                "test.eds:6: object 1019 has no section [1019]",
            ),
            (
                ("[1000]", "[1000]\nthis is no key"),
                "test.eds:11: expected [section] or key=value",
            ),
            (
                (
                    "DataType=0x0007\nAccessType=ro\nDefaultValue=0x00000191",
                    "DataType=0x0077\nAccessType=ro\nDefaultValue=0x00000191",
                ),
                "test.eds:13: DataType 0x0077 is not supported",
            ),
        ] {
            let text = MINIMAL.replacen(change.0, change.1, 1);
            assert_ne!(text, MINIMAL, "{expected}");
            let e = parse_text(&text).unwrap_err().to_string();
            assert!(e.starts_with(expected), "{e}");
        }
    }
}

//! The SDO server (CiA 301 7.2.4): a client reads (upload) and writes (download) the object
//! dictionary with confirmed 8-byte requests on 600h + node-ID, answered on 580h + node-ID.
//!
//! Byte 0 of every frame is the command specifier (7.2.4.3): bits 7..5 the client command (0
//! download segment, 1 initiate download, 2 initiate upload, 3 upload segment, 4 abort, 5 and 6
//! block transfers); an expedited transfer carries up to 4 bytes in the initiate frames (`e`, and
//! `s` with `n`, the bytes of the 4 that hold no data); a segmented one then moves 7 bytes per
//! segment with a toggle bit `t` that alternates from 0, `n` the unused bytes and `c` set on the
//! last. Either side may end a transfer with an abort (80h, index, sub-index, 32-bit code). Block
//! transfers (client commands 5 and 6) are in [`crate::sdo_block`].

use crate::od::ObjectDictionary;
use crate::sdo_block::{self, Block};

/// An SDO abort code (CiA 301 Table 22).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Abort(pub u32);

impl Abort {
    /// 0503 0000: toggle bit not alternated.
    pub const TOGGLE: Abort = Abort(0x0503_0000);
    /// 0504 0000: SDO protocol timed out.
    pub const TIMEOUT: Abort = Abort(0x0504_0000);
    /// 0504 0001: client/server command specifier not valid or unknown.
    pub const COMMAND: Abort = Abort(0x0504_0001);
    /// 0601 0001: attempt to read a write-only object.
    pub const WRITE_ONLY: Abort = Abort(0x0601_0001);
    /// 0601 0002: attempt to write a read-only object.
    pub const READ_ONLY: Abort = Abort(0x0601_0002);
    /// 0602 0000: object does not exist in the object dictionary.
    pub const NO_OBJECT: Abort = Abort(0x0602_0000);
    /// 0607 0010: data type does not match, length of service parameter does not match.
    pub const LENGTH: Abort = Abort(0x0607_0010);
    /// 0607 0012: length of service parameter too high.
    pub const LENGTH_TOO_HIGH: Abort = Abort(0x0607_0012);
    /// 0607 0013: length of service parameter too low.
    pub const LENGTH_TOO_LOW: Abort = Abort(0x0607_0013);
    /// 0609 0011: sub-index does not exist.
    pub const NO_SUB_INDEX: Abort = Abort(0x0609_0011);
    /// 0609 0030: invalid value for parameter (download only).
    pub const VALUE_RANGE: Abort = Abort(0x0609_0030);
    /// 0609 0031: value of parameter written too high (download only).
    pub const VALUE_TOO_HIGH: Abort = Abort(0x0609_0031);
    /// 0609 0032: value of parameter written too low (download only).
    pub const VALUE_TOO_LOW: Abort = Abort(0x0609_0032);
}

impl Abort {
    /// What the code means, in the words of CiA 301 Table 22.
    pub fn meaning(self) -> &'static str {
        match self.0 {
            0x0503_0000 => "toggle bit not alternated",
            0x0504_0000 => "SDO protocol timed out",
            0x0504_0001 => "client/server command specifier not valid or unknown",
            0x0504_0002 => "invalid block size",
            0x0504_0003 => "invalid sequence number",
            0x0504_0004 => "CRC error",
            0x0504_0005 => "out of memory",
            0x0601_0000 => "unsupported access to an object",
            0x0601_0001 => "attempt to read a write only object",
            0x0601_0002 => "attempt to write a read only object",
            0x0602_0000 => "object does not exist in the object dictionary",
            0x0604_0041 => "object cannot be mapped to the PDO",
            0x0604_0042 => "the objects to be mapped would exceed the PDO length",
            0x0604_0043 => "general parameter incompatibility",
            0x0604_0047 => "general internal incompatibility in the device",
            0x0606_0000 => "access failed due to a hardware error",
            0x0607_0010 => "data type does not match, length of service parameter does not match",
            0x0607_0012 => "data type does not match, length of service parameter too high",
            0x0607_0013 => "data type does not match, length of service parameter too low",
            0x0609_0011 => "sub-index does not exist",
            0x0609_0030 => "invalid value for parameter",
            0x0609_0031 => "value of parameter written too high",
            0x0609_0032 => "value of parameter written too low",
            0x0609_0036 => "maximum value is less than minimum value",
            0x060A_0023 => "resource not available: SDO connection",
            0x0800_0000 => "general error",
            0x0800_0020 => "data cannot be transferred or stored to the application",
            0x0800_0021 => "data cannot be transferred or stored because of local control",
            0x0800_0022 => "data cannot be transferred or stored because of the device state",
            0x0800_0023 => "no object dictionary is present",
            0x0800_0024 => "no data available",
            _ => "not a CiA 301 abort code",
        }
    }
}

impl std::fmt::Display for Abort {
    /// `0602 0000 (object does not exist in the object dictionary)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (high, low) = (self.0 >> 16, self.0 & 0xFFFF);
        write!(f, "{high:04X} {low:04X} ({})", self.meaning())
    }
}

/// Client command specifiers (bits 7..5 of byte 0).
const CCS_DOWNLOAD_SEGMENT: u8 = 0;
const CCS_INITIATE_DOWNLOAD: u8 = 1;
const CCS_INITIATE_UPLOAD: u8 = 2;
const CCS_UPLOAD_SEGMENT: u8 = 3;
const CCS_BLOCK_UPLOAD: u8 = 5;
const CCS_BLOCK_DOWNLOAD: u8 = 6;
/// Byte 0 of an abort.
const ABORT_COMMAND: u8 = 0x80;
/// Server command specifiers, in place (bits 7..5).
const SCS_UPLOAD_SEGMENT: u8 = 0x00;
const SCS_DOWNLOAD_SEGMENT: u8 = 0x20;
const SCS_INITIATE_UPLOAD: u8 = 0x40;
const SCS_INITIATE_DOWNLOAD: u8 = 0x60;
const SCS_ABORT: u8 = 0x80;
/// Flag bits of byte 0.
const EXPEDITED: u8 = 0x02;
const SIZE_INDICATED: u8 = 0x01;
const TOGGLE: u8 = 0x10;
const LAST_SEGMENT: u8 = 0x01;
/// Data bytes of an expedited transfer and of a segment.
const EXPEDITED_BYTES: usize = 4;
const SEGMENT_BYTES: usize = 7;
/// Microseconds without a request before an open transfer is aborted (0504 0000). CiA 301 leaves
/// the value to the device.
pub const SDO_TIMEOUT_US: u64 = 1_000_000;

/// A segmented transfer in progress.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Transfer {
    Download {
        index: u16,
        sub: u8,
        size: Option<usize>,
        data: Vec<u8>,
        toggle: bool,
    },
    Upload {
        index: u16,
        sub: u8,
        data: Vec<u8>,
        sent: usize,
        toggle: bool,
    },
    Block(Block),
}

/// The SDO server of one device.
#[derive(Clone, Debug, Default)]
pub struct SdoServer {
    transfer: Option<Transfer>,
    last_request_us: u64,
}

/// An 8-byte SDO frame.
pub type SdoFrame = [u8; 8];

/// The abort frame for `index`:`sub`.
pub fn abort_frame(index: u16, sub: u8, abort: Abort) -> SdoFrame {
    let [i0, i1] = index.to_le_bytes();
    let [c0, c1, c2, c3] = abort.0.to_le_bytes();
    [SCS_ABORT, i0, i1, sub, c0, c1, c2, c3]
}

fn header(command: u8, index: u16, sub: u8) -> SdoFrame {
    let [i0, i1] = index.to_le_bytes();
    [command, i0, i1, sub, 0, 0, 0, 0]
}

impl SdoServer {
    /// Whether a segmented transfer is open.
    pub fn busy(&self) -> bool {
        self.transfer.is_some()
    }

    /// Handles request `data` at `now_us`; the responses (none, one, or a sub-block of a block
    /// upload).
    pub fn request(
        &mut self,
        od: &mut ObjectDictionary,
        data: &[u8],
        now_us: u64,
    ) -> Vec<SdoFrame> {
        self.last_request_us = now_us;
        let Ok(frame) = <SdoFrame>::try_from(data) else {
            // CiA 301 7.2.4.3: SDO frames always have 8 bytes.
            return vec![abort_frame(0, 0, Abort::COMMAND)];
        };
        if frame[0] == ABORT_COMMAND {
            self.transfer = None;
            return Vec::new();
        }
        if let Some(Transfer::Block(block)) = &mut self.transfer {
            let block_request = matches!(frame[0] >> 5, CCS_BLOCK_UPLOAD | CCS_BLOCK_DOWNLOAD);
            if block.takes_segments() || block_request {
                return match block.request(od, &frame) {
                    Ok((answers, done)) => {
                        if done {
                            self.transfer = None;
                        }
                        answers
                    }
                    Err((index, sub, abort)) => {
                        self.transfer = None;
                        vec![abort_frame(index, sub, abort)]
                    }
                };
            }
        }
        let index = u16::from_le_bytes([frame[1], frame[2]]);
        let sub = frame[3];
        let result = match frame[0] >> 5 {
            CCS_INITIATE_DOWNLOAD => self.initiate_download(od, &frame, index, sub),
            CCS_DOWNLOAD_SEGMENT => self.download_segment(od, &frame),
            CCS_INITIATE_UPLOAD => self.initiate_upload(od, index, sub),
            CCS_UPLOAD_SEGMENT => self.upload_segment(&frame),
            CCS_BLOCK_UPLOAD | CCS_BLOCK_DOWNLOAD => self.initiate_block(od, &frame, index, sub),
            _ => Err((index, sub, Abort::COMMAND)),
        };
        match result {
            Ok(response) => vec![response],
            Err((index, sub, abort)) => {
                self.transfer = None;
                vec![abort_frame(index, sub, abort)]
            }
        }
    }

    fn initiate_block(
        &mut self,
        od: &ObjectDictionary,
        frame: &SdoFrame,
        index: u16,
        sub: u8,
    ) -> Result<SdoFrame, (u16, u8, Abort)> {
        // The sub-command: bits 1..0 of an upload request, bit 0 of a download request.
        let upload = frame[0] >> 5 == CCS_BLOCK_UPLOAD;
        let sub_command = frame[0] & if upload { 0x03 } else { 0x01 };
        if sub_command != sdo_block::CS_INITIATE {
            return Err((index, sub, Abort::COMMAND));
        }
        let (block, answer) = if upload {
            sdo_block::initiate_upload(od, frame, index, sub)?
        } else {
            sdo_block::initiate_download(od, frame, index, sub)?
        };
        self.transfer = Some(Transfer::Block(block));
        Ok(answer)
    }

    /// At `now_us`: the abort of a transfer the client left open for [`SDO_TIMEOUT_US`].
    pub fn check_timeout(&mut self, now_us: u64) -> Option<SdoFrame> {
        let transfer = self.transfer.as_ref()?;
        if now_us < self.last_request_us + SDO_TIMEOUT_US {
            return None;
        }
        let (index, sub) = match transfer {
            Transfer::Download { index, sub, .. }
            | Transfer::Upload { index, sub, .. }
            | Transfer::Block(Block::Download { index, sub, .. })
            | Transfer::Block(Block::Upload { index, sub, .. }) => (*index, *sub),
        };
        self.transfer = None;
        Some(abort_frame(index, sub, Abort::TIMEOUT))
    }

    /// When an open transfer times out.
    pub fn deadline(&self) -> Option<u64> {
        self.transfer
            .as_ref()
            .map(|_| self.last_request_us + SDO_TIMEOUT_US)
    }

    fn initiate_download(
        &mut self,
        od: &mut ObjectDictionary,
        frame: &SdoFrame,
        index: u16,
        sub: u8,
    ) -> Result<SdoFrame, (u16, u8, Abort)> {
        let fail = |abort| (index, sub, abort);
        let flags = frame[0];
        let size_field = u32::from_le_bytes([frame[4], frame[5], frame[6], frame[7]]) as usize;
        if flags & EXPEDITED != 0 {
            let len = if flags & SIZE_INDICATED != 0 {
                EXPEDITED_BYTES - usize::from((flags >> 2) & 0x03)
            } else {
                // No size: as many bytes as the entry holds (up to 4).
                od.entry(index, sub)
                    .map_err(fail)?
                    .data_type
                    .size()
                    .unwrap_or(EXPEDITED_BYTES)
                    .min(EXPEDITED_BYTES)
            };
            od.write(index, sub, &frame[4..4 + len]).map_err(fail)?;
            self.transfer = None;
            return Ok(header(SCS_INITIATE_DOWNLOAD, index, sub));
        }
        let entry = od.entry(index, sub).map_err(fail)?;
        if !entry.access.writable() {
            return Err(fail(Abort::READ_ONLY));
        }
        self.transfer = Some(Transfer::Download {
            index,
            sub,
            size: (flags & SIZE_INDICATED != 0).then_some(size_field),
            data: Vec::new(),
            toggle: false,
        });
        Ok(header(SCS_INITIATE_DOWNLOAD, index, sub))
    }

    fn download_segment(
        &mut self,
        od: &mut ObjectDictionary,
        frame: &SdoFrame,
    ) -> Result<SdoFrame, (u16, u8, Abort)> {
        let Some(Transfer::Download {
            index,
            sub,
            size,
            data,
            toggle,
        }) = &mut self.transfer
        else {
            return Err((0, 0, Abort::COMMAND));
        };
        let (index, sub) = (*index, *sub);
        let t = frame[0] & TOGGLE != 0;
        if t != *toggle {
            return Err((index, sub, Abort::TOGGLE));
        }
        let unused = usize::from((frame[0] >> 1) & 0x07);
        data.extend_from_slice(&frame[1..1 + SEGMENT_BYTES - unused]);
        *toggle = !*toggle;
        let response = [
            SCS_DOWNLOAD_SEGMENT | (frame[0] & TOGGLE),
            0,
            0,
            0,
            0,
            0,
            0,
            0,
        ];
        if frame[0] & LAST_SEGMENT == 0 {
            return Ok(response);
        }
        if size.is_some_and(|size| size != data.len()) {
            return Err((index, sub, Abort::LENGTH));
        }
        let data = std::mem::take(data);
        self.transfer = None;
        od.write(index, sub, &data)
            .map_err(|abort| (index, sub, abort))?;
        Ok(response)
    }

    fn initiate_upload(
        &mut self,
        od: &ObjectDictionary,
        index: u16,
        sub: u8,
    ) -> Result<SdoFrame, (u16, u8, Abort)> {
        let data = od.read(index, sub).map_err(|abort| (index, sub, abort))?;
        let mut response = header(SCS_INITIATE_UPLOAD | SIZE_INDICATED, index, sub);
        if data.len() <= EXPEDITED_BYTES {
            let unused = (EXPEDITED_BYTES - data.len()) as u8;
            response[0] |= EXPEDITED | (unused << 2);
            response[4..4 + data.len()].copy_from_slice(&data);
            self.transfer = None;
        } else {
            response[4..8].copy_from_slice(&(data.len() as u32).to_le_bytes());
            self.transfer = Some(Transfer::Upload {
                index,
                sub,
                data,
                sent: 0,
                toggle: false,
            });
        }
        Ok(response)
    }

    fn upload_segment(&mut self, frame: &SdoFrame) -> Result<SdoFrame, (u16, u8, Abort)> {
        let Some(Transfer::Upload {
            index,
            sub,
            data,
            sent,
            toggle,
        }) = &mut self.transfer
        else {
            return Err((0, 0, Abort::COMMAND));
        };
        let t = frame[0] & TOGGLE != 0;
        if t != *toggle {
            return Err((*index, *sub, Abort::TOGGLE));
        }
        let chunk = &data[*sent..(*sent + SEGMENT_BYTES).min(data.len())];
        let last = *sent + chunk.len() == data.len();
        let unused = (SEGMENT_BYTES - chunk.len()) as u8;
        let mut response = [0u8; 8];
        response[0] = SCS_UPLOAD_SEGMENT | (frame[0] & TOGGLE) | (unused << 1);
        if last {
            response[0] |= LAST_SEGMENT;
        }
        response[1..1 + chunk.len()].copy_from_slice(chunk);
        *sent += chunk.len();
        *toggle = !*toggle;
        if last {
            self.transfer = None;
        }
        Ok(response)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eds;
    use std::path::Path;

    /// 1008 (a 13-byte device name, ro), 2000 (UNSIGNED16 rw, 10..1000), 2001 (VISIBLE_STRING rw).
    const EDS: &str = "\
[MandatoryObjects]
SupportedObjects=1
1=0x1008
[ManufacturerObjects]
SupportedObjects=2
1=0x2000
2=0x2001
[1008]
ParameterName=Manufacturer device name
DataType=0x0009
AccessType=const
DefaultValue=cansim IO 8x8
[2000]
ParameterName=Setpoint
DataType=0x0006
AccessType=rw
DefaultValue=100
LowLimit=10
HighLimit=1000
[2001]
ParameterName=Label
DataType=0x0009
AccessType=rw
DefaultValue=
";

    fn od() -> ObjectDictionary {
        eds::parse(EDS, Path::new("t.eds"), 1).unwrap()
    }

    fn ask(server: &mut SdoServer, od: &mut ObjectDictionary, request: [u8; 8]) -> SdoFrame {
        let answers = server.request(od, &request, 0);
        assert_eq!(
            answers.len(),
            1,
            "one answer to {request:02X?}: {answers:02X?}"
        );
        answers[0]
    }

    #[test]
    fn expedited_download_and_upload() {
        let (mut server, mut od) = (SdoServer::default(), od());
        // Initiate download, expedited, size indicated, n = 2 (2 of 4 bytes unused): 0x2B.
        let answer = ask(
            &mut server,
            &mut od,
            [0x2B, 0x00, 0x20, 0x00, 0xF4, 0x01, 0, 0],
        );
        assert_eq!(answer, [0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0]);
        // Initiate upload: expedited answer 0x4B (e, s, n = 2) with 500 = 0x01F4.
        let answer = ask(&mut server, &mut od, [0x40, 0x00, 0x20, 0x00, 0, 0, 0, 0]);
        assert_eq!(answer, [0x4B, 0x00, 0x20, 0x00, 0xF4, 0x01, 0, 0]);
    }

    #[test]
    fn segmented_upload_toggles_and_ends_with_c() {
        let (mut server, mut od) = (SdoServer::default(), od());
        let answer = ask(&mut server, &mut od, [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]);
        assert_eq!(answer, [0x41, 0x08, 0x10, 0x00, 13, 0, 0, 0], "size 13");
        let first = ask(&mut server, &mut od, [0x60, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(first[0], 0x00);
        assert_eq!(&first[1..], b"cansim ");
        let second = ask(&mut server, &mut od, [0x70, 0, 0, 0, 0, 0, 0, 0]);
        // t = 1, n = 1 (one of 7 bytes unused), c = 1: 0x10 | 0x02 | 0x01.
        assert_eq!(second[0], 0x13);
        assert_eq!(&second[1..7], b"IO 8x8");
        assert!(!server.busy());
    }

    #[test]
    fn segmented_download_writes_on_the_last_segment() {
        let (mut server, mut od) = (SdoServer::default(), od());
        let answer = ask(&mut server, &mut od, [0x21, 0x01, 0x20, 0x00, 9, 0, 0, 0]);
        assert_eq!(answer, [0x60, 0x01, 0x20, 0x00, 0, 0, 0, 0]);
        let answer = ask(
            &mut server,
            &mut od,
            [0x00, b'd', b'o', b'o', b'r', b' ', b'l', b'e'],
        );
        assert_eq!(answer[0], 0x20);
        // t = 1, n = 5, c = 1: 0x10 | 0x0A | 0x01.
        let answer = ask(&mut server, &mut od, [0x1B, b'f', b't', 0, 0, 0, 0, 0]);
        assert_eq!(answer[0], 0x30);
        assert_eq!(od.read(0x2001, 0).unwrap(), b"door left");
    }

    #[test]
    fn aborts_carry_index_sub_index_and_the_cia_301_code() {
        let (mut server, mut od) = (SdoServer::default(), od());
        let code = |frame: SdoFrame| {
            (
                frame[0],
                u32::from_le_bytes([frame[4], frame[5], frame[6], frame[7]]),
            )
        };
        for (request, expected) in [
            ([0x40, 0x00, 0x30, 0x00, 0, 0, 0, 0], 0x0602_0000),
            ([0x40, 0x08, 0x10, 0x01, 0, 0, 0, 0], 0x0609_0011),
            ([0x2B, 0x08, 0x10, 0x00, 1, 0, 0, 0], 0x0601_0002),
            ([0x2B, 0x00, 0x20, 0x00, 0xE9, 0x03, 0, 0], 0x0609_0031),
            ([0x2B, 0x00, 0x20, 0x00, 9, 0, 0, 0], 0x0609_0032),
            ([0x2F, 0x00, 0x20, 0x00, 9, 0, 0, 0], 0x0607_0013),
            ([0xE0, 0x00, 0x20, 0x00, 0, 0, 0, 0], 0x0504_0001),
            ([0xA0, 0x08, 0x10, 0x00, 0, 0, 0, 0], 0x0504_0002),
            ([0x60, 0, 0, 0, 0, 0, 0, 0], 0x0504_0001),
        ] {
            let answer = ask(&mut server, &mut od, request);
            assert_eq!(code(answer), (0x80, expected), "{request:02X?}");
        }
        // A segment with the wrong toggle bit ends the transfer with 0503 0000.
        ask(&mut server, &mut od, [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]);
        let answer = ask(&mut server, &mut od, [0x70, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(code(answer), (0x80, 0x0503_0000));
        assert_eq!(&answer[1..4], &[0x08, 0x10, 0x00]);
        // A transfer the client leaves open times out with 0504 0000.
        server.request(&mut od, &[0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0], 5);
        assert_eq!(server.check_timeout(5 + SDO_TIMEOUT_US - 1), None);
        let answer = server.check_timeout(5 + SDO_TIMEOUT_US).unwrap();
        assert_eq!(code(answer), (0x80, 0x0504_0000));
    }
}

//! SDO block transfers (CiA 301 7.2.4.3.9–7.2.4.3.16): data in sub-blocks of up to 127 segments
//! of 7 bytes, each segment numbered (bits 6..0 of byte 0, bit 7 marks the last), one
//! confirmation per sub-block giving the last good number and the next block size, and a CRC over
//! the whole data when both sides support it (x^16 + x^12 + x^5 + 1, initial value 0: 7.2.4.3.16).
//!
//! Byte 0 holds the command specifier (bits 7..5); a download request then has cc (bit 2), s
//! (bit 1) and its sub-command (bit 0), an upload request cc (bit 2) and its sub-command (bits
//! 1..0).
//!
//! Download: the client initiates (C0h | cc 04h | s 02h, size), the server answers (A0h | sc 04h,
//! block size); the client sends a sub-block, the server confirms (A2h, ackseq, blksize); the
//! client ends (C1h | n << 2, CRC), the server confirms (A1h) once the data is written.
//!
//! Upload: the client initiates (A0h | cc, blksize, protocol switch threshold), the server answers
//! (C0h | sc | s, size), the client starts (A3h), the server sends a sub-block, the client
//! confirms (A2h, ackseq, blksize) and so on; the server ends (C1h | n << 2, CRC), the client
//! confirms (A1h).

use crate::od::ObjectDictionary;
use crate::sdo::{Abort, SdoFrame};

/// The most segments of a sub-block, and the block size this server asks for.
pub const MAX_BLOCK_SIZE: u8 = 127;
/// Data bytes of a segment.
const SEGMENT_BYTES: usize = 7;
/// Command bits.
const CRC_SUPPORTED: u8 = 0x04;
const SIZE_INDICATED: u8 = 0x02;
const LAST_SEGMENT: u8 = 0x80;
const SEQUENCE: u8 = 0x7F;
/// Sub-commands (bits 1..0) of the client's block requests.
pub const CS_INITIATE: u8 = 0;
const CS_END: u8 = 1;
const CS_CONFIRM: u8 = 2;
const CS_START_UPLOAD: u8 = 3;
/// Server command specifiers, in place.
const SCS_BLOCK_DOWNLOAD: u8 = 0xA0;
const SCS_BLOCK_UPLOAD: u8 = 0xC0;
/// 0504 0002: invalid block size; 0504 0004: CRC error.
const INVALID_BLOCK_SIZE: Abort = Abort(0x0504_0002);
const CRC_ERROR: Abort = Abort(0x0504_0004);

/// The CRC of block transfers: CRC-16 with polynomial 1021h, initial value 0, no reflection.
pub fn crc16(data: &[u8]) -> u16 {
    let mut crc: u16 = 0;
    for &byte in data {
        crc ^= u16::from(byte) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// A block transfer in progress.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Block {
    /// Receiving sub-blocks (or, with `last`, waiting for the end request).
    Download {
        /// Object.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// The size the client announced.
        size: Option<usize>,
        /// Both sides check the CRC.
        crc: bool,
        /// Data so far (whole segments).
        data: Vec<u8>,
        /// The next segment number expected.
        next: u8,
        /// The last segment arrived.
        last: bool,
    },
    /// Sending sub-blocks.
    Upload {
        /// Object.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Both sides check the CRC.
        crc: bool,
        /// The data.
        data: Vec<u8>,
        /// Bytes confirmed by the client.
        confirmed: usize,
        /// Segments per sub-block the client takes.
        block_size: u8,
        /// The client asked for the first sub-block.
        started: bool,
        /// The end was sent.
        ended: bool,
    },
}

/// An error of a transfer on `index`:`sub`.
type Failure = (u16, u8, Abort);

fn header(command: u8, index: u16, sub: u8) -> SdoFrame {
    let [i0, i1] = index.to_le_bytes();
    [command, i0, i1, sub, 0, 0, 0, 0]
}

/// Initiate block download (client command 6, sub-command 0).
pub fn initiate_download(
    od: &ObjectDictionary,
    frame: &SdoFrame,
    index: u16,
    sub: u8,
) -> Result<(Block, SdoFrame), Failure> {
    let entry = od.entry(index, sub).map_err(|abort| (index, sub, abort))?;
    if !entry.access.writable() {
        return Err((index, sub, Abort::READ_ONLY));
    }
    let size = u32::from_le_bytes([frame[4], frame[5], frame[6], frame[7]]) as usize;
    let block = Block::Download {
        index,
        sub,
        size: (frame[0] & SIZE_INDICATED != 0).then_some(size),
        crc: frame[0] & CRC_SUPPORTED != 0,
        data: Vec::new(),
        next: 1,
        last: false,
    };
    let mut answer = header(SCS_BLOCK_DOWNLOAD | CRC_SUPPORTED, index, sub);
    answer[4] = MAX_BLOCK_SIZE;
    Ok((block, answer))
}

/// Initiate block upload (client command 5, sub-command 0).
pub fn initiate_upload(
    od: &ObjectDictionary,
    frame: &SdoFrame,
    index: u16,
    sub: u8,
) -> Result<(Block, SdoFrame), Failure> {
    let block_size = frame[4];
    if !(1..=MAX_BLOCK_SIZE).contains(&block_size) {
        return Err((index, sub, INVALID_BLOCK_SIZE));
    }
    let data = od.read(index, sub).map_err(|abort| (index, sub, abort))?;
    let mut answer = header(
        SCS_BLOCK_UPLOAD | CRC_SUPPORTED | SIZE_INDICATED,
        index,
        sub,
    );
    answer[4..8].copy_from_slice(&(data.len() as u32).to_le_bytes());
    let block = Block::Upload {
        index,
        sub,
        crc: frame[0] & CRC_SUPPORTED != 0,
        data,
        confirmed: 0,
        block_size,
        started: false,
        ended: false,
    };
    Ok((block, answer))
}

impl Block {
    /// Whether a frame of the client is a segment of a download sub-block (which has no command
    /// specifier of its own).
    pub fn takes_segments(&self) -> bool {
        matches!(self, Block::Download { last: false, .. })
    }

    /// A frame of the client during the transfer; the answers, and whether the transfer is over.
    pub fn request(
        &mut self,
        od: &mut ObjectDictionary,
        frame: &SdoFrame,
    ) -> Result<(Vec<SdoFrame>, bool), Failure> {
        match self {
            Block::Download { last: false, .. } => Ok((self.segment(frame), false)),
            Block::Download { .. } => self
                .end_download(od, frame)
                .map(|answer| (vec![answer], true)),
            Block::Upload { .. } => self.upload_request(frame),
        }
    }

    fn segment(&mut self, frame: &SdoFrame) -> Vec<SdoFrame> {
        let Block::Download {
            data, next, last, ..
        } = self
        else {
            return Vec::new();
        };
        let sequence = frame[0] & SEQUENCE;
        // A segment out of order is dropped; the confirmation tells the client where to resume.
        if sequence == *next {
            data.extend_from_slice(&frame[1..]);
            *last = frame[0] & LAST_SEGMENT != 0;
            *next += 1;
        }
        if !*last && *next <= MAX_BLOCK_SIZE {
            return Vec::new();
        }
        let acknowledged = *next - 1;
        *next = 1;
        vec![[
            SCS_BLOCK_DOWNLOAD | CS_CONFIRM,
            acknowledged,
            MAX_BLOCK_SIZE,
            0,
            0,
            0,
            0,
            0,
        ]]
    }

    fn end_download(
        &mut self,
        od: &mut ObjectDictionary,
        frame: &SdoFrame,
    ) -> Result<SdoFrame, Failure> {
        let Block::Download {
            index,
            sub,
            size,
            crc,
            data,
            ..
        } = self
        else {
            unreachable!("only a download ends here");
        };
        let (index, sub) = (*index, *sub);
        if frame[0] >> 5 != 6 || frame[0] & 0x01 != CS_END {
            return Err((index, sub, Abort::COMMAND));
        }
        let unused = usize::from((frame[0] >> 2) & 0x07);
        data.truncate(data.len().saturating_sub(unused));
        if size.is_some_and(|size| size != data.len()) {
            return Err((index, sub, Abort::LENGTH));
        }
        if *crc && crc16(data) != u16::from_le_bytes([frame[1], frame[2]]) {
            return Err((index, sub, CRC_ERROR));
        }
        od.write(index, sub, data)
            .map_err(|abort| (index, sub, abort))?;
        Ok([SCS_BLOCK_DOWNLOAD | CS_END, 0, 0, 0, 0, 0, 0, 0])
    }

    fn upload_request(&mut self, frame: &SdoFrame) -> Result<(Vec<SdoFrame>, bool), Failure> {
        let Block::Upload {
            index,
            sub,
            crc,
            data,
            confirmed,
            block_size,
            started,
            ended,
        } = self
        else {
            unreachable!("only an upload answers here");
        };
        let (index, sub) = (*index, *sub);
        if frame[0] >> 5 != 5 {
            return Err((index, sub, Abort::COMMAND));
        }
        match frame[0] & 0x03 {
            CS_START_UPLOAD if !*started => *started = true,
            CS_CONFIRM if *started && !*ended => {
                let acknowledged = usize::from(frame[1]) * SEGMENT_BYTES;
                *confirmed = (*confirmed + acknowledged).min(data.len());
                if !(1..=MAX_BLOCK_SIZE).contains(&frame[2]) {
                    return Err((index, sub, INVALID_BLOCK_SIZE));
                }
                *block_size = frame[2];
                if *confirmed == data.len() {
                    *ended = true;
                    // Bytes of the last segment without data (all 7 when there was no data).
                    let unused = match data.len() % SEGMENT_BYTES {
                        0 if data.is_empty() => SEGMENT_BYTES,
                        0 => 0,
                        last => SEGMENT_BYTES - last,
                    } as u8;
                    let [c0, c1] = if *crc { crc16(data) } else { 0 }.to_le_bytes();
                    let end = [
                        SCS_BLOCK_UPLOAD | (unused << 2) | CS_END,
                        c0,
                        c1,
                        0,
                        0,
                        0,
                        0,
                        0,
                    ];
                    return Ok((vec![end], false));
                }
            }
            CS_END if *ended => return Ok((Vec::new(), true)),
            _ => return Err((index, sub, Abort::COMMAND)),
        }
        let mut segments = Vec::new();
        let mut offset = *confirmed;
        for sequence in 1..=*block_size {
            let chunk = &data[offset..(offset + SEGMENT_BYTES).min(data.len())];
            offset += chunk.len();
            let mut segment = [0u8; 8];
            segment[0] = sequence;
            segment[1..1 + chunk.len()].copy_from_slice(chunk);
            if offset == data.len() {
                segment[0] |= LAST_SEGMENT;
                segments.push(segment);
                break;
            }
            segments.push(segment);
        }
        Ok((segments, false))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eds;
    use crate::sdo::SdoServer;
    use std::path::Path;

    const EDS: &str = "\
[MandatoryObjects]
SupportedObjects=1
1=0x2001
[2001]
ParameterName=Label
DataType=0x0009
AccessType=rw
DefaultValue=cansim IO 8x8
";

    #[test]
    fn the_crc_is_crc16_1021_with_initial_value_0() {
        // The check value of this CRC over "123456789" is 31C3h.
        assert_eq!(crc16(b"123456789"), 0x31C3);
        assert_eq!(crc16(b""), 0);
    }

    #[test]
    fn block_download_in_one_sub_block_checked_by_crc() {
        let mut od = eds::parse(EDS, Path::new("t.eds"), 1).unwrap();
        let mut server = SdoServer::default();
        let text = b"twenty bytes of text";
        // Initiate: C0h | cc 04h | s 02h, size 20.
        let answer = server.request(&mut od, &[0xC6, 0x01, 0x20, 0x00, 20, 0, 0, 0], 0);
        assert_eq!(answer, [[0xA4, 0x01, 0x20, 0x00, 127, 0, 0, 0]]);
        let mut segments: Vec<[u8; 8]> = text
            .chunks(7)
            .enumerate()
            .map(|(k, chunk)| {
                let mut s = [0u8; 8];
                s[0] = k as u8 + 1;
                s[1..1 + chunk.len()].copy_from_slice(chunk);
                s
            })
            .collect();
        segments.last_mut().unwrap()[0] |= 0x80;
        assert!(server.request(&mut od, &segments[0], 0).is_empty());
        assert!(server.request(&mut od, &segments[1], 0).is_empty());
        assert_eq!(
            server.request(&mut od, &segments[2], 0),
            [[0xA2, 3, 127, 0, 0, 0, 0, 0]],
            "confirmed up to segment 3"
        );
        // End: C1h | n = 1 (one byte of the last segment unused) << 2, the CRC.
        let [c0, c1] = crc16(text).to_le_bytes();
        let answer = server.request(&mut od, &[0xC5, c0, c1, 0, 0, 0, 0, 0], 0);
        assert_eq!(answer, [[0xA1, 0, 0, 0, 0, 0, 0, 0]]);
        assert_eq!(od.read(0x2001, 0).unwrap(), text);
        // A wrong CRC aborts with 0504 0004 and writes nothing.
        server.request(&mut od, &[0xC6, 0x01, 0x20, 0x00, 1, 0, 0, 0], 0);
        server.request(&mut od, &[0x81, b'x', 0, 0, 0, 0, 0, 0], 0);
        let answer = server.request(&mut od, &[0xD9, 0x12, 0x34, 0, 0, 0, 0, 0], 0);
        assert_eq!(answer, [[0x80, 0x01, 0x20, 0x00, 0x04, 0x00, 0x04, 0x05]]);
        assert_eq!(od.read(0x2001, 0).unwrap(), text);
    }

    #[test]
    fn block_upload_in_sub_blocks_of_the_size_the_client_asks() {
        let mut od = eds::parse(EDS, Path::new("t.eds"), 1).unwrap();
        let mut server = SdoServer::default();
        // Initiate: A0h | cc 04h, block size 1.
        let answer = server.request(&mut od, &[0xA4, 0x01, 0x20, 0x00, 1, 0, 0, 0], 0);
        assert_eq!(answer, [[0xC6, 0x01, 0x20, 0x00, 13, 0, 0, 0]]);
        let first = server.request(&mut od, &[0xA3, 0, 0, 0, 0, 0, 0, 0], 0);
        assert_eq!(first.len(), 1);
        assert_eq!(first[0][0], 1);
        assert_eq!(&first[0][1..], b"cansim ");
        // Confirm segment 1, ask for 2 at a time: the rest is one segment, marked last.
        let second = server.request(&mut od, &[0xA2, 1, 2, 0, 0, 0, 0, 0], 0);
        assert_eq!(second.len(), 1);
        assert_eq!(second[0][0], 0x81);
        assert_eq!(&second[0][1..7], b"IO 8x8");
        // Confirmed: the end with n = 1 and the CRC, then the client's end.
        let end = server.request(&mut od, &[0xA2, 1, 2, 0, 0, 0, 0, 0], 0);
        let [c0, c1] = crc16(b"cansim IO 8x8").to_le_bytes();
        assert_eq!(end, [[0xC5, c0, c1, 0, 0, 0, 0, 0]]);
        assert!(server
            .request(&mut od, &[0xA1, 0, 0, 0, 0, 0, 0, 0], 0)
            .is_empty());
        assert!(!server.busy());
    }
}

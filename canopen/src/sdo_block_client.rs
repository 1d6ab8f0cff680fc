//! The client's side of SDO block transfers (CiA 301 7.2.4.3.9–7.2.4.3.16), the master's
//! counterpart of [`crate::sdo_block`]: a download sends the data in sub-blocks of the size the
//! server asks for and ends with the CRC; an upload asks for sub-blocks of [`BLOCK_SIZE`]
//! segments, confirms each, and checks the server's CRC at the end. Both sides announce CRC
//! support (cc, sc); the CRC is checked only when both did.

use crate::sdo::{Abort, SdoFrame};
use crate::sdo_block::crc16;
use crate::sdo_client::SdoOutcome;

/// Segments per sub-block this client takes when uploading.
pub const BLOCK_SIZE: u8 = 127;
const SEGMENT_BYTES: usize = 7;
/// Client command specifiers, in place.
const CCS_BLOCK_UPLOAD: u8 = 0xA0;
const CCS_BLOCK_DOWNLOAD: u8 = 0xC0;
/// Server command specifiers (bits 7..5 shifted down).
const SCS_BLOCK_DOWNLOAD: u8 = 5;
const SCS_BLOCK_UPLOAD: u8 = 6;
const SCS_ABORT: u8 = 4;
/// Flag and sub-command bits.
const CRC_SUPPORTED: u8 = 0x04;
const SIZE_INDICATED: u8 = 0x02;
const LAST_SEGMENT: u8 = 0x80;
const SEQUENCE: u8 = 0x7F;
const CS_INITIATE: u8 = 0;
const CS_END: u8 = 1;
const CS_CONFIRM: u8 = 2;
const CS_START_UPLOAD: u8 = 3;
/// 0504 0002: invalid block size; 0504 0004: CRC error.
const INVALID_BLOCK_SIZE: Abort = Abort(0x0504_0002);
const CRC_ERROR: Abort = Abort(0x0504_0004);

#[derive(Clone, Debug, PartialEq, Eq)]
enum State {
    /// Waiting for the initiate answer.
    Initiating,
    /// Download: the sub-block from `from` went out; waiting for its confirmation.
    Sending { from: usize, sent: usize },
    /// Download: the end went out.
    Ending,
    /// Upload: receiving segments; `next` is the sequence number expected.
    Receiving { next: u8 },
    /// Upload: the last segment arrived; waiting for the server's end.
    Ended,
}

/// One block transfer of a client.
#[derive(Clone, Debug)]
pub struct BlockClient {
    index: u16,
    sub: u8,
    upload: bool,
    state: State,
    data: Vec<u8>,
    crc: bool,
    last_us: u64,
}

fn header(command: u8, index: u16, sub: u8) -> SdoFrame {
    let [i0, i1] = index.to_le_bytes();
    [command, i0, i1, sub, 0, 0, 0, 0]
}

impl BlockClient {
    /// Starts writing `data` to `index`:`sub` at `now_us`; the initiate request.
    pub fn download(index: u16, sub: u8, data: &[u8], now_us: u64) -> (BlockClient, SdoFrame) {
        let mut request = header(
            CCS_BLOCK_DOWNLOAD | CRC_SUPPORTED | SIZE_INDICATED | CS_INITIATE,
            index,
            sub,
        );
        request[4..8].copy_from_slice(&(data.len() as u32).to_le_bytes());
        let client = BlockClient::new(index, sub, false, data.to_vec(), now_us);
        (client, request)
    }

    /// Starts reading `index`:`sub` at `now_us`; the initiate request (no protocol switch).
    pub fn upload(index: u16, sub: u8, now_us: u64) -> (BlockClient, SdoFrame) {
        let mut request = header(CCS_BLOCK_UPLOAD | CRC_SUPPORTED | CS_INITIATE, index, sub);
        request[4] = BLOCK_SIZE;
        (
            BlockClient::new(index, sub, true, Vec::new(), now_us),
            request,
        )
    }

    fn new(index: u16, sub: u8, upload: bool, data: Vec<u8>, now_us: u64) -> BlockClient {
        BlockClient {
            index,
            sub,
            upload,
            state: State::Initiating,
            data,
            crc: false,
            last_us: now_us,
        }
    }

    /// The server's frame at `now_us`: the frames to send next (none while a sub-block is still
    /// arriving), or the outcome (after an abort of the client's, send [`BlockClient::abort_frame`]).
    pub fn response(&mut self, frame: &[u8], now_us: u64) -> Result<Vec<SdoFrame>, SdoOutcome> {
        self.last_us = now_us;
        let Ok(frame) = <SdoFrame>::try_from(frame) else {
            return Err(SdoOutcome::Aborted(Abort::COMMAND));
        };
        if matches!(self.state, State::Receiving { .. }) {
            return self.segment(&frame);
        }
        let scs = frame[0] >> 5;
        if scs == SCS_ABORT {
            let code = u32::from_le_bytes([frame[4], frame[5], frame[6], frame[7]]);
            return Err(SdoOutcome::Aborted(Abort(code)));
        }
        let expected = if self.upload {
            SCS_BLOCK_UPLOAD
        } else {
            SCS_BLOCK_DOWNLOAD
        };
        if scs != expected {
            return Err(SdoOutcome::Aborted(Abort::COMMAND));
        }
        // The server's sub-command: bits 1..0 in a download, bit 0 in an upload (whose bit 1 is
        // the size indicator of the initiate answer).
        let sub_command = frame[0] & if self.upload { 0x01 } else { 0x03 };
        match (self.state.clone(), sub_command) {
            (State::Initiating, CS_INITIATE) if self.upload => {
                self.crc = frame[0] & CRC_SUPPORTED != 0;
                self.state = State::Receiving { next: 1 };
                Ok(vec![[
                    CCS_BLOCK_UPLOAD | CS_START_UPLOAD,
                    0,
                    0,
                    0,
                    0,
                    0,
                    0,
                    0,
                ]])
            }
            (State::Initiating, CS_INITIATE) => {
                self.crc = frame[0] & CRC_SUPPORTED != 0;
                self.sub_block(0, frame[4])
            }
            (State::Sending { from, sent }, CS_CONFIRM) => {
                let acknowledged = (usize::from(frame[1]) * SEGMENT_BYTES).min(sent - from);
                self.confirmed(from + acknowledged, frame[2])
            }
            (State::Ending, CS_END) => Err(SdoOutcome::Downloaded),
            (State::Ended, CS_END) => self.end_upload(&frame),
            _ => Err(SdoOutcome::Aborted(Abort::COMMAND)),
        }
    }

    /// Download: the next sub-block of `block_size` segments from byte `from`.
    fn sub_block(&mut self, from: usize, block_size: u8) -> Result<Vec<SdoFrame>, SdoOutcome> {
        if !(1..=BLOCK_SIZE).contains(&block_size) {
            return Err(SdoOutcome::Aborted(INVALID_BLOCK_SIZE));
        }
        let mut frames = Vec::new();
        let mut at = from;
        for sequence in 1..=block_size {
            let chunk = &self.data[at..(at + SEGMENT_BYTES).min(self.data.len())];
            let last = at + chunk.len() == self.data.len();
            let mut segment = [0u8; 8];
            segment[0] = sequence | if last { LAST_SEGMENT } else { 0 };
            segment[1..1 + chunk.len()].copy_from_slice(chunk);
            frames.push(segment);
            at += chunk.len();
            if last {
                break;
            }
        }
        self.state = State::Sending { from, sent: at };
        Ok(frames)
    }

    /// Download: the server has the data up to `confirmed` and takes `block_size` next.
    fn confirmed(&mut self, confirmed: usize, block_size: u8) -> Result<Vec<SdoFrame>, SdoOutcome> {
        if confirmed < self.data.len() {
            return self.sub_block(confirmed, block_size);
        }
        let unused = match self.data.len() % SEGMENT_BYTES {
            0 if self.data.is_empty() => SEGMENT_BYTES,
            0 => 0,
            last => SEGMENT_BYTES - last,
        } as u8;
        let [c0, c1] = if self.crc { crc16(&self.data) } else { 0 }.to_le_bytes();
        self.state = State::Ending;
        Ok(vec![[
            CCS_BLOCK_DOWNLOAD | (unused << 2) | CS_END,
            c0,
            c1,
            0,
            0,
            0,
            0,
            0,
        ]])
    }

    /// Upload: a segment of the sub-block.
    fn segment(&mut self, frame: &SdoFrame) -> Result<Vec<SdoFrame>, SdoOutcome> {
        let State::Receiving { next } = self.state else {
            unreachable!("only while receiving");
        };
        let sequence = frame[0] & SEQUENCE;
        let last = frame[0] & LAST_SEGMENT != 0;
        // A segment out of order is not taken: the confirmation names the last good one, and
        // the server sends again from there.
        let in_order = sequence == next;
        if in_order {
            self.data.extend_from_slice(&frame[1..]);
        }
        let good = if in_order { next } else { next - 1 };
        if !last && sequence < BLOCK_SIZE {
            if in_order {
                self.state = State::Receiving { next: next + 1 };
            }
            return Ok(Vec::new());
        }
        self.state = if last && in_order {
            State::Ended
        } else {
            State::Receiving { next: 1 }
        };
        Ok(vec![[
            CCS_BLOCK_UPLOAD | CS_CONFIRM,
            good,
            BLOCK_SIZE,
            0,
            0,
            0,
            0,
            0,
        ]])
    }

    /// Upload: the server's end with the unused bytes of the last segment and the CRC.
    fn end_upload(&mut self, frame: &SdoFrame) -> Result<Vec<SdoFrame>, SdoOutcome> {
        let unused = usize::from((frame[0] >> 2) & 0x07);
        self.data.truncate(self.data.len().saturating_sub(unused));
        if self.crc && crc16(&self.data) != u16::from_le_bytes([frame[1], frame[2]]) {
            return Err(SdoOutcome::Aborted(CRC_ERROR));
        }
        Err(SdoOutcome::Uploaded(std::mem::take(&mut self.data)))
    }

    /// The confirmation of an upload's end, sent once [`BlockClient::response`] returned the data.
    pub fn end_confirmation() -> SdoFrame {
        [CCS_BLOCK_UPLOAD | CS_END, 0, 0, 0, 0, 0, 0, 0]
    }

    /// The abort frame for this transfer and `abort`.
    pub fn abort_frame(&self, abort: Abort) -> SdoFrame {
        crate::sdo::abort_frame(self.index, self.sub, abort)
    }

    /// When the server last answered (or the transfer began).
    pub fn last_us(&self) -> u64 {
        self.last_us
    }
}

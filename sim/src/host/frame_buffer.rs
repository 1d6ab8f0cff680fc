//! The SJA1000 frame buffer layout (PeliCAN TX and RX buffer): frame information, 2 or 4 identifier
//! bytes, up to 8 data bytes. What a host writes to transmit a frame and reads to fetch one.
//!
//! Frame information: FF (bit 7, extended), RTR (bit 6), DLC (bits 3..0). Standard identifier:
//! ID.10..3, then ID.2..0 in bits 7..5 (RX: RTR copy in bit 4). Extended: ID.28..5 in three bytes,
//! then ID.4..0 in bits 7..3 (RX: RTR copy in bit 2).

use golden::frame::{Frame, Id};

/// Bytes of the frame buffer.
pub const FRAME_BUFFER_BYTES: usize = 13;

/// The frame-buffer bytes of `frame` as a host writes them (unused bytes 0).
pub fn encode_buffer(frame: &Frame) -> [u8; FRAME_BUFFER_BYTES] {
    let mut buf = [0u8; FRAME_BUFFER_BYTES];
    let (ff, id) = match frame.id() {
        Id::Standard(id) => (0u8, id as u32),
        Id::Extended(id) => (0x80, id),
    };
    buf[0] = ff | ((frame.is_remote() as u8) << 6) | frame.dlc();
    let data_at = if ff == 0 {
        buf[1] = (id >> 3) as u8;
        buf[2] = ((id & 7) << 5) as u8;
        3
    } else {
        buf[1] = (id >> 21) as u8;
        buf[2] = (id >> 13) as u8;
        buf[3] = (id >> 5) as u8;
        buf[4] = ((id & 0x1F) << 3) as u8;
        5
    };
    buf[data_at..data_at + frame.data_bytes().len()].copy_from_slice(frame.data_bytes());
    buf
}

/// How many frame-buffer bytes the frame whose frame information is `info` occupies.
pub fn buffer_len(info: u8) -> usize {
    let header = if info & 0x80 != 0 { 5 } else { 3 };
    let data = if info & 0x40 != 0 {
        0
    } else {
        (info & 0x0F).min(8) as usize
    };
    header + data
}

/// The frame stored in `bytes` (at least [`buffer_len`] of its first byte), as a host reads it
/// from the RX buffer.
pub fn decode_buffer(bytes: &[u8]) -> Frame {
    let info = bytes[0];
    let remote = info & 0x40 != 0;
    let dlc = info & 0x0F;
    let (id, data_at) = if info & 0x80 == 0 {
        let raw = ((bytes[1] as u16) << 3) | (bytes[2] as u16 >> 5);
        (Id::standard(raw).expect("11-bit identifier"), 3)
    } else {
        let raw = ((bytes[1] as u32) << 21)
            | ((bytes[2] as u32) << 13)
            | ((bytes[3] as u32) << 5)
            | (bytes[4] as u32 >> 3);
        (Id::extended(raw).expect("29-bit identifier"), 5)
    };
    let frame = if remote {
        Frame::remote(id, dlc)
    } else {
        let n = dlc.min(8) as usize;
        Frame::data_with_dlc(id, dlc, &bytes[data_at..data_at + n])
    };
    frame.expect("DLC 0..15")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_and_extended_frames_round_trip() {
        let frames = [
            Frame::data(Id::standard(0x5A5).unwrap(), &[1, 2, 3]).unwrap(),
            Frame::remote(Id::standard(0x7FF).unwrap(), 15).unwrap(),
            Frame::data_with_dlc(Id::extended(0x1ABC_DEF0).unwrap(), 12, &[9; 8]).unwrap(),
        ];
        for frame in frames {
            let buf = encode_buffer(&frame);
            assert_eq!(decode_buffer(&buf), frame);
            assert_eq!(
                buffer_len(buf[0]),
                1 + if frame.id().is_extended() { 4 } else { 2 } + frame.data_bytes().len()
            );
        }
    }

    #[test]
    fn standard_identifier_layout_matches_the_data_sheet() {
        let buf = encode_buffer(&Frame::data(Id::standard(0x123).unwrap(), &[0xAA]).unwrap());
        assert_eq!(&buf[..4], &[0x01, 0x24, 0x60, 0xAA]);
    }
}

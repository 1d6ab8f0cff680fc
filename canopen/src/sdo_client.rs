//! The SDO client (CiA 301 7.2.4), the master's side of [`crate::sdo`]: it reads (upload) and
//! writes (download) an entry of another node's dictionary, expedited when the data fits in 4
//! bytes and segmented otherwise (7 bytes per segment, toggle bit from 0, `c` on the last), and
//! reports the result, the server's abort code, or its own abort (wrong toggle 0503 0000, unknown
//! answer 0504 0001, no answer 0504 0000).

use crate::sdo::{abort_frame, Abort, SdoFrame};

/// Bytes of an expedited transfer and of a segment.
const EXPEDITED_BYTES: usize = 4;
const SEGMENT_BYTES: usize = 7;
/// Client command specifiers, in place (bits 7..5).
const CCS_DOWNLOAD_SEGMENT: u8 = 0x00;
const CCS_INITIATE_DOWNLOAD: u8 = 0x20;
const CCS_INITIATE_UPLOAD: u8 = 0x40;
const CCS_UPLOAD_SEGMENT: u8 = 0x60;
/// Server command specifiers (bits 7..5 shifted down).
const SCS_UPLOAD_SEGMENT: u8 = 0;
const SCS_DOWNLOAD_SEGMENT: u8 = 1;
const SCS_INITIATE_UPLOAD: u8 = 2;
const SCS_INITIATE_DOWNLOAD: u8 = 3;
const SCS_ABORT: u8 = 4;
/// Flag bits of byte 0.
const EXPEDITED: u8 = 0x02;
const SIZE_INDICATED: u8 = 0x01;
const TOGGLE: u8 = 0x10;
const LAST_SEGMENT: u8 = 0x01;

/// How a transfer ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SdoOutcome {
    /// An upload's data.
    Uploaded(Vec<u8>),
    /// A download was confirmed.
    Downloaded,
    /// The server aborted with this code, or the client did (then its abort frame went out).
    Aborted(Abort),
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum State {
    Idle,
    /// Waiting for the initiate answer of an upload.
    Uploading,
    /// Receiving segments.
    UploadSegments {
        data: Vec<u8>,
        toggle: bool,
    },
    /// Waiting for the initiate answer of a download; then sending `data` from `sent`.
    Downloading {
        data: Vec<u8>,
        sent: usize,
        toggle: bool,
        expedited: bool,
    },
}

/// A client's transfers with one server.
#[derive(Clone, Debug)]
pub struct SdoClient {
    state: State,
    index: u16,
    sub: u8,
    last_us: u64,
}

impl Default for SdoClient {
    fn default() -> Self {
        SdoClient {
            state: State::Idle,
            index: 0,
            sub: 0,
            last_us: 0,
        }
    }
}

fn header(command: u8, index: u16, sub: u8) -> SdoFrame {
    let [i0, i1] = index.to_le_bytes();
    [command, i0, i1, sub, 0, 0, 0, 0]
}

impl SdoClient {
    /// Whether a transfer is open.
    pub fn busy(&self) -> bool {
        self.state != State::Idle
    }

    /// Starts reading `index`:`sub` at `now_us`: the request to send.
    pub fn upload(&mut self, index: u16, sub: u8, now_us: u64) -> SdoFrame {
        (self.index, self.sub, self.last_us) = (index, sub, now_us);
        self.state = State::Uploading;
        header(CCS_INITIATE_UPLOAD, index, sub)
    }

    /// Starts writing `data` to `index`:`sub` at `now_us`: the request to send.
    pub fn download(&mut self, index: u16, sub: u8, data: &[u8], now_us: u64) -> SdoFrame {
        (self.index, self.sub, self.last_us) = (index, sub, now_us);
        let expedited = data.len() <= EXPEDITED_BYTES;
        let mut request = header(CCS_INITIATE_DOWNLOAD | SIZE_INDICATED, index, sub);
        if expedited {
            let unused = (EXPEDITED_BYTES - data.len()) as u8;
            request[0] |= EXPEDITED | (unused << 2);
            request[4..4 + data.len()].copy_from_slice(data);
        } else {
            request[4..8].copy_from_slice(&(data.len() as u32).to_le_bytes());
        }
        self.state = State::Downloading {
            data: data.to_vec(),
            sent: 0,
            toggle: false,
            expedited,
        };
        request
    }

    /// The server's answer `frame` at `now_us`: the next request to send, or the outcome.
    pub fn response(&mut self, frame: &[u8], now_us: u64) -> Result<SdoFrame, SdoOutcome> {
        self.last_us = now_us;
        let Ok(frame) = <SdoFrame>::try_from(frame) else {
            return Err(self.abort(Abort::COMMAND));
        };
        let scs = frame[0] >> 5;
        if scs == SCS_ABORT {
            self.state = State::Idle;
            let code = u32::from_le_bytes([frame[4], frame[5], frame[6], frame[7]]);
            return Err(SdoOutcome::Aborted(Abort(code)));
        }
        match std::mem::replace(&mut self.state, State::Idle) {
            State::Uploading if scs == SCS_INITIATE_UPLOAD => self.initiated_upload(&frame),
            State::UploadSegments { data, toggle } if scs == SCS_UPLOAD_SEGMENT => {
                self.upload_segment(&frame, data, toggle)
            }
            State::Downloading {
                data,
                sent,
                toggle,
                expedited,
            } if scs == SCS_INITIATE_DOWNLOAD && sent == 0 => {
                if expedited {
                    return Err(SdoOutcome::Downloaded);
                }
                Ok(self.next_segment(data, 0, toggle))
            }
            State::Downloading {
                data, sent, toggle, ..
            } if scs == SCS_DOWNLOAD_SEGMENT => {
                // The server echoes the toggle bit of the segment it confirms.
                if (frame[0] & TOGGLE != 0) == toggle {
                    return Err(self.abort(Abort::TOGGLE));
                }
                if sent == data.len() {
                    return Err(SdoOutcome::Downloaded);
                }
                Ok(self.next_segment(data, sent, toggle))
            }
            _ => Err(self.abort(Abort::COMMAND)),
        }
    }

    fn initiated_upload(&mut self, frame: &SdoFrame) -> Result<SdoFrame, SdoOutcome> {
        if frame[0] & EXPEDITED != 0 {
            let len = if frame[0] & SIZE_INDICATED != 0 {
                EXPEDITED_BYTES - usize::from((frame[0] >> 2) & 0x03)
            } else {
                EXPEDITED_BYTES
            };
            return Err(SdoOutcome::Uploaded(frame[4..4 + len].to_vec()));
        }
        self.state = State::UploadSegments {
            data: Vec::new(),
            toggle: false,
        };
        Ok([CCS_UPLOAD_SEGMENT, 0, 0, 0, 0, 0, 0, 0])
    }

    fn upload_segment(
        &mut self,
        frame: &SdoFrame,
        mut data: Vec<u8>,
        toggle: bool,
    ) -> Result<SdoFrame, SdoOutcome> {
        if (frame[0] & TOGGLE != 0) != toggle {
            return Err(self.abort(Abort::TOGGLE));
        }
        let unused = usize::from((frame[0] >> 1) & 0x07);
        data.extend_from_slice(&frame[1..1 + SEGMENT_BYTES - unused]);
        if frame[0] & LAST_SEGMENT != 0 {
            return Err(SdoOutcome::Uploaded(data));
        }
        let next = !toggle;
        self.state = State::UploadSegments { data, toggle: next };
        Ok([
            CCS_UPLOAD_SEGMENT | if next { TOGGLE } else { 0 },
            0,
            0,
            0,
            0,
            0,
            0,
            0,
        ])
    }

    fn next_segment(&mut self, data: Vec<u8>, sent: usize, toggle: bool) -> SdoFrame {
        let chunk = &data[sent..(sent + SEGMENT_BYTES).min(data.len())];
        let last = sent + chunk.len() == data.len();
        let unused = (SEGMENT_BYTES - chunk.len()) as u8;
        let mut request = [0u8; 8];
        request[0] = CCS_DOWNLOAD_SEGMENT | if toggle { TOGGLE } else { 0 } | (unused << 1);
        if last {
            request[0] |= LAST_SEGMENT;
        }
        request[1..1 + chunk.len()].copy_from_slice(chunk);
        let sent = sent + chunk.len();
        self.state = State::Downloading {
            data,
            sent,
            toggle: !toggle,
            expedited: false,
        };
        request
    }

    /// Ends the transfer with `abort`; the abort frame is [`SdoClient::abort_frame`].
    fn abort(&mut self, abort: Abort) -> SdoOutcome {
        self.state = State::Idle;
        SdoOutcome::Aborted(abort)
    }

    /// The abort frame for this client's transfer and `abort`.
    pub fn abort_frame(&self, abort: Abort) -> SdoFrame {
        abort_frame(self.index, self.sub, abort)
    }

    /// When the server last answered (or the transfer began).
    pub fn last_us(&self) -> u64 {
        self.last_us
    }

    /// At `now_us`, with `timeout_us` allowed per answer: the abort of a transfer left unanswered.
    pub fn check_timeout(&mut self, now_us: u64, timeout_us: u64) -> Option<SdoOutcome> {
        if !self.busy() || now_us < self.last_us + timeout_us {
            return None;
        }
        Some(self.abort(Abort::TIMEOUT))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eds;
    use crate::od::ObjectDictionary;
    use crate::sdo::SdoServer;
    use std::path::Path;

    const EDS: &str = "\
[MandatoryObjects]
SupportedObjects=3
1=0x1008
2=0x1017
3=0x2001
[1008]
ParameterName=Manufacturer device name
DataType=0x0009
AccessType=const
DefaultValue=cansim IO 8x8
[1017]
ParameterName=Producer heartbeat time
DataType=0x0006
AccessType=rw
DefaultValue=0
[2001]
ParameterName=Label
DataType=0x0009
AccessType=rw
DefaultValue=
";

    /// Runs a transfer between `client` and a server on `od` until it ends.
    fn transfer(client: &mut SdoClient, od: &mut ObjectDictionary, first: SdoFrame) -> SdoOutcome {
        let mut server = SdoServer::default();
        let mut request = first;
        for _ in 0..100 {
            let answers = server.request(od, &request, 0);
            match client.response(&answers[0], 0) {
                Ok(next) => request = next,
                Err(outcome) => return outcome,
            }
        }
        panic!("no end")
    }

    #[test]
    fn expedited_and_segmented_both_ways_against_our_server() {
        let mut od = eds::parse(EDS, Path::new("t.eds"), 2).unwrap();
        let mut client = SdoClient::default();
        let first = client.upload(0x1008, 0, 0);
        assert_eq!(
            transfer(&mut client, &mut od, first),
            SdoOutcome::Uploaded(b"cansim IO 8x8".to_vec())
        );
        let first = client.download(0x1017, 0, &[100, 0], 0);
        assert_eq!(first[0], 0x2B, "expedited, 2 bytes");
        assert_eq!(
            transfer(&mut client, &mut od, first),
            SdoOutcome::Downloaded
        );
        assert_eq!(od.unsigned(0x1017, 0), 100);
        let label = b"a label of twenty-five b";
        let first = client.download(0x2001, 0, label, 0);
        assert_eq!(
            transfer(&mut client, &mut od, first),
            SdoOutcome::Downloaded
        );
        let first = client.upload(0x2001, 0, 0);
        assert_eq!(
            transfer(&mut client, &mut od, first),
            SdoOutcome::Uploaded(label.to_vec())
        );
        assert!(!client.busy());
    }

    #[test]
    fn server_aborts_and_client_aborts() {
        let mut od = eds::parse(EDS, Path::new("t.eds"), 2).unwrap();
        let mut client = SdoClient::default();
        let first = client.download(0x1008, 0, b"x", 0);
        assert_eq!(
            transfer(&mut client, &mut od, first),
            SdoOutcome::Aborted(Abort(0x0601_0002))
        );
        // A segment with the wrong toggle bit: the client aborts with 0503 0000.
        client.upload(0x1008, 0, 0);
        client
            .response(&[0x41, 0x08, 0x10, 0, 13, 0, 0, 0], 0)
            .unwrap();
        let wrong = [0x10, b'c', b'a', b'n', b's', b'i', b'm', b' '];
        assert_eq!(
            client.response(&wrong, 0),
            Err(SdoOutcome::Aborted(Abort(0x0503_0000)))
        );
        assert_eq!(
            client.abort_frame(Abort::TOGGLE),
            [0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x03, 0x05]
        );
        // No answer: 0504 0000 after the timeout.
        client.upload(0x1017, 0, 1_000);
        assert_eq!(client.check_timeout(1_999, 1_000), None);
        assert_eq!(
            client.check_timeout(2_000, 1_000),
            Some(SdoOutcome::Aborted(Abort(0x0504_0000)))
        );
    }
}

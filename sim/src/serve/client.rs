//! One client of `cansim serve`: its TCP connection (non-blocking), where it is in the socketcand
//! protocol, its node on the bus and what waits to be written to it.
//!
//! Each handshake answer goes out on its own, and frames only start flowing once the client has
//! surely read the `rawmode` answer (python-can reads each answer with one `recv` and compares it
//! whole): when it sends anything after it, or [`RAW_HOLD`] after it.

use std::collections::VecDeque;
use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

use golden::frame::Frame;

use super::socketcand::{Splitter, GREETING};

/// How long frames wait after the `rawmode` answer when the client sends nothing.
pub const RAW_HOLD: Duration = Duration::from_millis(200);
/// Bytes waiting for a client that does not read, at most; frames beyond are lost for it (as a
/// socket's receive queue overflows) and counted.
pub const MAX_OUTBOX: usize = 1 << 20;
/// Bytes read from a socket at once.
const READ_CHUNK: usize = 4096;

/// Where a client is in the protocol.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Greeted, no bus open yet.
    NoBus,
    /// It asked to open the bus; its controller is integrating. Its `< ok >` waits until the
    /// controller takes part in the traffic, and what it sends meanwhile waits unread.
    Opening,
    /// The bus is open (socketcand's BCM mode): it can send, but frames do not reach it.
    Opened,
    /// Raw mode: every frame its node receives reaches it.
    Raw,
}

/// A connected client.
pub struct Client {
    /// Its address.
    pub peer: SocketAddr,
    stream: TcpStream,
    splitter: Splitter,
    /// Where it is in the protocol.
    pub phase: Phase,
    /// Its node, once it opened the bus.
    pub node: Option<usize>,
    /// Frames are held until then (after the `rawmode` answer).
    hold_until: Option<Instant>,
    outbox: VecDeque<u8>,
    /// Frames lost because it did not read.
    pub lost: u64,
    /// Frames it sent that wait for room in its controller's queue (while any wait, it is not
    /// read: TCP flow control holds it back).
    pub waiting: VecDeque<Frame>,
    /// The connection ended (closed by the client or broken).
    pub gone: bool,
}

impl Client {
    /// A new connection: non-blocking, no delay, greeted.
    pub fn new(stream: TcpStream, peer: SocketAddr) -> std::io::Result<Client> {
        stream.set_nonblocking(true)?;
        stream.set_nodelay(true)?;
        let mut client = Client {
            peer,
            stream,
            splitter: Splitter::default(),
            phase: Phase::NoBus,
            node: None,
            hold_until: None,
            outbox: VecDeque::new(),
            lost: 0,
            waiting: VecDeque::new(),
            gone: false,
        };
        client.answer(GREETING);
        Ok(client)
    }

    /// The messages it sent since the last call (and what was wrong with the rest); anything it
    /// sends after the `rawmode` answer lifts the hold.
    pub fn read(&mut self) -> Vec<Result<String, String>> {
        let mut messages = Vec::new();
        let mut buffer = [0u8; READ_CHUNK];
        while !self.gone {
            match self.stream.read(&mut buffer) {
                Ok(0) => self.gone = true,
                Ok(n) => messages.extend(self.splitter.push(&buffer[..n])),
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(_) => self.gone = true,
            }
        }
        if !messages.is_empty() && self.phase == Phase::Raw {
            self.hold_until = None;
        }
        messages
    }

    /// Sends a protocol answer now, on its own.
    pub fn answer(&mut self, message: &str) {
        self.outbox.extend(message.as_bytes());
        self.flush();
    }

    /// Enters raw mode: answers, and holds frames until the answer has surely been read.
    pub fn enter_raw_mode(&mut self, answer: &str) {
        self.answer(answer);
        self.phase = Phase::Raw;
        self.hold_until = Some(Instant::now() + RAW_HOLD);
    }

    /// Queues a frame message (in raw mode; in other phases frames do not reach the client).
    pub fn forward(&mut self, message: &str) {
        if self.phase != Phase::Raw {
            return;
        }
        if self.outbox.len() + message.len() > MAX_OUTBOX {
            self.lost += 1;
            return;
        }
        self.outbox.extend(message.as_bytes());
    }

    /// Writes what the socket takes of what waits (nothing while frames are held).
    pub fn flush(&mut self) {
        if self.hold_until.is_some_and(|until| Instant::now() < until) {
            return;
        }
        self.hold_until = None;
        while !self.outbox.is_empty() && !self.gone {
            let (front, _) = self.outbox.as_slices();
            match self.stream.write(front) {
                Ok(0) => self.gone = true,
                Ok(n) => {
                    self.outbox.drain(..n);
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(_) => self.gone = true,
            }
        }
    }
}

//! `cansim serve`: the bus of a scenario, running without end, as a socketcand server in raw mode
//! ([`socketcand`]), so python-can (`interface="socketcand"`), cantools, python `canopen` and
//! whatever else speaks socketcand can take part.
//!
//! Every client is a node: when it opens the bus, a complete controller (the RTL, at the
//! scenario's bus clock and bit timing, open filter, restarted 100 ms after bus-off) joins the
//! bus, driven through its registers by the model of the Linux driver. What the client sends is
//! transmitted by that controller, arbitrating like any other; what the controller receives goes
//! to the client, stamped with the simulated time; like SocketCAN, a client never gets its own
//! frames back. A client that goes away leaves the bus at its controller's next quiet moment, once
//! the frames it sent are out and its controller is in no frame, so its going loses none of its
//! frames and corrupts no other (after 1000 bit times it leaves anyway). The scenario's
//! nodes, traffic and faults run as with `cansim run`.
//!
//! Nothing grows with time: the bus log goes to its file as it happens (or nowhere), the events
//! are counted and forgotten, a client that does not read loses frames beyond 1 MiB of backlog
//! (counted), and the place of a client that left is taken by the next.

pub mod client;
pub mod pacing;
pub mod socketcand;

use std::fs::File;
use std::io::{BufWriter, ErrorKind, Write};
use std::net::TcpListener;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use crate::engine::time::{FS_PER_MS, FS_PER_S};
use crate::host::driver::DriverEvent;
use crate::nodes::controller_node::ModelEngine;
use crate::scenario::report::{Happening, NodeCounts};
use crate::scenario::run::Runner;
use crate::scenario::summary::LogCounts;
use crate::scenario::{NodeConfig, NodeMode, Scenario, ScenarioError, DEFAULT_TXQUEUELEN};

use client::{Client, Phase};
use pacing::Pace;
use socketcand::{error_message, frame_message, Request, ECHO, OK};

/// The port socketcand listens on.
pub const DEFAULT_PORT: u16 = 29536;
/// How long a client's controller waits after bus-off before its driver restarts it.
pub const CLIENT_RESTART_FS: u64 = 100 * FS_PER_MS;
/// How long the loop sleeps when the bus may not run further and no client does anything.
const IDLE_POLL: Duration = Duration::from_millis(1);
/// Bit times a departing client's controller may take to finish what it is doing before it is
/// taken off the bus anyway.
const LEAVE_LIMIT_BITS: u64 = 1000;
/// Where simulated time ends (femtoseconds in a `u64`: a little over 5 hours), with a second
/// to spare.
pub const END_OF_TIME_FS: u64 = u64::MAX - FS_PER_S;

/// How to serve.
pub struct ServeOptions<'a> {
    /// The bus name clients open (`can0`).
    pub channel: String,
    /// Pace the bus to the wall clock.
    pub realtime: bool,
    /// Without `realtime`: how far the bus may run past the last client activity.
    pub slice_fs: u64,
    /// Stop at this simulated time (else at Ctrl-C, SIGTERM or the end of simulated time).
    pub until_fs: Option<u64>,
    /// Write a VCD of the bus and the scenario's nodes here.
    pub vcd: Option<PathBuf>,
    /// Write the bus log here as it happens.
    pub log: Option<PathBuf>,
    /// The engine stepping the controllers (`None`: the one `CAN_ENGINE` chooses).
    pub engine: Option<ModelEngine>,
    /// Set to stop (by the Ctrl-C / SIGTERM handler).
    pub stop: &'a AtomicBool,
}

/// What a served run did.
#[derive(Debug)]
pub struct ServeSummary {
    /// Simulated time at the end.
    pub simulated_fs: u64,
    /// Simulated time per wall-clock time.
    pub factor: f64,
    /// Clients that connected.
    pub clients: usize,
    /// The bus log's counts.
    pub bus: LogCounts,
    /// The scenario's nodes and the clients still connected, at the end.
    pub nodes: Vec<NodeCounts>,
    /// The VCD written, if any.
    pub vcd: Option<PathBuf>,
    /// Steps of the CANopen master that failed or had not ended.
    pub failed_steps: usize,
}

/// Listens on `address` (`HOST:PORT`; port 0 picks a free one), or says why it cannot.
pub fn listen(address: &str) -> Result<TcpListener, String> {
    let listener =
        TcpListener::bind(address).map_err(|e| format!("cannot listen on {address}: {e}"))?;
    listener
        .set_nonblocking(true)
        .map_err(|e| format!("cannot listen on {address}: {e}"))?;
    Ok(listener)
}

/// Serves `scenario`'s bus to the clients of `listener` until stopped; `say` gets what happens
/// (clients coming and going, falling behind real time).
pub fn serve(
    scenario: &Scenario,
    listener: &TcpListener,
    options: ServeOptions,
    say: &mut dyn FnMut(&str),
) -> Result<ServeSummary, ScenarioError> {
    let model = match options.engine {
        Some(engine) => engine,
        None => ModelEngine::from_env().map_err(ScenarioError::new)?,
    };
    let log = match &options.log {
        Some(path) => Some(BufWriter::new(File::create(path).map_err(|e| {
            ScenarioError::new(format!("cannot write {}: {e}", path.display()))
        })?)),
        None => None,
    };
    let mut runner = Runner::new(scenario, model)?;
    if let Some(path) = &options.vcd {
        runner.trace(path)?;
    }
    runner.begin()?;
    let mut server = Server {
        pace: Pace::new(options.realtime, options.slice_fs, runner.clock()),
        runner,
        scenario,
        clients: Vec::new(),
        leaving: Vec::new(),
        channel: options.channel,
        connected: 0,
        log,
        counts: LogCounts::default(),
        failed_steps: 0,
    };
    let end = options
        .until_fs
        .unwrap_or(END_OF_TIME_FS)
        .min(END_OF_TIME_FS);
    while !options.stop.load(Ordering::Relaxed) && server.runner.clock() < end {
        server.accept(listener, say);
        server.read_clients(say)?;
        server.queue_client_frames();
        server.complete_opens(say);
        server.depart(say);
        let allowed = server.pace.allowed().min(end);
        if server.runner.clock() < allowed {
            server.runner.step(allowed)?;
            if let Some(message) = server.pace.check_behind(server.runner.clock()) {
                say(&message);
            }
        } else {
            std::thread::sleep(IDLE_POLL);
        }
        server.route();
        server.write_log()?;
        server.report_master(say);
        server.clients.iter_mut().for_each(Client::flush);
    }
    if server.runner.clock() >= END_OF_TIME_FS {
        say("simulated time ends here (5.1 hours of femtoseconds)");
    }
    server.report_master(say);
    for line in server.runner.unfinished_master_steps() {
        server.failed_steps += 1;
        say(&format!("master: {line}"));
    }
    server.finish()
}

/// The state of a served bus.
struct Server<'s> {
    runner: Runner<'s>,
    scenario: &'s Scenario,
    pace: Pace,
    clients: Vec<Client>,
    /// Nodes of clients that went away, with the simulated time they went.
    leaving: Vec<(usize, u64)>,
    channel: String,
    /// Clients that connected so far.
    connected: usize,
    log: Option<BufWriter<File>>,
    counts: LogCounts,
    /// Steps of the CANopen master that did not give what they expected.
    failed_steps: usize,
}

impl Server<'_> {
    /// Greets the new connections.
    fn accept(&mut self, listener: &TcpListener, say: &mut dyn FnMut(&str)) {
        loop {
            match listener.accept() {
                Ok((stream, peer)) => match Client::new(stream, peer) {
                    Ok(client) => {
                        self.connected += 1;
                        self.clients.push(client);
                        self.pace.activity(self.runner.clock());
                    }
                    Err(e) => say(&format!("client {peer}: {e}")),
                },
                Err(e) if e.kind() == ErrorKind::WouldBlock => return,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => {
                    say(&format!("accepting a client failed: {e}"));
                    return;
                }
            }
        }
    }

    /// Reads and answers what every client sent; sends the controllers of clients that went away
    /// on their way out.
    fn read_clients(&mut self, say: &mut dyn FnMut(&str)) -> Result<(), ScenarioError> {
        for c in 0..self.clients.len() {
            // Flow control: a client whose frames wait for room in its controller's queue is not
            // read, so TCP slows it down instead of its frames being dropped.
            if self.clients[c].phase == Phase::Opening || !self.clients[c].waiting.is_empty() {
                continue;
            }
            for message in self.clients[c].read() {
                self.pace.activity(self.runner.clock());
                self.handle(c, message)?;
            }
        }
        let now = self.runner.clock();
        for client in self.clients.iter().filter(|c| c.gone) {
            if let Some(n) = client.node {
                // What it sent before it went still goes out (the waiting frames too).
                for frame in client.waiting.iter() {
                    self.runner.push_unbounded(n, *frame);
                }
                self.leaving.push((n, now));
            }
            say(&format!(
                "client {} went away at {:.3} ms{}",
                client.peer,
                now as f64 / FS_PER_MS as f64,
                match client.lost {
                    0 => String::new(),
                    lost => format!(" ({lost} frames lost: it did not read them)"),
                }
            ));
        }
        self.clients.retain(|c| !c.gone);
        Ok(())
    }

    /// Answers one message of client `c`.
    fn handle(&mut self, c: usize, message: Result<String, String>) -> Result<(), ScenarioError> {
        let request = message.and_then(|m| socketcand::parse(&m));
        let client = &mut self.clients[c];
        match (request, client.phase, client.node) {
            (Err(e), _, _) => client.answer(&error_message(&e)),
            (Ok(Request::Echo), _, _) => client.answer(ECHO),
            (Ok(Request::Open(bus)), Phase::NoBus, _) if bus != self.channel => {
                let text = format!("no bus '{bus}' here: this server has {}", self.channel);
                client.answer(&error_message(&text));
                client.gone = true;
            }
            (Ok(Request::Open(_)), Phase::NoBus, _) => {
                let config = self.client_node();
                let n = self.runner.join(&config)?;
                let client = &mut self.clients[c];
                client.node = Some(n);
                client.phase = Phase::Opening;
            }
            (Ok(_), Phase::NoBus, _) | (_, _, None) => {
                let text = format!("open the bus first (open {})", self.channel);
                client.answer(&error_message(&text));
            }
            (Ok(Request::Open(_)), _, _) => client.answer(&error_message("the bus is open")),
            (Ok(Request::RawMode), _, _) => client.enter_raw_mode(OK),
            (Ok(Request::BcmMode), _, _) => {
                client.phase = Phase::Opened;
                client.answer(OK);
            }
            (Ok(Request::Send(frame)), _, Some(_)) => client.waiting.push_back(frame),
        }
        Ok(())
    }

    /// Moves the frames clients sent into their controllers' queues, as far as there is room.
    fn queue_client_frames(&mut self) {
        for client in &mut self.clients {
            let Some(n) = client.node else {
                continue;
            };
            while self.runner.has_room(n) {
                let Some(frame) = client.waiting.pop_front() else {
                    break;
                };
                self.runner.offer(n, frame);
            }
        }
    }

    /// Answers the clients whose controllers are now on the bus.
    fn complete_opens(&mut self, say: &mut dyn FnMut(&str)) {
        for client in &mut self.clients {
            let Some(n) = client.node.filter(|_| client.phase == Phase::Opening) else {
                continue;
            };
            if !self.runner.integrated(n) {
                continue;
            }
            client.phase = Phase::Opened;
            client.answer(OK);
            say(&format!(
                "client {} opened {} at {:.3} ms: it is node {}",
                client.peer,
                self.channel,
                self.runner.clock() as f64 / FS_PER_MS as f64,
                self.runner.name(n)
            ));
        }
    }

    /// The node of the next client: the bus's clock and bit timing, an open filter.
    fn client_node(&self) -> NodeConfig {
        let bus = &self.scenario.bus;
        NodeConfig {
            name: format!("client{}", self.connected),
            clock_hz: bus.clock_hz,
            ppm: 0.0,
            delay_fs: 0,
            btr: bus.btr,
            mode: NodeMode::Normal,
            filter: crate::host::driver::open_filter(),
            restart_fs: Some(CLIENT_RESTART_FS),
            berr_reporting: true,
            one_shot: false,
            txqueuelen: DEFAULT_TXQUEUELEN,
            canopen: None,
            canopen_master: None,
        }
    }

    /// Takes the controllers of departed clients off the bus once they are quiet.
    fn depart(&mut self, say: &mut dyn FnMut(&str)) {
        let now = self.runner.clock();
        let limit = LEAVE_LIMIT_BITS * self.scenario.bus.bit_fs();
        let mut k = 0;
        while k < self.leaving.len() {
            let (n, since) = self.leaving[k];
            if !self.runner.can_leave(n) && now - since < limit {
                k += 1;
                continue;
            }
            let counts = self.runner.counts(n);
            self.runner.leave(n);
            self.leaving.swap_remove(k);
            say(&format!(
                "node {} left the bus: sent {}, received {}, dropped {}",
                counts.name, counts.sent, counts.received, counts.dropped
            ));
        }
    }

    /// Hands every client the frames its controller received; forgets the other events.
    fn route(&mut self) {
        for n in 0..self.runner.node_count() {
            let events = self.runner.take_events(n);
            let Some(client) = self.clients.iter_mut().find(|c| c.node == Some(n)) else {
                continue;
            };
            for (at, what) in events {
                if let Happening::Driver(DriverEvent::Received(frame)) = what {
                    client.forward(&frame_message(&frame, at));
                }
            }
        }
    }

    /// Says what the CANopen master did since the last call.
    fn report_master(&mut self, say: &mut dyn FnMut(&str)) {
        for line in self.runner.take_master_lines() {
            self.failed_steps += usize::from(line.failed);
            say(&format!("master: {line}"));
        }
    }

    /// Counts the bus log since the last call and writes it to the log file.
    fn write_log(&mut self) -> Result<(), ScenarioError> {
        let events = self.runner.take_log();
        for event in &events {
            self.counts.add(event);
        }
        if let (Some(log), false) = (&mut self.log, events.is_empty()) {
            let written: std::io::Result<()> = events
                .iter()
                .try_for_each(|event| writeln!(log, "{event}"))
                .and_then(|_| log.flush());
            written.map_err(|e| ScenarioError::new(format!("writing the bus log: {e}")))?;
        }
        Ok(())
    }

    fn finish(mut self) -> Result<ServeSummary, ScenarioError> {
        self.write_log()?;
        let simulated_fs = self.runner.clock();
        let present: Vec<usize> = (0..self.runner.node_count())
            .filter(|&n| self.runner.present(n))
            .collect();
        let nodes = present.into_iter().map(|n| self.runner.counts(n)).collect();
        Ok(ServeSummary {
            simulated_fs,
            factor: self.pace.factor(simulated_fs),
            clients: self.connected,
            bus: self.counts,
            nodes,
            vcd: self.runner.finish_trace()?,
            failed_steps: self.failed_steps,
        })
    }
}

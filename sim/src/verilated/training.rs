//! The training run of a profile-guided build (`cache.rs`): the instrumented library runs the
//! reference workload's kind of traffic (two controllers at 500 kbit/s, one sending 8-byte frames
//! through its registers, the other reading and releasing each, the quiet edges skipped as the
//! engine skips them) and writes its profile, from which the compiler lays out the library that is
//! kept. What the training does changes how fast the library runs, never what it computes.

use std::path::Path;

use golden::frame::{Frame, Id};
use rtl::registers::{command, pelican, status};

use super::quiet_word::QuietField;
use super::{EngineError, ModelLibrary, PortInputs, VerilatedController, MIN_SKIPPED_CYCLES};
use crate::host::sja1000::{
    enter_operating_mode, read_rx_message, release_rx, set_up_pelican, transmit, PelicanSetup,
    BTR0_500K_SJW2_AT_16MHZ, BTR1_500K_AT_16MHZ,
};
use crate::host::RegisterPort;

/// Frames of the training run (about 0.3 s instrumented).
const FRAMES: u8 = 16;
/// Cycles after a transmit request in which the frame is sent and received (an 8-byte frame with
/// stuff bits and intermission is at most about 140 bits of 32 cycles).
const CYCLES_PER_FRAME: u64 = 5_000;
/// Reset cycles at the start, as the engine's controllers get.
const RESET_CYCLES: u64 = 4;

type DumpFn = unsafe extern "C" fn();

/// Runs the training on the instrumented library at `path` (its quiet word laid out as `layout`)
/// and writes the profile. The library stays loaded (a model library is never unloaded).
pub(super) fn train(path: &Path, layout: &[QuietField]) -> Result<(), EngineError> {
    let library: &'static ModelLibrary = Box::leak(Box::new(ModelLibrary::open((
        path.to_path_buf(),
        layout.to_vec(),
    ))?));
    // SAFETY: the shim defines `cc_profile_dump` as `void()` in the instrumented build.
    let dump: DumpFn = unsafe { library.handle.function("cc_profile_dump") }
        .map_err(|e| EngineError::Load(format!("{}: {e}", path.display())))?;
    TrainingBus::of(library)?.run_traffic()?;
    // SAFETY: takes no arguments; writes the counters' files.
    unsafe { dump() };
    Ok(())
}

/// Two controllers on a wired-AND bus, stepped together; the host accesses one at a time.
struct TrainingBus {
    nodes: [VerilatedController; 2],
    /// The bus level both see at the next edge.
    rx: bool,
    /// The node [`RegisterPort`] accesses reach.
    node: usize,
}

impl TrainingBus {
    /// Two new controllers of `library` on an idle bus.
    fn of(library: &'static ModelLibrary) -> Result<TrainingBus, EngineError> {
        Ok(TrainingBus {
            nodes: [
                VerilatedController::with_library(library)?,
                VerilatedController::with_library(library)?,
            ],
            rx: true,
            node: 0,
        })
    }

    /// One edge of both, the host's access (if any) at node `self.node`.
    fn cycle(&mut self, access: PortInputs) {
        let idle = self.idle();
        let mut rx = true;
        for (k, node) in self.nodes.iter_mut().enumerate() {
            let inputs = if k == self.node {
                PortInputs {
                    rx: idle.rx,
                    ..access
                }
            } else {
                idle
            };
            rx &= node.cycle(inputs).tx();
        }
        self.rx = rx;
    }

    fn idle(&self) -> PortInputs {
        PortInputs {
            rx: self.rx,
            ..PortInputs::default()
        }
    }

    /// `cycles` idle edges, the quiet stretches both nodes agree on skipped (as the engine does
    /// for two controllers on one clock).
    fn idle_cycles(&mut self, cycles: u64) {
        let mut done = 0;
        while done < cycles {
            let idle = self.idle();
            let quiet = self
                .nodes
                .iter()
                .map(|n| n.quiet_cycles(idle, false, MIN_SKIPPED_CYCLES))
                .min()
                .unwrap_or(0)
                .min(cycles - done);
            if quiet >= MIN_SKIPPED_CYCLES {
                for node in &mut self.nodes {
                    node.skip(quiet, false, false);
                }
                done += quiet;
            } else {
                self.cycle(idle);
                done += 1;
            }
        }
    }

    /// Both controllers set up, node 0 sends [`FRAMES`] frames, node 1 takes each; an error if a
    /// frame does not arrive intact (then the training would not be the traffic it should be).
    fn run_traffic(&mut self) -> Result<(), EngineError> {
        let reset = PortInputs {
            reset: true,
            ..PortInputs::default()
        };
        for _ in 0..RESET_CYCLES {
            self.cycle(reset);
        }
        self.cycle(PortInputs::default());
        let setup = PelicanSetup::open(BTR0_500K_SJW2_AT_16MHZ, BTR1_500K_AT_16MHZ);
        for node in 0..self.nodes.len() {
            self.node = node;
            set_up_pelican(self, &setup);
            enter_operating_mode(self, 0);
        }
        // Bus integration: 11 recessive bits.
        self.idle_cycles(CYCLES_PER_FRAME / 10);
        for k in 0..FRAMES {
            let data: Vec<u8> = (0..8)
                .map(|i| k.wrapping_mul(37).wrapping_add(i * 11))
                .collect();
            let id = Id::standard(0x100 + u16::from(k)).expect("an 11-bit identifier");
            let frame = Frame::data(id, &data).expect("8 data bytes");
            self.node = 0;
            transmit(self, &frame, command::TR);
            self.idle_cycles(CYCLES_PER_FRAME);
            self.node = 1;
            let received = (self.read(pelican::SR) & status::RBS != 0).then(|| {
                let received = read_rx_message(self);
                release_rx(self);
                received
            });
            if received.as_ref() != Some(&frame) {
                return Err(EngineError::Build(format!(
                    "profile training: frame {k} sent as {frame:?}, received {received:?}"
                )));
            }
        }
        Ok(())
    }
}

impl RegisterPort for TrainingBus {
    fn write(&mut self, addr: u8, value: u8) {
        self.cycle(PortInputs {
            addr,
            wdata: value,
            we: true,
            ..PortInputs::default()
        });
    }

    fn read(&mut self, addr: u8) -> u8 {
        self.cycle(PortInputs {
            addr,
            re: true,
            ..PortInputs::default()
        });
        self.nodes[self.node].outputs().rdata()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The training is the traffic it is meant to be only if its frames arrive: on the kept
    /// library (the same design and shim), every one of them intact.
    #[test]
    fn the_training_traffic_arrives_intact() {
        let library = super::super::model_library().unwrap_or_else(|e| panic!("{e}"));
        let mut bus = TrainingBus::of(library).unwrap();
        bus.run_traffic().unwrap_or_else(|e| panic!("{e}"));
    }
}

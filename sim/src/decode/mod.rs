//! Reading a bus: the streaming CAN bus decoder (level changes in, frames, error and overload
//! frames out) and the VCD reader that feeds it from any waveform file.

pub mod bus_decoder;
pub mod vcd_reader;

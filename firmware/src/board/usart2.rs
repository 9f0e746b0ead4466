//! USART2, the serial link to the autopilot (MAVLink 2, `autopilot-link`), shared by both
//! boards: the driver of [`super::usart`] with its own queues.
//!
//! Pins and speed: on the `f405` board PA2 (TX) / PA3 (RX, pull-up), alternate function 7,
//! at 460,800 baud 8N1 (ArduPilot's `SERIALn_BAUD` 460; PX4's `SER_TELn_BAUD` to match):
//! a step's MAVLink (158 bytes in, 72 out, 50 times a second) is 17 % of it, and its
//! interrupts, in the control task's bound, land half as often as at 921,600; under QEMU
//! the second `-serial`.
//!
//! Queue sizes: receive [`RX_QUEUE_LEN`], transmit [`TX_QUEUE_LEN`] (the reasons at each).
//! The main loop reads whenever a byte is queued (MAVLink frames are delimited by their
//! length, not by a zero).
//!
//! Invariants: those of [`super::usart`].

/// Receive queue capacity, bytes: two control periods of the autopilot's stream as the
/// simulator sends it at its longest (a heartbeat, two `PARAM_VALUE`s, `LOCAL_POSITION_NED`,
/// `VFR_HUD`, `AOA_SSA` and `ATTITUDE`: 235 bytes), rounded up to a power of two. The main loop drains it
/// every pass; a byte that finds it full is counted (`AutopilotLinkCounters::rx_errors`).
pub const RX_QUEUE_LEN: usize = 512;

/// Transmit queue capacity, bytes: a period's largest burst (a heartbeat, two parameter
/// requests and a setpoint, 136 bytes) three times over, rounded up to a power of two; at
/// 460,800 baud it drains in 11 ms.
pub const TX_QUEUE_LEN: usize = 512;

const _: () = assert!(autopilot_link::session::MAX_BURST_LEN * 3 <= TX_QUEUE_LEN);
const _: () = assert!(
    2 * autopilot_link::peer::MAX_TELEMETRY_LEN <= RX_QUEUE_LEN
        && crate::app::AUTOPILOT_CHUNK_LEN <= RX_QUEUE_LEN
);

super::usart::serial_port!(USART2);

impl embedded_io::ReadReady for SerialLink {
    /// Any byte: MAVLink frames have no end marker to wait for.
    fn read_ready(&mut self) -> Result<bool, core::convert::Infallible> {
        Ok(rx_pending())
    }
}

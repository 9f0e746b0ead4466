//! USART1, the serial link to the peer, shared by both boards: an interrupt-fed receive
//! queue and an interrupt-drained transmit queue ([`SerialLink`], the driver of
//! [`super::usart`]).
//!
//! Place in the data flow: the USART1 interrupt runs [`SerialQueues::on_interrupt`]
//! (`crate::serial`: every decision is there, board-independent and host-tested) over the
//! USART1 registers ([`Usart1Registers`]); the application reads received bytes through
//! [`embedded_io::Read`] and hands each frame whole to [`SerialLink::transmit`], which
//! queues it (or refuses it whole) and pends the interrupt, and returns at once: the
//! control task never waits on the wire (the largest command frame takes 3.8 ms at
//! 921,600 baud). Under QEMU the baud rate is ignored and a write is immediate, so the
//! pended interrupt sends a whole frame in one run; on the MCU each TXE interrupt sends the
//! next byte.
//!
//! Queue sizes: receive [`RX_QUEUE_LEN`], transmit [`TX_QUEUE_LEN`] (the reasons at each).
//!
//! Invariants: after [`init`] only the interrupt touches the USART's registers (the main
//! loop touches the queues and pends the interrupt in the NVIC), so no register access
//! needs a critical section and nothing here can panic (this file is in the no-panic link
//! check, `src/bin/nopanic.rs`). A received byte is never dropped silently: a hardware
//! error (overrun, noise, framing, parity) or a full queue is counted ([`take_rx_errors`]);
//! a frame the transmit queue cannot take whole is refused, and the application counts it.

/// Receive queue capacity, bytes: more than a configuration write (447 bytes, the largest
/// frame the peer sends) and five measurement frames; 5.5 ms of back-to-back bytes at
/// 921,600 baud; the main loop drains it at every frame's end and whenever it is half full.
pub const RX_QUEUE_LEN: usize = 512;

// One read of the application takes the whole queue, so a frame is decoded in one call.
const _: () = assert!(crate::app::RX_CHUNK_LEN >= RX_QUEUE_LEN);

/// Transmit queue capacity, bytes: the largest frame the link can carry
/// ([`ibvs_core::wire::MAX_FRAME_LEN`], 704; a configuration report is at most 655), the
/// largest command frame (138) and the largest telemetry frame (359) behind it, so that a
/// configuration report followed by the period's frames is never refused (a power of two:
/// 2,048). At 921,600 baud those 1,201 bytes drain in 13.0 ms, less than one control period,
/// so in flight (one command frame per period, 1.5 ms on the wire) it never holds more than
/// that period's frames; a refused frame means the wire is slower than that (counted,
/// `LinkCounters::tx_dropped`).
pub const TX_QUEUE_LEN: usize = 2048;

const _: () = assert!(TX_QUEUE_LEN >= ibvs_core::wire::MAX_FRAME_LEN + 138 + 359);

super::usart::serial_port!(USART1);

impl embedded_io::ReadReady for SerialLink {
    /// The peer's frames end in a zero: ready once one is in (or the queue is half full), so
    /// a frame is decoded whole in one read.
    fn read_ready(&mut self) -> Result<bool, core::convert::Infallible> {
        Ok(rx_frame_ready())
    }
}

//! USART1, the serial link to the peer, shared by both boards: an interrupt-fed receive
//! queue and an interrupt-drained transmit queue ([`SerialLink`]).
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

use core::convert::Infallible;

use stm32f4xx_hal::pac::{self, USART1, interrupt};

use crate::serial::{QueueFull, SerialQueues, UsartRegisters, UsartStatus};

/// Receive queue capacity, bytes: more than a configuration write (447 bytes, the largest
/// frame the peer sends) and five measurement frames; 5.5 ms of back-to-back bytes at
/// 921,600 baud; the main loop drains it at every frame's end and whenever it is half full.
pub const RX_QUEUE_LEN: usize = 512;

// One read of the application takes the whole queue, so a frame is decoded in one call.
const _: () = assert!(crate::app::RX_CHUNK_LEN >= RX_QUEUE_LEN);

/// Transmit queue capacity, bytes: the largest frame the link can carry
/// ([`ibvs_core::wire::MAX_FRAME_LEN`], 704; a configuration report is at most 655), the
/// largest command frame (138) and the largest telemetry frame (253) behind it, so that a
/// configuration report followed by the period's frames is never refused (a power of two:
/// 2,048). At 921,600 baud those 1,095 bytes drain in 11.9 ms, less than one control period,
/// so in flight (one command frame per period, 1.5 ms on the wire) it never holds more than
/// that period's frames; a refused frame means the wire is slower than that (counted,
/// `LinkCounters::tx_dropped`).
pub const TX_QUEUE_LEN: usize = 2048;

const _: () = assert!(TX_QUEUE_LEN >= ibvs_core::wire::MAX_FRAME_LEN + 138 + 253);

/// The queues the USART1 interrupt and the main loop share.
static LINK: SerialQueues<RX_QUEUE_LEN, TX_QUEUE_LEN> = SerialQueues::new();

/// The USART1 registers, as the interrupt uses them.
pub struct Usart1Registers(());

impl Usart1Registers {
    fn regs() -> &'static pac::usart1::RegisterBlock {
        // Note(unsafe): a shared reference to the memory-mapped register block, which is
        // always mapped. Only the USART1 interrupt uses it after `init` (which owned the
        // peripheral and configured it), and the fault path, with interrupts masked.
        #[allow(unsafe_code)]
        unsafe {
            &*USART1::ptr()
        }
    }
}

impl UsartRegisters for Usart1Registers {
    fn status(&mut self) -> UsartStatus {
        let sr = Self::regs().sr().read();
        UsartStatus {
            rx_ready: sr.rxne().bit_is_set(),
            tx_empty: sr.txe().bit_is_set(),
            rx_error: sr.ore().bit_is_set()
                || sr.nf().bit_is_set()
                || sr.fe().bit_is_set()
                || sr.pe().bit_is_set(),
        }
    }

    fn read_data(&mut self) -> u8 {
        Self::regs().dr().read().dr().bits() as u8
    }

    fn write_data(&mut self, byte: u8) {
        Self::regs().dr().write(|w| w.dr().set(u16::from(byte)));
    }

    fn set_tx_empty_interrupt(&mut self, enabled: bool) {
        // Written whole every run, from what `init` set: one bus write, where reading it to
        // compare or modify costs one or two reads more on every run (the interrupt's cost is
        // in the control task's cycle bound). The interrupt is CR1's only writer after
        // `init`; writing UE, TE, RE and RXNEIE as they are changes nothing (TE sends an
        // idle frame only on a 0-to-1 change).
        Self::regs().cr1().write(|w| cr1(w, enabled));
    }
}

/// CR1 as the link runs it: the USART, its transmitter, its receiver and the receive
/// interrupt on (8N1: the other bits at their reset values), the TXE interrupt as asked.
/// [`init`] and the interrupt both write it whole.
fn cr1(w: &mut pac::usart1::cr1::W, tx_empty_interrupt: bool) -> &mut pac::usart1::cr1::W {
    w.ue().set_bit();
    w.te().set_bit();
    w.re().set_bit();
    w.rxneie().set_bit();
    w.txeie().bit(tx_empty_interrupt)
}

/// The link: reads drain the receive queue, [`SerialLink::transmit`] fills the transmit
/// queue.
pub struct SerialLink {
    _private: (),
}

/// Enables USART1 (8N1, transmitter, receiver, receive interrupt) with the baud-rate register
/// `brr` (`None`: leave it, for QEMU, which ignores it), unmasks its interrupt and returns
/// the link. The caller has enabled the peripheral's clock and pins (real board).
pub fn init(usart: USART1, brr: Option<u16>) -> SerialLink {
    if let Some(brr) = brr {
        usart.brr().write(|w| {
            w.div_mantissa().set(brr >> 4);
            w.div_fraction().set((brr & 0xF) as u8)
        });
    }
    usart.cr2().reset();
    usart.cr3().reset();
    usart.cr1().write(|w| cr1(w, false));
    // The peripheral token goes out of scope here: from now on the interrupt owns the
    // registers.
    // Note(unsafe): unmasking may break a critical section that relies on this interrupt
    // being masked; none does: the interrupt shares only the lock-free queues.
    #[allow(unsafe_code)]
    unsafe {
        cortex_m::peripheral::NVIC::unmask(pac::Interrupt::USART1);
    }
    SerialLink { _private: () }
}

/// Receive errors (hardware or queue overflow) since the last call.
pub fn take_rx_errors() -> u32 {
    LINK.take_rx_errors()
}

/// True when the main loop should read the receive queue: a frame's end is in it, or it is
/// half full ([`crate::serial::SerialQueues::rx_ready`]).
pub fn rx_ready() -> bool {
    LINK.rx_ready()
}

#[interrupt]
fn USART1() {
    LINK.on_interrupt(&mut Usart1Registers(()));
}

impl SerialLink {
    /// Queues `frame` whole for transmission and pends the USART1 interrupt, which sends
    /// it; returns at once. [`QueueFull`] when it does not fit whole: nothing of it is sent.
    pub fn transmit(&mut self, frame: &[u8]) -> Result<(), QueueFull> {
        LINK.enqueue_frame(frame)?;
        cortex_m::peripheral::NVIC::pend(pac::Interrupt::USART1);
        Ok(())
    }
}

impl embedded_io::ErrorType for SerialLink {
    // Receive errors are reported out of band (`take_rx_errors`), so reads never fail.
    type Error = Infallible;
}

impl embedded_io::ReadReady for SerialLink {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(rx_ready())
    }
}

impl embedded_io::Read for SerialLink {
    /// Blocks until at least one byte is queued (embedded-io semantics), then takes as many
    /// as fit. The application reads only after [`embedded_io::ReadReady`] said bytes wait.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        if buf.is_empty() {
            return Ok(0);
        }
        loop {
            let n = LINK.read(buf);
            if n > 0 {
                return Ok(n);
            }
            cortex_m::asm::nop();
        }
    }
}

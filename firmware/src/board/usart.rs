//! The boards' serial ports, one driver for both ports and both boards: an interrupt-fed
//! receive queue and an interrupt-drained transmit queue per port ([`serial_port!`]).
//!
//! Place in the data flow: a port's interrupt runs [`crate::serial::SerialQueues::on_interrupt`]
//! (`crate::serial`: every decision is there, board-independent and host-tested) over its
//! USART's registers; the application reads received bytes through [`embedded_io::Read`]
//! and hands each frame whole to the port's `transmit`, which queues it (or refuses it
//! whole) and pends the interrupt, and returns at once: the control task never waits on the
//! wire. Under QEMU the baud rate is ignored and a write is immediate, so the pended
//! interrupt sends a whole frame in one run; on the MCU each TXE interrupt sends the next
//! byte.
//!
//! The ports ([`super::usart1`]: the peer's link; [`super::usart2`]: the autopilot's
//! MAVLink) differ in their queue sizes and in when the main loop reads (each module's
//! `ReadReady`); the macro writes the rest once, so a fix reaches both.
//!
//! Invariants: after `init` only the port's interrupt touches its USART's registers (the
//! main loop touches the queues and pends the interrupt in the NVIC), so no register access
//! needs a critical section and nothing here can panic (both ports are in the no-panic link
//! check, `src/bin/nopanic.rs`). A received byte is never dropped silently: a hardware error
//! (overrun, noise, framing, parity) or a full queue is counted (`take_rx_errors`); a frame
//! the transmit queue cannot take whole is refused, and the application counts it.

pub(crate) use stm32f4xx_hal::pac;

/// The queues, the register access, `init`, the interrupt and the link type of the port on
/// the USART `$periph` (its receive and transmit queues sized by the invoking module's
/// `RX_QUEUE_LEN` and `TX_QUEUE_LEN`). Every USART of the STM32F405 has USART1's register
/// block.
macro_rules! serial_port {
    ($periph:ident) => {
        // The PAC's `#[interrupt]` names its vector through `interrupt::$periph`.
        use super::usart::pac::interrupt;

        /// The queues the USART interrupt and the main loop share.
        static LINK: $crate::serial::SerialQueues<RX_QUEUE_LEN, TX_QUEUE_LEN> =
            $crate::serial::SerialQueues::new();

        /// The USART registers, as the interrupt uses them.
        pub struct Registers(());

        impl Registers {
            fn regs() -> &'static super::usart::pac::usart1::RegisterBlock {
                // Note(unsafe): a shared reference to the memory-mapped register block, which is
                // always mapped. Only the USART interrupt uses it after `init` (which owned the
                // peripheral and configured it), and the fault path, with interrupts masked.
                #[allow(unsafe_code)]
                unsafe {
                    &*super::usart::pac::$periph::ptr()
                }
            }
        }

        impl $crate::serial::UsartRegisters for Registers {
            fn status(&mut self) -> $crate::serial::UsartStatus {
                let sr = Self::regs().sr().read();
                $crate::serial::UsartStatus {
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
        fn cr1(
            w: &mut super::usart::pac::usart1::cr1::W,
            tx_empty_interrupt: bool,
        ) -> &mut super::usart::pac::usart1::cr1::W {
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

        /// Enables the USART (8N1, transmitter, receiver, receive interrupt) with the baud-rate register
        /// `brr` (`None`: leave it, for QEMU, which ignores it), unmasks its interrupt and returns
        /// the link. The caller has enabled the peripheral's clock and pins (real board).
        pub fn init(usart: super::usart::pac::$periph, brr: Option<u16>) -> SerialLink {
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
                cortex_m::peripheral::NVIC::unmask(super::usart::pac::Interrupt::$periph);
            }
            SerialLink { _private: () }
        }

        /// Receive errors (hardware or queue overflow) since the last call.
        pub fn take_rx_errors() -> u32 {
            LINK.take_rx_errors()
        }

        /// True when a frame's end (a zero, the peer link's COBS framing) is in the receive
        /// queue, or it is half full ([`crate::serial::SerialQueues::rx_ready`]).
        #[allow(dead_code)]
        pub fn rx_frame_ready() -> bool {
            LINK.rx_ready()
        }

        /// True when any byte is in the receive queue ([`crate::serial::SerialQueues::rx_pending`]).
        #[allow(dead_code)]
        pub fn rx_pending() -> bool {
            LINK.rx_pending()
        }

        #[interrupt]
        fn $periph() {
            LINK.on_interrupt(&mut Registers(()));
        }

        impl SerialLink {
            /// Queues `frame` whole for transmission and pends the USART interrupt, which sends
            /// it; returns at once. [`crate::serial::QueueFull`] when it does not fit whole: nothing of it is sent.
            pub fn transmit(&mut self, frame: &[u8]) -> Result<(), $crate::serial::QueueFull> {
                LINK.enqueue_frame(frame)?;
                cortex_m::peripheral::NVIC::pend(super::usart::pac::Interrupt::$periph);
                Ok(())
            }
        }

        impl embedded_io::ErrorType for SerialLink {
            // Receive errors are reported out of band (`take_rx_errors`), so reads never fail.
            type Error = core::convert::Infallible;
        }

        impl embedded_io::Read for SerialLink {
            /// Blocks until at least one byte is queued (embedded-io semantics), then takes as many
            /// as fit. The application reads only after [`embedded_io::ReadReady`] said bytes wait.
            fn read(&mut self, buf: &mut [u8]) -> Result<usize, core::convert::Infallible> {
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
    };
}

pub(crate) use serial_port;

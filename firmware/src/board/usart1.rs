//! USART1, the serial link to the peer, shared by both boards: interrupt-fed receive queue,
//! polled transmit, behind the embedded-io traits ([`SerialLink`]).
//!
//! Place in the data flow: the USART1 interrupt moves each received byte into [`RX_QUEUE_LEN`]
//! bytes of queue; the application drains it through [`embedded_io::Read`] and writes command
//! frames through [`embedded_io::Write`] (blocking on TXE, one byte at a time: at 921,600 baud
//! the largest command frame (317 bytes) takes 3.4 ms of the 20 ms period; DMA would free the CPU for that
//! time). Under QEMU the baud rate is ignored and a write is immediate.
//!
//! Invariants: a received byte is never dropped silently: a hardware error (overrun, noise,
//! framing, parity) or a full queue is counted ([`take_rx_errors`]); the register block is
//! only touched inside critical sections (the interrupt and the main loop share it).

use core::cell::RefCell;
use core::convert::Infallible;
use core::sync::atomic::{AtomicU32, Ordering};

use critical_section::Mutex;
use heapless::Deque;
use stm32f4xx_hal::pac::{self, USART1, interrupt};

/// Receive queue capacity, bytes: two largest frames, i.e. 40 ms of back-to-back frames at
/// 115,200 baud or 5 ms at 921,600 (the main loop drains it every period).
pub const RX_QUEUE_LEN: usize = 512;

static USART: Mutex<RefCell<Option<USART1>>> = Mutex::new(RefCell::new(None));
static RXQ: Mutex<RefCell<Deque<u8, RX_QUEUE_LEN>>> = Mutex::new(RefCell::new(Deque::new()));
static RX_ERRORS: AtomicU32 = AtomicU32::new(0);

/// The link: reads drain the receive queue, writes go to the transmit register.
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
    usart.cr1().write(|w| {
        w.ue().set_bit();
        w.te().set_bit();
        w.re().set_bit();
        w.rxneie().set_bit()
    });
    critical_section::with(|cs| USART.borrow_ref_mut(cs).replace(usart));
    // Note(unsafe): unmasking may break a critical section that relies on this interrupt
    // being masked; none does: the interrupt's shared state is all behind `critical_section`.
    #[allow(unsafe_code)]
    unsafe {
        cortex_m::peripheral::NVIC::unmask(pac::Interrupt::USART1);
    }
    SerialLink { _private: () }
}

/// Receive errors (hardware or queue overflow) since the last call.
pub fn take_rx_errors() -> u32 {
    RX_ERRORS.swap(0, Ordering::Relaxed)
}

/// True when received bytes wait in the queue.
pub fn rx_pending() -> bool {
    critical_section::with(|cs| !RXQ.borrow_ref(cs).is_empty())
}

#[interrupt]
fn USART1() {
    critical_section::with(|cs| {
        let usart = USART.borrow_ref(cs);
        let Some(u) = usart.as_ref() else {
            return;
        };
        let sr = u.sr().read();
        let error = sr.ore().bit_is_set()
            || sr.nf().bit_is_set()
            || sr.fe().bit_is_set()
            || sr.pe().bit_is_set();
        if error {
            RX_ERRORS.fetch_add(1, Ordering::Relaxed);
        }
        if sr.rxne().bit_is_set() || error {
            // Reading DR after SR clears RXNE and the error flags.
            let byte = u.dr().read().dr().bits() as u8;
            if sr.rxne().bit_is_set() && RXQ.borrow_ref_mut(cs).push_back(byte).is_err() {
                RX_ERRORS.fetch_add(1, Ordering::Relaxed);
            }
        }
    });
}

impl embedded_io::ErrorType for SerialLink {
    // Receive errors are reported out of band (`take_rx_errors`), so reads never fail.
    type Error = Infallible;
}

impl embedded_io::ReadReady for SerialLink {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(rx_pending())
    }
}

impl embedded_io::Read for SerialLink {
    /// Blocks until at least one byte is queued (embedded-io semantics), then takes as many
    /// as fit.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        if buf.is_empty() {
            return Ok(0);
        }
        loop {
            let n = critical_section::with(|cs| {
                let mut q = RXQ.borrow_ref_mut(cs);
                let mut n = 0;
                for slot in buf.iter_mut() {
                    match q.pop_front() {
                        Some(b) => {
                            *slot = b;
                            n += 1;
                        }
                        None => break,
                    }
                }
                n
            });
            if n > 0 {
                return Ok(n);
            }
            cortex_m::asm::nop();
        }
    }
}

fn with_usart<R>(f: impl FnOnce(&USART1) -> R) -> Option<R> {
    critical_section::with(|cs| USART.borrow_ref(cs).as_ref().map(f))
}

impl embedded_io::Write for SerialLink {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        for &b in buf {
            // Wait for the transmit register outside the critical section, so the receive
            // interrupt is not held off for a byte time.
            while with_usart(|u| u.sr().read().txe().bit_is_clear()).unwrap_or(false) {}
            with_usart(|u| u.dr().write(|w| w.dr().set(u16::from(b))));
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        while with_usart(|u| u.sr().read().tc().bit_is_clear()).unwrap_or(false) {}
        Ok(())
    }
}

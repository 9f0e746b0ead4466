//! The serial link's byte queues and the USART interrupt's logic, board-independent.
//!
//! Place in the data flow: between the USART and the application. Receive: the USART
//! interrupt moves each received byte into the receive queue ([`SerialQueues::on_interrupt`]),
//! the main loop drains it ([`SerialQueues::read`]). Transmit: the main loop hands a whole
//! frame to the transmit queue ([`SerialQueues::enqueue_frame`]) and pends the interrupt; the
//! interrupt writes bytes into the data register while it is empty (TXE) and enables the
//! TXE interrupt only while bytes remain. The interrupt takes the transmit queue's bytes in
//! one [`Reader`] run: one acquire of the tail when it starts and one release of the head
//! when it ends, however many bytes it takes (its run is in the control task's cycle bound,
//! `target-bench`); the main loop pops the receive queue a byte at a time (less code in the
//! loop, which no bound covers). The board (`crate::board::usart1`) supplies the registers
//! ([`UsartRegisters`]) and the interrupt vector; everything that decides is here,
//! unit-tested on the host and covered by the no-panic link check (`src/bin/nopanic.rs`).
//!
//! Why interrupt-driven rather than DMA (DMA2 stream 7 channel 4 is USART1_TX on the
//! STM32F405): the same code runs on both boards and is tested in QEMU, whose
//! netduinoplus2 models no DMA controller; a byte interrupt costs on the order of a hundred
//! cycles every 10.8 us (1,814 cycles) at 921,600 baud while a frame is on the wire, about
//! 1 % of the CPU over a 20 ms period with one 354-byte frame (an estimate, not measured on
//! a board); and the queue needs no contiguous buffer, so a frame that wraps around the
//! ring needs no second transfer.
//!
//! Invariants:
//! - Lock-free single producer, single consumer: each queue has exactly one context that
//!   pushes and one that pops (receive: the interrupt pushes, the main loop pops; transmit:
//!   the reverse). The producer alone writes the tail index, the consumer alone the head; a
//!   slot is written before the tail that publishes it (release/acquire), and read before
//!   the head that frees it. No critical section, no `RefCell`, nothing that can panic.
//! - A frame is queued whole or not at all ([`ByteQueue::push_all`]): a frame that does not
//!   fit is refused (the application counts it, `LinkCounters::tx_dropped`), never sent in
//!   part. A received byte that does not fit, and every receive error the USART flags, is
//!   counted ([`SerialQueues::take_rx_errors`]).
//! - The interrupt writes at most the bytes queued when its run began (at most the queue's
//!   capacity) and returns; with TXE's interrupt enabled only while bytes remain, an idle
//!   link raises no interrupt. Bytes queued after its run began are the next run's: the
//!   producer pends the interrupt after queuing them.
//! - [`SerialQueues::rx_ready`] is true only while the receive queue holds a byte, so the
//!   main loop's read after it never waits; and it is true whenever a frame's end (a zero)
//!   is queued, so no frame waits for the next byte. Frame ends are counted, not flagged:
//!   the interrupt counts the zeros it queues, the main loop the zeros it takes, each side
//!   writing only its own count, and their difference is the zeros queued now, whatever the
//!   point of a read the interrupt lands at (tested at every point of
//!   [`ByteQueue::pop_into`] and [`SerialQueues::read`]). A flag that `read` cleared before
//!   it popped could be set by a zero the same read then took, leaving it over an empty queue:
//!   the loop saw data, and the blocking read waited for the next byte.

use core::sync::atomic::{AtomicU8, AtomicU32, Ordering};

/// A point of the consumer's code between two accesses to shared state, where the producer's
/// interrupt may run. Nothing on the boards; in the tests, the hook that runs the interrupt
/// there (`tests::preemption`), so that every interleaving of a push with a read is tried.
#[inline(always)]
fn interrupt_may_run_here() {
    #[cfg(test)]
    tests::preemption::point();
}

/// A queue refused bytes: they did not fit (nothing was queued).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct QueueFull;

/// A fixed ring of `N` bytes (`N` a power of two) between one producer and one consumer
/// context (see the module doc).
pub struct ByteQueue<const N: usize> {
    slots: [AtomicU8; N],
    /// Bytes ever pushed, wrapping; written by the producer only.
    tail: AtomicU32,
    /// Bytes ever popped, wrapping; written by the consumer only.
    head: AtomicU32,
}

impl<const N: usize> ByteQueue<N> {
    /// `N` must be a power of two (the index is masked) and well inside the 32-bit indices.
    const SIZE_OK: () = assert!(N.is_power_of_two() && N <= 1 << 16);

    /// An empty queue.
    pub const fn new() -> Self {
        let () = Self::SIZE_OK;
        Self {
            slots: [const { AtomicU8::new(0) }; N],
            tail: AtomicU32::new(0),
            head: AtomicU32::new(0),
        }
    }

    /// Capacity, bytes.
    pub const fn capacity(&self) -> usize {
        N
    }

    fn slot(&self, index: u32) -> Option<&AtomicU8> {
        self.slots.get(index as usize & (N - 1))
    }

    /// Bytes queued now (either side may call it; the other side can only change it
    /// toward what it does: the producer adds, the consumer removes).
    pub fn len(&self) -> usize {
        let tail = self.tail.load(Ordering::Acquire);
        let head = self.head.load(Ordering::Acquire);
        tail.wrapping_sub(head) as usize
    }

    /// True when nothing is queued.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Producer: queues `bytes` whole, or nothing ([`QueueFull`]) when they do not fit.
    pub fn push_all(&self, bytes: &[u8]) -> Result<(), QueueFull> {
        let tail = self.tail.load(Ordering::Relaxed);
        let head = self.head.load(Ordering::Acquire);
        let free = N.saturating_sub(tail.wrapping_sub(head) as usize);
        if bytes.len() > free {
            return Err(QueueFull);
        }
        let mut at = tail;
        for &b in bytes {
            if let Some(slot) = self.slot(at) {
                slot.store(b, Ordering::Relaxed);
            }
            at = at.wrapping_add(1);
        }
        self.tail.store(at, Ordering::Release);
        Ok(())
    }

    /// Producer: queues one byte, or refuses it when the queue is full.
    pub fn push(&self, byte: u8) -> Result<(), QueueFull> {
        self.push_all(&[byte])
    }

    /// Consumer: a run over the bytes queued now ([`Reader`]), oldest first.
    pub fn reader(&self) -> Reader<'_, N> {
        // The head is the consumer's own: no ordering needed to read it back.
        let head = self.head.load(Ordering::Relaxed);
        let tail = self.tail.load(Ordering::Acquire);
        // At most N (the producer never queues more): the run stays bounded whatever the
        // indices hold.
        let queued = tail.wrapping_sub(head).min(N as u32);
        Reader {
            queue: self,
            head,
            at: head,
            end: head.wrapping_add(queued),
        }
    }

    /// Consumer: the oldest byte, if any.
    pub fn pop(&self) -> Option<u8> {
        let head = self.head.load(Ordering::Relaxed);
        interrupt_may_run_here();
        let tail = self.tail.load(Ordering::Acquire);
        interrupt_may_run_here();
        if head == tail {
            return None;
        }
        let b = self.slot(head)?.load(Ordering::Relaxed);
        interrupt_may_run_here();
        self.head.store(head.wrapping_add(1), Ordering::Release);
        interrupt_may_run_here();
        Some(b)
    }

    /// Consumer: moves as many of the oldest bytes as fit into `buf`; how many, and how many
    /// of them are zeros (frame ends).
    pub fn pop_into(&self, buf: &mut [u8]) -> (usize, u32) {
        let (mut n, mut zeros) = (0, 0u32);
        for slot in buf.iter_mut() {
            match self.pop() {
                Some(b) => {
                    *slot = b;
                    n += 1;
                    zeros += u32::from(b == 0);
                }
                None => break,
            }
        }
        (n, zeros)
    }
}

/// A consumer's run over a [`ByteQueue`]: the bytes queued when it began (one acquire of the
/// tail), taken one by one without touching the shared head, which [`Reader::finish`]
/// publishes once (one release) and so frees their slots to the producer. The queue's one
/// consumer has at most one run at a time.
pub struct Reader<'a, const N: usize> {
    queue: &'a ByteQueue<N>,
    /// The head when the run began.
    head: u32,
    /// The next byte to take.
    at: u32,
    /// The tail when the run began.
    end: u32,
}

impl<const N: usize> Reader<'_, N> {
    /// True when the run has taken every byte it saw queued.
    pub fn is_empty(&self) -> bool {
        self.at == self.end
    }

    /// The next byte, if the run has one left.
    pub fn pop(&mut self) -> Option<u8> {
        if self.at == self.end {
            return None;
        }
        let b = self.queue.slot(self.at)?.load(Ordering::Relaxed);
        self.at = self.at.wrapping_add(1);
        Some(b)
    }

    /// Ends the run: frees the bytes taken (the slots were read before the head that frees
    /// them is published); true when bytes it saw queued remain.
    pub fn finish(self) -> bool {
        if self.at != self.head {
            self.queue.head.store(self.at, Ordering::Release);
        }
        self.at != self.end
    }
}

impl<const N: usize> Default for ByteQueue<N> {
    fn default() -> Self {
        Self::new()
    }
}

/// One reading of the USART's status register: the bits the interrupt acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct UsartStatus {
    /// A received byte waits in the data register (RXNE).
    pub rx_ready: bool,
    /// The transmit data register is empty (TXE): a byte may be written.
    pub tx_empty: bool,
    /// A receive error: overrun, noise, framing or parity (ORE, NF, FE, PE).
    pub rx_error: bool,
}

/// The USART's registers as the interrupt uses them (the board implements it over the
/// peripheral; the tests over a model).
pub trait UsartRegisters {
    /// Reads the status register.
    fn status(&mut self) -> UsartStatus;
    /// Reads the data register: the received byte; after [`UsartRegisters::status`] this
    /// clears RXNE and the error flags.
    fn read_data(&mut self) -> u8;
    /// Writes a byte to transmit into the data register.
    fn write_data(&mut self, byte: u8);
    /// Enables or disables the interrupt on TXE (TXEIE).
    fn set_tx_empty_interrupt(&mut self, enabled: bool);
}

/// Both queues of one USART and its receive-error count: the state its interrupt and the
/// main loop share (a `static` on the board).
pub struct SerialQueues<const RX: usize, const TX: usize> {
    rx: ByteQueue<RX>,
    tx: ByteQueue<TX>,
    rx_errors: AtomicU32,
    /// Zeros (frame ends) the interrupt has queued, ever, wrapping: the interrupt alone
    /// writes it, after the push that queued the zero is published.
    rx_ends_queued: AtomicU32,
    /// Zeros the main loop has taken out of the receive queue, ever, wrapping: the main loop
    /// alone writes it. `rx_ends_queued - rx_ends_taken` zeros are queued now.
    rx_ends_taken: AtomicU32,
}

impl<const RX: usize, const TX: usize> SerialQueues<RX, TX> {
    /// Empty queues, no error.
    pub const fn new() -> Self {
        Self {
            rx: ByteQueue::new(),
            tx: ByteQueue::new(),
            rx_errors: AtomicU32::new(0),
            rx_ends_queued: AtomicU32::new(0),
            rx_ends_taken: AtomicU32::new(0),
        }
    }

    /// The USART interrupt (receive and transmit): takes a received byte into the receive
    /// queue (a full queue or a flagged error counted), then writes queued bytes while the
    /// data register is empty, and leaves TXE's interrupt enabled only while bytes remain.
    /// On QEMU a write is immediate (TXE never clears), so one run empties the queue; on the
    /// MCU the register takes one byte while the shift register sends the previous one, so a
    /// run writes one or two bytes and the TXE interrupt brings the next run a byte time
    /// later.
    ///
    /// Its cost is in the control task's cycle bound (it runs up to twice a byte time), so
    /// it is lean: one status read serves the receive side and the first transmit test (TXE
    /// only ever sets between the two: only a write here clears it), the transmit queue is
    /// read in one [`Reader`] run (one acquire and one release, not two of each per byte),
    /// and the error counter is updated once a run.
    pub fn on_interrupt<R: UsartRegisters>(&self, regs: &mut R) {
        let sr = regs.status();
        let mut errors = u32::from(sr.rx_error);
        if sr.rx_ready || sr.rx_error {
            // Reading the data register after the status clears RXNE and the error flags.
            let byte = regs.read_data();
            if sr.rx_ready {
                match self.rx.push(byte) {
                    // The interrupt is the count's only writer: a load and a store, no
                    // read-modify-write loop; published after the zero it counts.
                    Ok(()) if byte == 0 => self.rx_ends_queued.store(
                        self.rx_ends_queued.load(Ordering::Relaxed).wrapping_add(1),
                        Ordering::Release,
                    ),
                    Ok(()) => {}
                    Err(QueueFull) => errors += 1,
                }
            }
        }
        if errors > 0 {
            self.rx_errors.fetch_add(errors, Ordering::Relaxed);
        }
        let mut run = self.tx.reader();
        let mut tx_empty = sr.tx_empty;
        while tx_empty {
            let Some(b) = run.pop() else { break };
            regs.write_data(b);
            tx_empty = regs.status().tx_empty;
            // The index made opaque to the optimiser, so that it keeps one byte a pass
            // instead of unrolling the loop four times: the cycle bound charges the loop per
            // pass, at most two passes a run on the MCU (a change of its shape fails the
            // bound's loop table, `target-bench`).
            run.at = core::hint::black_box(run.at);
        }
        regs.set_tx_empty_interrupt(run.finish());
    }

    /// Main loop: moves received bytes into `buf`; how many (0 when none wait). The zeros
    /// taken are counted off the frame ends queued, so a zero the interrupt queues during
    /// the read is either taken by it (and counted) or left queued (and still counted as
    /// queued): never a frame end reported over an empty queue, never one missed.
    pub fn read(&self, buf: &mut [u8]) -> usize {
        let (n, zeros) = self.rx.pop_into(buf);
        if zeros > 0 {
            let taken = self.rx_ends_taken.load(Ordering::Relaxed);
            interrupt_may_run_here();
            self.rx_ends_taken
                .store(taken.wrapping_add(zeros), Ordering::Relaxed);
        }
        n
    }

    /// True when the main loop should read: a frame's end (a zero) is queued, or the queue
    /// is half full (bytes that end no frame are read before they could overflow it). True
    /// only while a byte is queued, so the read after it returns at once. The application
    /// decodes a frame once it is whole, in one pass over the queued bytes: the work after a
    /// frame's last byte is the same however its bytes arrived, and a frame costs one decode
    /// call, not one a byte.
    pub fn rx_ready(&self) -> bool {
        // Acquire: a count seen includes the push of the zero it counts.
        self.rx_ends_queued.load(Ordering::Acquire) != self.rx_ends_taken.load(Ordering::Relaxed)
            || self.rx.len() >= RX / 2
    }

    /// Main loop: whether any byte is in the receive queue (a link without frame ends to wait
    /// for: MAVLink's frames are delimited by their length, not by a zero).
    pub fn rx_pending(&self) -> bool {
        !self.rx.is_empty()
    }

    /// Receive errors (flagged by the USART, or a byte the full queue could not take) since
    /// the last call.
    pub fn take_rx_errors(&self) -> u32 {
        self.rx_errors.swap(0, Ordering::Relaxed)
    }

    /// Main loop: queues a whole frame for transmission, or refuses it ([`QueueFull`])
    /// without queuing any of it. The caller then pends the USART interrupt, which starts
    /// sending.
    pub fn enqueue_frame(&self, frame: &[u8]) -> Result<(), QueueFull> {
        self.tx.push_all(frame)
    }

    /// Bytes waiting to be sent.
    pub fn tx_queued(&self) -> usize {
        self.tx.len()
    }
}

impl<const RX: usize, const TX: usize> Default for SerialQueues<RX, TX> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use std::vec::Vec;

    use super::*;

    /// The tests' preemption points ([`super::interrupt_may_run_here`]): each call is one
    /// point of the consumer's code, counted per thread; the interrupt armed by [`run`]
    /// runs, once, at the point it was armed for.
    pub(super) mod preemption {
        use std::boxed::Box;
        use std::cell::{Cell, RefCell};

        type Interrupt = Box<dyn FnOnce()>;

        std::thread_local! {
            static PASSED: Cell<u32> = const { Cell::new(0) };
            static ARMED: RefCell<Option<(u32, Interrupt)>> = const { RefCell::new(None) };
        }

        /// One point: runs the armed interrupt if this is its point.
        pub fn point() {
            let n = PASSED.with(|p| p.replace(p.get() + 1));
            let due = ARMED.with(|a| {
                let mut a = a.borrow_mut();
                match a.as_ref() {
                    Some((at, _)) if *at == n => a.take().map(|(_, f)| f),
                    _ => None,
                }
            });
            if let Some(interrupt) = due {
                interrupt();
            }
        }

        /// Runs `f` with `interrupt` armed at its `at`-th point (from 0; `None`: never);
        /// returns `f`'s result, the points `f` passed and whether the interrupt ran.
        pub fn run<R>(
            at: Option<u32>,
            interrupt: Interrupt,
            f: impl FnOnce() -> R,
        ) -> (R, u32, bool) {
            PASSED.with(|p| p.set(0));
            ARMED.with(|a| *a.borrow_mut() = at.map(|at| (at, interrupt)));
            let r = f();
            let fired = ARMED.with(|a| a.borrow_mut().take().is_none()) && at.is_some();
            (r, PASSED.with(Cell::get), fired)
        }
    }

    /// The receive race: the interrupt queues a byte (a frame's end or not) at every point
    /// of the main loop's read (each access `pop_into` and `read` make to shared state), over
    /// queues holding nothing, part of a frame, a whole frame, or close to half full, read
    /// into buffers smaller and larger than what is queued. After the read, the queue
    /// reports ready exactly when a zero is queued or it is half full (so a read after it
    /// never waits, and no frame's end waits for another byte), and every byte comes out
    /// once, in order.
    #[test]
    fn a_byte_received_at_any_point_of_a_read_leaves_readiness_exact() {
        use std::cell::RefCell;
        use std::rc::Rc;

        const RX: usize = 16;
        let queued: [&[u8]; 6] = [
            &[],
            &[5, 6],
            &[5, 0],
            &[5, 0, 7],
            &[0, 0],
            &[1, 2, 3, 4, 5, 6, 7],
        ];
        let mut interleavings = 0;
        for before in queued {
            for buf_len in [1, 2, 3, 8] {
                for arrives in [0u8, 9] {
                    // The read's points without an interrupt, then the interrupt at each.
                    let points = {
                        let link = SerialQueues::<RX, 16>::new();
                        for &b in before {
                            let mut usart = Usart {
                                rx: Some(b),
                                ..Usart::default()
                            };
                            link.on_interrupt(&mut usart);
                        }
                        let mut buf = [0u8; 8];
                        let (_, points, _) = preemption::run(None, Box::new(|| {}), || {
                            link.read(&mut buf[..buf_len])
                        });
                        points
                    };
                    for at in 0..points {
                        let link = Rc::new(SerialQueues::<RX, 16>::new());
                        let usart = Rc::new(RefCell::new(Usart::default()));
                        for &b in before {
                            usart.borrow_mut().rx = Some(b);
                            link.on_interrupt(&mut *usart.borrow_mut());
                        }
                        let interrupt = {
                            let (link, usart) = (Rc::clone(&link), Rc::clone(&usart));
                            Box::new(move || {
                                usart.borrow_mut().rx = Some(arrives);
                                link.on_interrupt(&mut *usart.borrow_mut());
                            })
                        };
                        let mut buf = [0u8; 8];
                        let (n, _, fired) =
                            preemption::run(Some(at), interrupt, || link.read(&mut buf[..buf_len]));
                        assert!(fired, "point {at} of {points}");
                        let case = format!(
                            "{before:?} read into {buf_len}, {arrives} at point {at} of {points}"
                        );
                        // What is queued now, without taking it.
                        let mut run = link.rx.reader();
                        let mut left = Vec::new();
                        while let Some(b) = run.pop() {
                            left.push(b);
                        }
                        let want_ready = left.contains(&0) || left.len() >= RX / 2;
                        assert_eq!(link.rx_ready(), want_ready, "{case}: left {left:?}");
                        let mut all = buf[..n].to_vec();
                        all.extend_from_slice(&left);
                        let mut sent = before.to_vec();
                        sent.push(arrives);
                        assert_eq!(all, sent, "{case}");
                        assert_eq!(link.take_rx_errors(), 0, "{case}");
                        interleavings += 1;
                    }
                }
            }
        }
        assert!(interleavings > 300, "{interleavings}");
    }

    #[test]
    fn a_queue_keeps_order_across_many_wraps() {
        let q = ByteQueue::<16>::new();
        let mut next_in = 0u8;
        let mut next_out = 0u8;
        // Pushes of 1..=7 bytes and pops of 1..=5, so the indices wrap many times at every
        // phase of the ring.
        for round in 0..500u32 {
            let push = (round % 7 + 1) as usize;
            let chunk: Vec<u8> = (0..push).map(|i| next_in.wrapping_add(i as u8)).collect();
            if q.push_all(&chunk).is_ok() {
                next_in = next_in.wrapping_add(push as u8);
            }
            for _ in 0..(round % 5 + 1) {
                if let Some(b) = q.pop() {
                    assert_eq!(b, next_out);
                    next_out = next_out.wrapping_add(1);
                }
            }
            assert!(q.len() <= q.capacity());
        }
        while let Some(b) = q.pop() {
            assert_eq!(b, next_out);
            next_out = next_out.wrapping_add(1);
        }
        assert_eq!(next_in, next_out);
    }

    #[test]
    fn a_frame_that_does_not_fit_is_refused_whole() {
        let q = ByteQueue::<8>::new();
        assert_eq!(q.push_all(&[1, 2, 3, 4, 5]), Ok(()));
        assert_eq!(q.push_all(&[6, 7, 8, 9]), Err(QueueFull), "4 into 3 free");
        assert_eq!(q.len(), 5, "nothing of the refused frame queued");
        assert_eq!(q.push_all(&[6, 7, 8]), Ok(()), "exactly full");
        assert_eq!(q.push(9), Err(QueueFull));
        let mut out = [0u8; 16];
        assert_eq!(q.pop_into(&mut out), (8, 0));
        assert_eq!(&out[..8], &[1, 2, 3, 4, 5, 6, 7, 8]);
        assert!(q.is_empty() && q.pop().is_none());
        assert_eq!(q.push_all(&[]), Ok(()), "an empty frame fits");
        assert_eq!(q.push_all(&[0; 9]), Err(QueueFull), "larger than the queue");
    }

    /// A USART model: TXE clears on a write and comes back when the test shifts the byte
    /// out (the MCU), or never clears (QEMU's model, whose writes are immediate).
    #[derive(Default)]
    struct Usart {
        immediate: bool,
        holding: Option<u8>,
        sent: Vec<u8>,
        rx: Option<u8>,
        error: bool,
        txeie: bool,
        txeie_set: u32,
    }

    impl Usart {
        /// The shift register takes the held byte (one byte time later on the MCU).
        fn shift(&mut self) {
            if let Some(b) = self.holding.take() {
                self.sent.push(b);
            }
        }
        /// True when the USART's interrupt line is raised (TXE with TXEIE).
        fn tx_interrupt(&self) -> bool {
            self.txeie && self.holding.is_none()
        }
    }

    impl UsartRegisters for Usart {
        fn status(&mut self) -> UsartStatus {
            UsartStatus {
                rx_ready: self.rx.is_some(),
                tx_empty: self.holding.is_none(),
                rx_error: self.error,
            }
        }
        fn read_data(&mut self) -> u8 {
            self.error = false;
            self.rx.take().unwrap_or(0xEE)
        }
        fn write_data(&mut self, byte: u8) {
            assert!(self.holding.is_none(), "written while TXE was clear");
            if self.immediate {
                self.sent.push(byte);
            } else {
                self.holding = Some(byte);
            }
        }
        fn set_tx_empty_interrupt(&mut self, enabled: bool) {
            if enabled && !self.txeie {
                self.txeie_set += 1;
            }
            self.txeie = enabled;
        }
    }

    #[test]
    fn the_interrupt_sends_a_frame_a_byte_per_txe_on_the_mcu_and_then_goes_quiet() {
        let link = SerialQueues::<16, 64>::new();
        let mut usart = Usart::default();
        let frame: Vec<u8> = (1..=40).collect();
        assert_eq!(link.enqueue_frame(&frame), Ok(()));
        // The pended run writes the first byte and enables TXE's interrupt.
        link.on_interrupt(&mut usart);
        assert!(usart.txeie && usart.holding == Some(1));
        let mut runs = 1;
        while usart.holding.is_some() {
            usart.shift();
            if usart.tx_interrupt() {
                link.on_interrupt(&mut usart);
                runs += 1;
            }
        }
        assert_eq!(usart.sent, frame);
        assert_eq!(runs, 40, "one run per byte");
        assert!(!usart.txeie, "no interrupt once the queue is empty");
        assert_eq!(link.tx_queued(), 0);
    }

    /// The MCU's transmitter as two stages: the data register and the shift register. A
    /// write to an empty data register with the shifter idle passes straight on (TXE sets
    /// again at once); the shifter sends one byte per byte time.
    #[derive(Default)]
    struct TwoStage {
        data: Option<u8>,
        shifter: Option<u8>,
        sent: Vec<u8>,
        txeie: bool,
        writes_this_run: u32,
    }

    impl TwoStage {
        fn settle(&mut self) {
            if self.shifter.is_none() {
                self.shifter = self.data.take();
            }
        }
        /// One byte time: the shifter's byte is on the wire, the data register moves on.
        fn byte_time(&mut self) {
            if let Some(b) = self.shifter.take() {
                self.sent.push(b);
            }
            self.settle();
        }
    }

    impl UsartRegisters for TwoStage {
        fn status(&mut self) -> UsartStatus {
            UsartStatus {
                tx_empty: self.data.is_none(),
                ..UsartStatus::default()
            }
        }
        fn read_data(&mut self) -> u8 {
            0
        }
        fn write_data(&mut self, byte: u8) {
            assert!(self.data.is_none(), "written while TXE was clear");
            self.data = Some(byte);
            self.writes_this_run += 1;
            self.settle();
        }
        fn set_tx_empty_interrupt(&mut self, enabled: bool) {
            self.txeie = enabled;
        }
    }

    /// The control task's cycle bound charges the interrupt's transmit loop at most two
    /// bytes a run: the first passes to the idle shifter, the second fills the data
    /// register, which then stays full for a byte time (longer than a run).
    #[test]
    fn a_run_writes_at_most_two_bytes_on_the_mcu() {
        let link = SerialQueues::<16, 64>::new();
        let mut usart = TwoStage::default();
        let frame: Vec<u8> = (1..=30).collect();
        assert_eq!(link.enqueue_frame(&frame), Ok(()));
        let mut runs = 0;
        let mut most = 0;
        loop {
            usart.writes_this_run = 0;
            link.on_interrupt(&mut usart);
            runs += 1;
            most = most.max(usart.writes_this_run);
            usart.byte_time();
            if !(usart.txeie && usart.data.is_none()) {
                break;
            }
        }
        while usart.shifter.is_some() {
            usart.byte_time();
        }
        assert_eq!(usart.sent, frame);
        assert_eq!(most, 2, "two bytes in the first run, never more");
        assert_eq!(runs, 29, "the first run two bytes, then one a byte time");
    }

    #[test]
    fn a_reader_frees_its_bytes_only_when_it_finishes() {
        let q = ByteQueue::<4>::new();
        assert_eq!(q.push_all(&[1, 2, 3, 4]), Ok(()));
        let mut run = q.reader();
        assert_eq!((run.pop(), run.pop()), (Some(1), Some(2)));
        // Not freed yet: the producer still sees a full queue.
        assert_eq!(q.push(5), Err(QueueFull));
        assert!(run.finish(), "two bytes remain");
        assert_eq!(q.push_all(&[5, 6]), Ok(()));
        // A run sees what was queued when it began, nothing queued after.
        let mut run = q.reader();
        assert_eq!(run.pop(), Some(3));
        let mut rest = Vec::new();
        while let Some(b) = run.pop() {
            rest.push(b);
        }
        assert_eq!(rest, [4, 5, 6]);
        assert!(run.is_empty() && !run.finish());
        assert!(q.is_empty());
    }

    #[test]
    fn on_qemu_one_run_empties_the_queue_without_the_txe_interrupt() {
        let link = SerialQueues::<16, 1024>::new();
        let mut usart = Usart {
            immediate: true,
            ..Usart::default()
        };
        let a: Vec<u8> = (0..600).map(|i| (i % 251) as u8 + 1).collect();
        let b: Vec<u8> = (0..300).map(|i| (i % 13) as u8).collect();
        assert_eq!(link.enqueue_frame(&a), Ok(()));
        assert_eq!(link.enqueue_frame(&b), Ok(()), "both fit in 1024");
        assert_eq!(link.enqueue_frame(&[7; 200]), Err(QueueFull));
        link.on_interrupt(&mut usart);
        let mut want = a.clone();
        want.extend_from_slice(&b);
        assert_eq!(usart.sent, want);
        assert_eq!(usart.txeie_set, 0);
        assert!(!usart.txeie);
    }

    #[test]
    fn received_bytes_are_queued_and_every_error_or_overflow_counted() {
        let link = SerialQueues::<4, 16>::new();
        let mut usart = Usart::default();
        for b in 1..=6u8 {
            usart.rx = Some(b);
            link.on_interrupt(&mut usart);
        }
        // Four fit, two overflowed.
        let mut out = [0u8; 8];
        assert_eq!(link.read(&mut out), 4);
        assert_eq!(&out[..4], &[1, 2, 3, 4]);
        assert_eq!(link.take_rx_errors(), 2);
        // A flagged error: counted once, and its byte kept (it arrived, with a flag).
        usart.rx = Some(9);
        usart.error = true;
        link.on_interrupt(&mut usart);
        // An error without a byte (an overrun seen after the data was read): counted, the
        // flag cleared by reading the data register, nothing queued.
        usart.error = true;
        link.on_interrupt(&mut usart);
        assert!(!usart.error);
        assert_eq!(link.take_rx_errors(), 2);
        assert_eq!(link.take_rx_errors(), 0, "taken");
        assert_eq!(link.read(&mut out), 1);
        assert_eq!(out[0], 9);
        assert!(!link.rx_ready());
        // Receiving touches the transmit side only to keep its interrupt off.
        assert!(usart.sent.is_empty() && !usart.txeie);
    }

    #[test]
    fn the_main_loop_reads_at_a_frames_end_or_a_half_full_queue() {
        let link = SerialQueues::<8, 16>::new();
        let mut usart = Usart::default();
        let mut receive = |b: u8| {
            usart.rx = Some(b);
            link.on_interrupt(&mut usart);
        };
        for b in [5, 6, 7] {
            receive(b);
        }
        assert!(!link.rx_ready(), "three bytes of a frame: not yet");
        receive(0);
        assert!(link.rx_ready(), "its end");
        let mut out = [0u8; 8];
        assert_eq!(link.read(&mut out), 4);
        assert!(!link.rx_ready(), "read");
        // A frame end queued while the loop reads is seen on its next pass.
        receive(1);
        assert!(!link.rx_ready());
        receive(0);
        assert!(link.rx_ready());
        assert_eq!(link.read(&mut out[..1]), 1, "part of it taken");
        assert!(link.rx_ready(), "the rest, its end among it, is read next");
        assert_eq!(link.read(&mut out), 1);
        assert!(!link.rx_ready());
        // Bytes that end no frame: read once they half fill the queue.
        for b in [1, 2, 3] {
            receive(b);
        }
        assert!(!link.rx_ready());
        receive(4);
        assert!(link.rx_ready(), "half of 8");
    }
}

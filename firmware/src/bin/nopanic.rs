//! # nopanic: a link-time proof that the flight code cannot panic
//!
//! This binary calls [`Controller::new`](ibvs_core::Controller::new) on an arbitrary configuration and
//! [`Controller::step`](ibvs_core::Controller::step) on arbitrary inputs, each followed by
//! [`Controller::follow_schedule`](ibvs_core::Controller::follow_schedule) (all through `black_box`, so the optimiser must
//! keep every path), then the link code on arbitrary bytes: [`FrameDecoder::feed`](ibvs_core::wire::FrameDecoder::feed), the
//! measurement frame's deserialisation and [`encode_downlink`](ibvs_core::wire::encode_downlink). Its panic handler calls a
//! function that does not exist. It also runs the configuration path: a configuration frame's
//! deserialisation, [`Controller::reconfigure`](ibvs_core::Controller::reconfigure), the
//! configuration's id and the report's encoding; and the flight application's whole loop
//! (`App::run`: byte handling, framing, the configuration path, the deadline, the reset
//! acknowledgement, both schedules) twice: on a board whose every answer is opaque, and on
//! the boards' own serial link and configuration store: USART1's driver and interrupt
//! handler (`board/usart1.rs`, the same file the firmware builds, with its vector in this
//! binary's table) over the lock-free queues and the interrupt's logic (`serial.rs`), and
//! the store (`store.rs`) over the `f405` board's flash driver (`flash.rs`: reads, erase,
//! program and the caches' flush, over the registers of `board/flash.rs`). The release build (LTO, dead code removed) therefore links only if
//! no panic is reachable from any of them: a bounds check, an `unwrap`, an overflow check
//! or an `unreachable!` that the optimiser could not prove dead would keep the panic
//! handler, and with it the undefined symbol `a_panic_is_reachable_from_the_flight_code`,
//! and the link fails naming it (checked: a deliberate out-of-bounds index in the
//! interrupt's logic fails the link).
//!
//! Not in it: the boards' start-up (the `f405` board's clock start, `board/rcc.rs`:
//! register writes and bounded polls over factors `clock.rs` checks at compile time; the
//! brown-out level's read and the provisioning build's option-byte write), the SysTick
//! handler (two atomic operations and a register read), the watchdog driver, the fault
//! handlers themselves and the boards' logging (semihosting formatting; defmt).
//!
//! It is built with the firmware (`cargo build -p firmware --target thumbv7em-none-eabihf
//! --release`, both boards), so the check runs wherever the firmware is built; it is never
//! flashed. Debug builds keep their panic paths (no optimisation), so there the handler just
//! loops and nothing is checked. On the host it is an empty program.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

/// The flight application itself (byte handling, framing, the configuration path, both
/// schedules), the same source file the firmware builds.
#[cfg(target_os = "none")]
#[path = "../app.rs"]
#[allow(dead_code)]
mod app;

/// What the board found at reset (the application's `BootReport`).
#[cfg(target_os = "none")]
#[path = "../boot.rs"]
#[allow(dead_code)]
mod boot;

/// The link's queues and the USART interrupt's logic.
#[cfg(target_os = "none")]
#[path = "../serial.rs"]
#[allow(dead_code)]
mod serial;

/// The configuration store.
#[cfg(target_os = "none")]
#[path = "../store.rs"]
#[allow(dead_code)]
mod store;

/// The boards' serial-port driver, and USART1's and USART2's ports and interrupt handlers, as
/// the firmware builds them.
#[cfg(target_os = "none")]
#[path = "../board/usart.rs"]
#[allow(dead_code, unsafe_code)]
mod usart;
#[cfg(target_os = "none")]
#[path = "../board/usart1.rs"]
#[allow(dead_code, unsafe_code)]
mod usart1;
#[cfg(target_os = "none")]
#[path = "../board/usart2.rs"]
#[allow(dead_code, unsafe_code)]
mod usart2;

/// The `f405` board's flash driver under the store (its logic, board-independent).
#[cfg(target_os = "none")]
#[path = "../flash.rs"]
#[allow(dead_code)]
mod flash;

/// The `f405` board's flash registers under that driver.
#[cfg(target_os = "none")]
#[path = "../board/flash.rs"]
#[allow(dead_code, unsafe_code)]
mod flash_registers;

#[cfg(target_os = "none")]
mod target {
    use core::hint::black_box;

    use super::app::{App, Board, BootReport, Event, NoCounter, Periods, QueueFull, Schedule};
    use super::flash::{STORE_SLOT_LEN, STORE_SLOTS, StoreFlash};
    use super::flash_registers::Registers;
    use super::store::{ConfigStore, Persist};
    use super::usart1::{self, SerialLink};
    use super::usart2;
    use embedded_io::{ErrorType, Read, ReadReady};

    /// A board whose every answer is opaque to the optimiser: any byte, any readiness, any
    /// number of periods, any store outcome.
    struct AnyBoard;

    impl ErrorType for AnyBoard {
        type Error = core::convert::Infallible;
    }

    impl Read for AnyBoard {
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
            for b in buf.iter_mut() {
                *b = black_box(0);
            }
            Ok(black_box(buf.len()))
        }
    }

    impl ReadReady for AnyBoard {
        fn read_ready(&mut self) -> Result<bool, Self::Error> {
            Ok(black_box(true))
        }
    }

    impl Board for AnyBoard {
        type Link = Self;
        type Autopilot = Self;
        type Counter = NoCounter;

        fn link(&mut self) -> &mut Self {
            self
        }

        fn autopilot(&mut self) -> &mut Self {
            self
        }

        fn transmit_autopilot(&mut self, frames: &[u8]) -> Result<(), QueueFull> {
            self.transmit(frames)
        }

        fn take_autopilot_rx_errors(&mut self) -> u32 {
            black_box(0)
        }

        fn transmit(&mut self, frame: &[u8]) -> Result<(), QueueFull> {
            black_box(frame);
            if black_box(true) {
                Ok(())
            } else {
                Err(QueueFull)
            }
        }

        fn take_periods(&mut self) -> Periods {
            black_box(Periods {
                count: 1,
                last_tick_at: 0,
            })
        }

        fn take_rx_errors(&mut self) -> u32 {
            black_box(0)
        }

        fn pass_completed(&mut self) {}

        fn wait_for_event(&mut self) {}

        fn log(&mut self, event: Event) {
            black_box(event);
        }

        fn persist(&mut self, cfg: &ControllerConfig) -> ConfigStorage {
            black_box(cfg);
            black_box(ConfigStorage::Unavailable)
        }
    }

    /// The boards' own links and store: USART1's and USART2's queues and interrupts, the
    /// flash driver.
    struct McuLink {
        link: SerialLink,
        autopilot: usart2::SerialLink,
        store: Option<ConfigStore<StoreFlash<Registers>>>,
    }

    impl Board for McuLink {
        type Link = SerialLink;
        type Autopilot = usart2::SerialLink;
        type Counter = NoCounter;

        fn link(&mut self) -> &mut SerialLink {
            &mut self.link
        }

        fn autopilot(&mut self) -> &mut usart2::SerialLink {
            &mut self.autopilot
        }

        fn transmit_autopilot(&mut self, frames: &[u8]) -> Result<(), QueueFull> {
            self.autopilot.transmit(frames)
        }

        fn take_autopilot_rx_errors(&mut self) -> u32 {
            usart2::take_rx_errors()
        }

        fn transmit(&mut self, frame: &[u8]) -> Result<(), QueueFull> {
            self.link.transmit(frame)
        }

        fn take_periods(&mut self) -> Periods {
            black_box(Periods::default())
        }

        fn take_rx_errors(&mut self) -> u32 {
            usart1::take_rx_errors()
        }

        fn pass_completed(&mut self) {}

        fn wait_for_event(&mut self) {}

        fn log(&mut self, event: Event) {
            black_box(event);
        }

        fn persist(&mut self, cfg: &ControllerConfig) -> ConfigStorage {
            match &mut self.store {
                Some(s) => s.persist(cfg),
                None => ConfigStorage::Failed,
            }
        }
    }

    use cortex_m_rt::entry;
    use ibvs_core::wire::{
        ConfigReport, ConfigStatus, ConfigStorage, Downlink, FrameDecoder, MAX_FRAME_LEN,
        PeerMessage, config_id, encode_config_report, encode_downlink,
    };
    use ibvs_core::{Controller, ControllerConfig, ControllerInput};
    // The device's interrupt vectors (cortex-m-rt's link script needs them).
    use stm32f4xx_hal::pac;

    #[entry]
    fn main() -> ! {
        let mut decoder = FrameDecoder::new();
        let mut buf = [0u8; MAX_FRAME_LEN];
        // The application's loop: boot frame, then every byte and period, either schedule.
        let schedule = if black_box(true) {
            Schedule::Lockstep
        } else {
            Schedule::FreeRunning
        };
        let boot = black_box(BootReport::default());
        if let Ok(app) = App::new(schedule, boot, black_box(None))
            && black_box(true)
        {
            app.run(&mut AnyBoard);
        }
        // Again on the boards' USART1 driver and the store on the flash driver.
        if black_box(true)
            && let Some(dp) = pac::Peripherals::take()
        {
            let link = usart1::init(dp.USART1, black_box(None));
            let autopilot = usart2::init(dp.USART2, black_box(None));
            let mut store = ConfigStore::new(
                StoreFlash::new(Registers::new(dp.FLASH)),
                STORE_SLOTS,
                STORE_SLOT_LEN,
            )
            .ok();
            let stored = store
                .as_mut()
                .and_then(|s| s.load().newest)
                .map(|(cfg, _)| cfg);
            if let Ok(app) = App::new(schedule, boot, stored) {
                app.run(&mut McuLink {
                    link,
                    autopilot,
                    store,
                });
            }
        }
        loop {
            // The controller: any configuration, any input.
            if let Ok(mut controller) = Controller::new(black_box(ControllerConfig::default())) {
                for _ in 0..black_box(2u32) {
                    let input: ControllerInput = black_box(ControllerInput::default());
                    black_box(controller.step(&input));
                    // The gain schedule's follow-up the flight loop runs after each step.
                    black_box(black_box(&mut controller).follow_schedule());
                }
            }
            // The link: any byte, any frame the flight computer takes, any command frame.
            let mut written = None;
            if let Some(frame) = decoder.feed(black_box(0u8)) {
                match frame.and_then(|p| p.peer_message()) {
                    Ok(PeerMessage::ConfigWrite(cfg)) => written = Some(cfg),
                    other => {
                        black_box(other.is_ok());
                    }
                }
            }
            black_box(encode_downlink(&black_box(Downlink::default()), &mut buf).is_ok());
            // The configuration path: any configuration written, applied or refused, reported.
            if let (Some(cfg), Ok(mut controller)) = (
                written,
                Controller::new(black_box(ControllerConfig::default())),
            ) {
                let status = match controller.reconfigure(cfg) {
                    Ok(()) => ConfigStatus::Applied,
                    Err(e) => ConfigStatus::refused(e),
                };
                let report = ConfigReport {
                    seq: 0,
                    status,
                    storage: ConfigStorage::default(),
                    config_id: config_id(controller.config()),
                    config: *controller.config(),
                };
                black_box(encode_config_report(&black_box(report), &mut buf).is_ok());
            }
        }
    }

    #[cfg(not(debug_assertions))]
    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
        // Note(unsafe): never called; the symbol does not exist, so this handler makes the
        // link fail if anything can reach it (see the crate doc).
        #[allow(unsafe_code)]
        unsafe extern "C" {
            fn a_panic_is_reachable_from_the_flight_code() -> !;
        }
        #[allow(unsafe_code)]
        unsafe {
            a_panic_is_reachable_from_the_flight_code()
        }
    }

    #[cfg(debug_assertions)]
    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
        loop {}
    }
}

/// Host builds: nothing to check here (the check is the target link).
#[cfg(not(target_os = "none"))]
fn main() {}

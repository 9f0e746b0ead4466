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
//! (`App::run`: byte handling, framing, the configuration path, both schedules) on a board
//! whose every answer is opaque. The release build (LTO, dead code removed) therefore links
//! only if no panic is reachable from any of them: a bounds check, an `unwrap`, an overflow
//! check or an `unreachable!` that the optimiser could not prove dead would keep the panic
//! handler, and with it the undefined symbol
//! `a_panic_is_reachable_from_the_flight_code`, and the link fails naming it.
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

#[cfg(target_os = "none")]
mod target {
    use core::hint::black_box;

    use super::app::{App, Board, Event, NoCounter, Schedule};
    use embedded_io::{ErrorType, Read, ReadReady, Write};

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

    impl Write for AnyBoard {
        fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
            black_box(buf);
            Ok(black_box(buf.len()))
        }

        fn flush(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
    }

    impl Board for AnyBoard {
        type Link = Self;
        type Counter = NoCounter;

        fn link(&mut self) -> &mut Self {
            self
        }

        fn take_periods(&mut self) -> u32 {
            black_box(1)
        }

        fn take_rx_errors(&mut self) -> u32 {
            black_box(0)
        }

        fn wait_for_event(&mut self) {}

        fn log(&mut self, event: Event) {
            black_box(event);
        }

        fn persist(&mut self, cfg: &ControllerConfig) -> ConfigStorage {
            black_box(cfg);
            black_box(ConfigStorage::Unavailable)
        }
    }

    use cortex_m_rt::entry;
    use ibvs_core::wire::{
        ConfigReport, ConfigStatus, ConfigStorage, Downlink, FrameDecoder, MAX_FRAME_LEN,
        PeerMessage, config_id, encode_config_report, encode_downlink,
    };
    use ibvs_core::{Controller, ControllerConfig, ControllerInput};
    // The device's interrupt vectors (cortex-m-rt's link script needs them).
    use stm32f4xx_hal as _;

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
        if let Ok(app) = App::new(schedule, black_box(false), black_box(None)) {
            if black_box(true) {
                app.run(&mut AnyBoard);
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

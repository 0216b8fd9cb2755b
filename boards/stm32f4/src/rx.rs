//! Interrupt-driven reception into bounded queues.
//!
//! Each USART's RXNE interrupt drains its data register into a `heapless` SPSC queue: the
//! interrupt owns the producer (inside a `critical_section::Mutex`, installed once), the main
//! loop owns the consumer and never blocks the interrupt. A byte that finds its queue full is
//! dropped and counted; a framing, noise, parity or overrun error is counted. Nothing panics.

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};

use critical_section::Mutex;
use embedded_hal_nb::serial::Read;
use heapless::spsc::{Consumer, Producer, Queue};
use static_cell::ConstStaticCell;
use stm32f4xx_hal::pac::{USART1, USART2};
use stm32f4xx_hal::serial::{Instance, Rx, RxListen};

/// Bytes the laser queue holds: 1023 (about 20 ms at 500 kBd, more than one full LMS
/// telegram of 732 bytes; the main loop bounds each step's blocking transmission to less,
/// and 1 KiB more would take the static RAM past 96 KiB).
pub const LASER_QUEUE: usize = 1024;
/// Bytes the host-link queue holds: 255 (about 2.8 ms at 921.6 kBd; the host's largest
/// command, a Configure, is 104 bytes encoded, and the main loop takes 64 bytes a step).
pub const HOST_QUEUE: usize = 256;

/// What a receive path has counted since it was installed. Counters saturate.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, defmt::Format)]
pub struct RxStats {
    /// Bytes queued.
    pub bytes: u32,
    /// Bytes dropped because the queue was full.
    pub dropped: u32,
    /// Receive errors (framing, noise, parity, overrun).
    pub errors: u32,
}

struct RxPath<U: Instance> {
    rx: Rx<U>,
    producer: Producer<'static, u8>,
    stats: RxStats,
}

impl<U: Instance> RxPath<U> {
    /// Moves every byte the USART holds into the queue; returns how many it queued.
    fn drain(&mut self) -> u32 {
        let mut queued = 0;
        loop {
            match self.rx.read() {
                Ok(byte) => {
                    if self.producer.enqueue(byte).is_ok() {
                        self.stats.bytes = self.stats.bytes.saturating_add(1);
                        queued += 1;
                    } else {
                        self.stats.dropped = self.stats.dropped.saturating_add(1);
                    }
                }
                Err(nb::Error::WouldBlock) => break,
                // The HAL has read the data register, which clears the error flags.
                Err(nb::Error::Other(_)) => self.stats.errors = self.stats.errors.saturating_add(1),
            }
        }
        queued
    }
}

/// When the laser interrupt last queued a byte, µs ([`crate::clock::micros`]).
static LASER_LAST_US: AtomicU32 = AtomicU32::new(0);

/// When the last laser byte was queued, µs (the board's clock): the arrival time of the
/// newest byte in the laser queue.
pub fn laser_last_us() -> u32 {
    LASER_LAST_US.load(Ordering::Relaxed)
}

static LASER_QUEUE_CELL: ConstStaticCell<Queue<u8, LASER_QUEUE>> =
    ConstStaticCell::new(Queue::new());
static HOST_QUEUE_CELL: ConstStaticCell<Queue<u8, HOST_QUEUE>> = ConstStaticCell::new(Queue::new());

static LASER: Mutex<RefCell<Option<RxPath<USART1>>>> = Mutex::new(RefCell::new(None));
static HOST: Mutex<RefCell<Option<RxPath<USART2>>>> = Mutex::new(RefCell::new(None));

/// Hands the laser's receiver to its interrupt (enabling RXNE) and returns the queue's
/// consumer. Call once, before [`crate::hw::unmask_usart_interrupts`].
pub fn install_laser(rx: Rx<USART1>) -> Consumer<'static, u8> {
    let (producer, consumer) = LASER_QUEUE_CELL.take().split();
    install(&LASER, rx, producer);
    consumer
}

/// Hands the host link's receiver to its interrupt (enabling RXNE) and returns the queue's
/// consumer. Call once, before [`crate::hw::unmask_usart_interrupts`].
pub fn install_host(rx: Rx<USART2>) -> Consumer<'static, u8> {
    let (producer, consumer) = HOST_QUEUE_CELL.take().split();
    install(&HOST, rx, producer);
    consumer
}

/// Enables RXNE on `rx` and hands it, with the producer of its queue, to the interrupt that
/// reads `path`.
fn install<U: Instance>(
    path: &Mutex<RefCell<Option<RxPath<U>>>>,
    mut rx: Rx<U>,
    producer: Producer<'static, u8>,
) {
    rx.listen();
    critical_section::with(|cs| {
        path.borrow(cs).replace(Some(RxPath {
            rx,
            producer,
            stats: RxStats::default(),
        }));
    });
}

/// The USART1 interrupt's work.
pub fn on_laser_interrupt() {
    critical_section::with(|cs| {
        if let Some(path) = LASER.borrow_ref_mut(cs).as_mut() {
            if path.drain() > 0 {
                LASER_LAST_US.store(crate::clock::micros(), Ordering::Relaxed);
            }
        }
    });
}

/// The USART2 interrupt's work.
pub fn on_host_interrupt() {
    critical_section::with(|cs| {
        if let Some(path) = HOST.borrow_ref_mut(cs).as_mut() {
            let _ = path.drain();
        }
    });
}

/// The laser path's counters.
pub fn laser_stats() -> RxStats {
    critical_section::with(|cs| {
        LASER
            .borrow_ref(cs)
            .as_ref()
            .map(|p| p.stats)
            .unwrap_or_default()
    })
}

/// The host path's counters.
pub fn host_stats() -> RxStats {
    critical_section::with(|cs| {
        HOST.borrow_ref(cs)
            .as_ref()
            .map(|p| p.stats)
            .unwrap_or_default()
    })
}

/// Moves up to `buf.len()` queued bytes into `buf`; returns how many (0 when the interrupt has
/// queued nothing).
pub fn take(consumer: &mut Consumer<'static, u8>, buf: &mut [u8]) -> usize {
    let mut n = 0;
    for slot in buf.iter_mut() {
        let Some(byte) = consumer.dequeue() else {
            break;
        };
        *slot = byte;
        n += 1;
    }
    n
}

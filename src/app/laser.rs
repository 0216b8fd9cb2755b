//! The laser side of the co-processor: bytes from the laser UART decoded into SICK lines and
//! lidar packets, each placed at its actuator angle (the board's source, the servo's model
//! or the host's PanAngle) and fed to the pipeline; the servo's command; the laser UART's
//! setup for the board.

use super::{bump, AppCounters, CoProcessor, Shutdown};
use crate::actuator::ServoSweep;
use crate::angle::AngleSource;
use crate::angle::{Angle, FineAngle};
use crate::geometry::PoseTrack;
use crate::laser::{LaserItem, Sensor};
use crate::pipeline::{Frontend, PacketActuator, PacketTimes};
use crate::pyramid::Pyramid;
use crate::wire::sick::MeasuredValues;
use crate::wire::FeedResult;

/// An angle source for boards without one (an actuator driven open-loop, or angles that come
/// only from the host): every reading fails, so the host's PanAngle is used.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NoAngleSource;

/// The error of [`NoAngleSource`]: there is no source.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NoSource;

impl AngleSource for NoAngleSource {
    type Error = NoSource;

    fn read_angle(&mut self) -> Result<Angle, NoSource> {
        Err(NoSource)
    }
}

/// The laser as the board sets up its UART for it ([`CoProcessor::take_laser_change`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LaserPort {
    /// The sensor (the board sends it whatever starts its stream: a SCAN request, the SICK's
    /// continuous-output command).
    pub sensor: Sensor,
    /// The UART's baud rate, bits per second.
    pub baud: u32,
}

impl<const W: usize, const L: usize, const C: usize, const Q: usize, const N: usize>
    CoProcessor<W, L, C, Q, N>
{
    /// Takes bytes from the laser's UART that arrived by `now_us` (the board's clock, µs,
    /// wrapping: when the chunk's last byte arrived, as near as the board knows). Every SICK
    /// telegram they complete is parsed and its line fed to the pipeline at the actuator
    /// angle of that moment; every lidar packet they complete is timed back from `now_us`
    /// and fed with the actuator's angles at its first and last return (see the
    /// [module documentation](super) for where the angles come from). Bytes of an incomplete
    /// telegram or packet are kept for the next call. Nothing is taken while a Shutdown waits
    /// for its answer.
    pub fn laser(&mut self, bytes: &[u8], now_us: u32, angle: &mut impl AngleSource) {
        self.laser_timed(bytes, now_us, now_us, angle);
    }

    /// [`laser`](Self::laser) for a board that knows when the chunk's last byte arrived
    /// (`arrival_us`, from its receive interrupt) apart from the time of the call (`now_us`,
    /// when the angle source is read): packets are timed back from `arrival_us`, the source's
    /// reading is kept with `now_us`. Both on the board's µs clock.
    pub fn laser_timed(
        &mut self,
        bytes: &[u8],
        arrival_us: u32,
        now_us: u32,
        angle: &mut impl AngleSource,
    ) {
        if self.shutdown != Shutdown::Running {
            return;
        }
        self.clock_us = now_us;
        self.clock_known = true;
        if self.servo.is_on() {
            self.servo.track(now_us);
        }
        // The board's source, read at most once per call (at `now_us`).
        let mut reading = Reading::NotYet;
        let mut chunk = bytes;
        loop {
            let result = self.laser.feed(chunk);
            chunk = result.remaining();
            let item = match result {
                FeedResult::Consumed => return,
                FeedResult::Item { item, .. } => item,
                // Refused candidates are counted by the decoder.
                FeedResult::Rejected { .. } => continue,
            };
            match item {
                LaserItem::Telegram(telegram) => match MeasuredValues::parse(&telegram) {
                    Ok(values) => {
                        let servo = self.servo.is_on().then_some(&self.servo);
                        match line_angle(
                            angle,
                            self.host_angle,
                            servo,
                            arrival_us,
                            &mut self.counters,
                        ) {
                            Some(a) => {
                                self.frontend.set_actuator(a);
                                // A refused line is counted by the pipeline.
                                if self.poses.is_empty() {
                                    let _ = self.frontend.line(&mut self.pyramid, &values);
                                } else {
                                    // The telegram's last byte arrived before the bytes
                                    // still in the chunk; its last beam was measured one
                                    // transmission time before that (docs/lidars.md).
                                    let end = arrival_us
                                        .wrapping_sub(self.timer.bytes_us(chunk.len()))
                                        .wrapping_sub(
                                            self.timer.bytes_us(telegram.as_bytes().len()),
                                        );
                                    Self::timed_line(
                                        &mut self.frontend,
                                        &mut self.pyramid,
                                        &self.poses,
                                        &values,
                                        end,
                                    );
                                }
                            }
                            None => bump(&mut self.counters.lines_without_angle),
                        }
                    }
                    Err(_) => bump(&mut self.counters.telegrams_unparsed),
                },
                LaserItem::Packet(packet) => {
                    // The packet's last byte arrived before the bytes still in the chunk.
                    let end = arrival_us.wrapping_sub(self.timer.bytes_us(chunk.len()));
                    let starts = self.revolutions.starts(&packet);
                    let (first, last) = self.timer.times(&packet, end, starts);
                    if reading == Reading::NotYet {
                        reading = match angle.read_angle() {
                            Ok(a) => {
                                self.track.push(now_us, FineAngle::from(a));
                                Reading::Read
                            }
                            Err(_) => {
                                bump(&mut self.counters.angle_source_errors);
                                Reading::Failed
                            }
                        };
                    }
                    // A packet of one return (an RPLIDAR node) has one time: one lookup.
                    let actuator = match reading {
                        Reading::Read if last == first => self.track.at(first).map(|a| (a, a)),
                        Reading::Read => self.track.at(first).zip(self.track.at(last)),
                        _ if self.servo.is_on() => {
                            self.servo.estimate(first).zip(self.servo.estimate(last))
                        }
                        _ => self.host_angle.map(|a| {
                            let a = FineAngle::from(a);
                            (a, a)
                        }),
                    };
                    match actuator {
                        Some((first_angle, last_angle)) => {
                            let actuator = PacketActuator {
                                first: first_angle,
                                last: last_angle,
                            };
                            // A refused packet is counted by the pipeline.
                            if self.poses.is_empty() {
                                let _ = self.frontend.packet(
                                    &mut self.pyramid,
                                    packet.returns(),
                                    starts,
                                    actuator,
                                );
                            } else {
                                Self::timed_packet(
                                    &mut self.frontend,
                                    &mut self.pyramid,
                                    &self.poses,
                                    &packet,
                                    starts,
                                    actuator,
                                    PacketTimes {
                                        first_us: first,
                                        last_us: last,
                                    },
                                );
                            }
                        }
                        None => bump(&mut self.counters.lines_without_angle),
                    }
                }
                // ACKs, descriptors, responses: nothing to place.
                LaserItem::Other => {}
            }
        }
    }

    /// A SICK line placed by stamped poses (out of line: the untimed path's stack frame stays
    /// as it was; a refused line is counted by the pipeline).
    #[inline(never)]
    fn timed_line(
        frontend: &mut Frontend<C, L>,
        pyramid: &mut Pyramid<W, L>,
        poses: &PoseTrack<N>,
        values: &MeasuredValues<'_>,
        last_beam_us: u32,
    ) {
        let _ = frontend.line_timed(pyramid, values, last_beam_us, poses);
    }

    /// A lidar packet placed by stamped poses (out of line, as [`Self::timed_line`]).
    #[inline(never)]
    fn timed_packet(
        frontend: &mut Frontend<C, L>,
        pyramid: &mut Pyramid<W, L>,
        poses: &PoseTrack<N>,
        packet: &crate::laser::Packet<'_>,
        starts: bool,
        actuator: PacketActuator,
        times: PacketTimes,
    ) {
        let _ = frontend.packet_timed(pyramid, packet.returns(), starts, actuator, times, poses);
    }

    /// The angle to command a nodding servo at `now_us` (the board's clock, µs), when the
    /// setup has one: the board writes it to the servo's PWM (`drivers::servo`) every step of
    /// its main loop. The first call begins the sweep (a settling hold at its lower end);
    /// `None` without a servo.
    pub fn actuator_command(&mut self, now_us: u32) -> Option<FineAngle> {
        if self.servo.is_on() {
            self.clock_us = now_us;
            self.clock_known = true;
        }
        self.servo.is_on().then(|| self.servo.command(now_us))
    }

    /// The laser the setup in force names and its UART's baud rate.
    #[must_use]
    pub fn laser_port(&self) -> LaserPort {
        LaserPort {
            sensor: self.laser.sensor(),
            baud: self.frontend.config().baud,
        }
    }

    /// The laser UART's baud rate in force, bits per second.
    #[must_use]
    pub fn laser_baud(&self) -> u32 {
        self.frontend.config().baud
    }

    /// The laser the board must set its UART up for, once after boot and after each Setup
    /// that changed the sensor or the baud rate (then `None` until the next change): the board
    /// sets the rate (an emulated UART ignores it) and starts the sensor's stream.
    pub fn take_laser_change(&mut self) -> Option<LaserPort> {
        core::mem::take(&mut self.laser_change).then(|| self.laser_port())
    }

    /// Counts an overrun of the laser's UART (bytes lost before they reached [`laser`]).
    ///
    /// [`laser`]: Self::laser
    pub fn laser_overrun(&mut self) {
        bump(&mut self.counters.laser_overruns);
    }
}

/// Whether the board's angle source was read in this call of [`CoProcessor::laser`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Reading {
    NotYet,
    Read,
    Failed,
}

/// The actuator angle of a SICK line: the source's, else the servo model's at `now_us` when
/// the setup has a servo, else the host's (the source's failure counted).
fn line_angle(
    source: &mut impl AngleSource,
    host: Option<Angle>,
    servo: Option<&ServoSweep>,
    now_us: u32,
    counters: &mut AppCounters,
) -> Option<FineAngle> {
    match source.read_angle() {
        Ok(angle) => Some(FineAngle::from(angle)),
        Err(_) => {
            bump(&mut counters.angle_source_errors);
            match servo {
                Some(servo) => servo.estimate(now_us),
                None => host.map(FineAngle::from),
            }
        }
    }
}

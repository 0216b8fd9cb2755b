//! The receive side of the link: host frames decoded, each message validated and converted
//! into a [`Command`] (or refused with the Reply that says why), sequence gaps counted, and
//! the commands that concern only the link and the maps carried out here ([`Link::serve`]).

use crate::angle::Angle;
use crate::geometry::Pose;
use crate::pipeline::FrontendConfig;
use crate::pyramid::{Config, Pyramid};
use crate::wire::link::{
    DecodeError, Decoded, Header, Message, Reply, ReplyCode, SnapshotScope, Undecoded,
};
use crate::wire::FeedResult;
use crate::Design;

use super::convert;
use super::{layers_of, Link};

/// A host command, decoded, validated and converted into the core's types by the link
/// ([`convert`]): what the application carries out. Commands that fail validation never
/// become one: the link refuses them itself ([`Rejection::Refused`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Command<const L: usize> {
    /// The robot's pose (checked by [`Pose::from_f32`]'s rule) and its stamp: `None`, an
    /// unstamped pose, in force for every return from now on (version 3's latest-pose rule);
    /// `Some(stamp_us)`, a stamped pose (Pose `flags` bit 0), the robot's pose at `stamp_us` of
    /// the device's µs clock (wrapping), for the pose track. Flags other than bit 0 are
    /// refused by the link (Reply OutOfRange, param [`convert::PARAM_POSE_FLAGS`]).
    Pose(Pose, Option<u32>),
    /// The actuator angle from the host (boards without an encoder, or when it fails).
    PanAngle(Angle),
    /// A new design and configuration (checked by [`Design::new`] and the increments' and
    /// clamp's rules; the window and the margin are checked when it is applied).
    Configure(Design<L>, Config),
    /// Forget every observation.
    Reset,
    /// Send every tile of these layers again.
    Snapshot(SnapshotScope),
    /// Answer Ok.
    Ping,
    /// Answer with a TimeReply (the link does, in [`Link::serve`]; no Reply).
    TimeRequest {
        /// The host's clock, echoed, µs.
        host_us: u64,
        /// The device's µs clock (wrapping) the board passed with the host bytes that
        /// completed the request ([`Link::receive_at`]).
        device_us: u32,
    },
    /// The laser's mounting, its lines' grouping and the classifier (checked by
    /// [`convert::frontend_config`]).
    Setup(FrontendConfig),
    /// The classifier's step threshold (metres) and navigability rule, the rest of the setup
    /// unchanged (checked by [`convert::set_rule_of`]).
    SetRule(crate::units::Meters, crate::classify::NavigabilityRule),
    /// Send a Stats frame at the next poll, whatever the interval.
    RequestStats,
    /// End the current observation now (no Reply).
    EndObservation,
    /// Answer with the stack's high-water mark (Reply Ok, `value` the bytes used, `a` the
    /// stack's size), drain the queue, stop.
    Shutdown,
}

/// A command and the header of the frame that carried it (its Reply names it).
#[derive(Debug, Clone, PartialEq)]
pub struct Request<const L: usize> {
    /// The frame's header.
    pub header: Header,
    /// What it asks.
    pub command: Command<L>,
}

/// Why a host frame became no [`Request`]. Both are counted; a Reply has been queued where
/// the frame could be answered.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Rejection {
    /// The frame did not decode (framing, CRC, version, type, body); answered when its header
    /// was readable.
    BadFrame(DecodeError),
    /// The command failed validation; this Reply, queued, says why.
    Refused(Reply),
}

impl<const Q: usize, const N: usize> Link<Q, N> {
    /// Carries out and answers the commands that concern only the link and the maps (a
    /// snapshot, a Stats request, a ping, a time request) and hands back the others, which
    /// are the application's ([`crate::app::CoProcessor`] carries them out).
    pub fn serve<const W: usize>(
        &mut self,
        pyramid: &mut Pyramid<W, N>,
        request: Request<N>,
    ) -> Option<Request<N>> {
        let header = request.header;
        match request.command {
            Command::Snapshot(scope) => {
                if self.snapshot(pyramid, scope) {
                    self.answer(Reply::ok(header));
                    self.announce(pyramid);
                } else {
                    let layers = layers_of(pyramid).min(N);
                    self.refuse(convert::layer_refusal(header, scope, layers));
                }
                None
            }
            Command::RequestStats => {
                self.request_stats();
                None
            }
            Command::Ping => {
                self.answer(Reply::ok(header));
                None
            }
            Command::TimeRequest { host_us, device_us } => {
                self.time_reply(host_us, device_us);
                None
            }
            _ => Some(request),
        }
    }

    /// Takes bytes from the host and returns the first thing they complete, postcard-style:
    /// a validated [`Request`] to carry out, or a [`Rejection`] (counted, and answered where
    /// possible), each with the bytes not yet taken; [`FeedResult::Consumed`] when the bytes
    /// complete nothing. Call it again with `remaining` until `Consumed`.
    ///
    /// Invalid commands are refused here, by the rule that converts them, with a Reply that
    /// names the field; a valid one is the application's to carry out and to answer
    /// ([`answer`](Self::answer), [`refuse`](Self::refuse)).
    ///
    /// The device time a TimeRequest carries is the one of the last
    /// [`receive_at`](Self::receive_at) (0 before any): a board with a µs clock calls that.
    pub fn receive<'c>(&mut self, bytes: &'c [u8]) -> FeedResult<'c, Request<N>, Rejection> {
        // The message borrows the receive buffer: convert it into an owned command first.
        let (frame, offset, remaining) = match self.rx.feed(bytes) {
            FeedResult::Consumed => return FeedResult::Consumed,
            FeedResult::Item {
                item: Decoded { header, message },
                offset,
                remaining,
            } => (
                Ok((header, command(header, message, self.rx_clock_us))),
                offset,
                remaining,
            ),
            FeedResult::Rejected {
                error: Undecoded { error, header },
                offset,
                remaining,
            } => (Err((error, header)), offset, remaining),
        };
        match frame {
            Ok((header, Ok(command))) => {
                self.track_seq(header.seq);
                FeedResult::Item {
                    item: Request { header, command },
                    offset,
                    remaining,
                }
            }
            Ok((header, Err(reply))) => {
                self.track_seq(header.seq);
                self.refuse(reply);
                FeedResult::Rejected {
                    error: Rejection::Refused(reply),
                    offset,
                    remaining,
                }
            }
            Err((error, header)) => {
                if let Some(header) = header {
                    self.track_seq(header.seq);
                    let code = match error {
                        DecodeError::UnknownType(_) => ReplyCode::Unsupported,
                        _ => ReplyCode::Malformed,
                    };
                    self.refuse(Reply::code(header, code));
                }
                FeedResult::Rejected {
                    error: Rejection::BadFrame(error),
                    offset,
                    remaining,
                }
            }
        }
    }

    /// [`receive`](Self::receive) of host bytes the board took at `now_us` of its µs clock
    /// (wrapping): a TimeRequest they complete carries that time as its `device_us`. Later
    /// calls of `receive` (the rest of the same bytes) keep it.
    pub fn receive_at<'c>(
        &mut self,
        bytes: &'c [u8],
        now_us: u32,
    ) -> FeedResult<'c, Request<N>, Rejection> {
        self.rx_clock_us = now_us;
        self.receive(bytes)
    }

    fn track_seq(&mut self, seq: u16) {
        if let Some(expected) = self.rx_expected {
            let d = seq.wrapping_sub(expected);
            if d != 0 {
                let missing = if d < 0x8000 { u32::from(d) } else { 1 };
                self.counters.rx_seq_gaps = self.counters.rx_seq_gaps.saturating_add(missing);
            }
        }
        self.rx_expected = Some(seq.wrapping_add(1));
    }
}

/// A host message as a validated command, or the Reply that refuses it; `now_us` is the
/// device time of the bytes that completed it.
fn command<const L: usize>(
    header: Header,
    message: Message<'_>,
    now_us: u32,
) -> Result<Command<L>, Reply> {
    Ok(match message {
        Message::Pose(report) => {
            let pose = convert::pose_of(&report).map_err(|e| convert::pose_refusal(header, &e))?;
            let stamp =
                convert::stamp_of(&report).map_err(|f| convert::pose_flags_refusal(header, f))?;
            Command::Pose(pose, stamp)
        }
        Message::TimeRequest(request) => Command::TimeRequest {
            host_us: request.host_us,
            device_us: now_us,
        },
        Message::PanAngle(pan) => Command::PanAngle(pan.angle()),
        Message::Configure(c) => {
            let refuse = |e: crate::DesignError| convert::design_refusal(header, &e);
            let design = convert::design_of::<L>(&c).map_err(refuse)?;
            let config = convert::config_of(&c).map_err(refuse)?;
            Command::Configure(design, config)
        }
        Message::Reset => Command::Reset,
        Message::RequestSnapshot(scope) => Command::Snapshot(scope),
        Message::Ping => Command::Ping,
        Message::Setup(setup) => Command::Setup(
            convert::frontend_config(&setup).map_err(|e| convert::setup_refusal(header, &e))?,
        ),
        Message::SetRule(set) => {
            let (step, rule) =
                convert::set_rule_of(&set).map_err(|e| convert::setup_refusal(header, &e))?;
            Command::SetRule(step, rule)
        }
        Message::RequestStats => Command::RequestStats,
        Message::EndObservation => Command::EndObservation,
        Message::Shutdown => Command::Shutdown,
        Message::Hello(_)
        | Message::LayerPatch(_)
        | Message::WindowMoved(_)
        | Message::Stats(_)
        | Message::Reply(_)
        | Message::Decayed(_)
        | Message::TimeReply(_)
        | Message::Observed(_) => return Err(Reply::code(header, ReplyCode::Unsupported)),
    })
}

//! A device whose maps go to the live outputs as they arrive: `pyramid run` with `--ros2`,
//! `--foxglove` or `--mcap` drives the board through [`Publishing`], so a recording played
//! through the emulated board (or in process) reaches the same topics, server and file as a
//! device heard by `pyramid listen`.
use super::{Outputs, RobotPose};
use crate::device::Device;
use crate::link::{HostLink, LinkEvent};
use terrain_pyramid::wire::link::Message;

/// `device`, with the mirror offered to `outputs` after every exchange and the pose the host
/// sent last as the robot's.
pub struct Publishing<'d, 'o, D> {
    device: &'d mut D,
    outputs: &'o mut Outputs,
    pose: Option<RobotPose>,
}

impl<'d, 'o, D: Device> Publishing<'d, 'o, D> {
    /// Wraps `device`; nothing is offered until it has answered something. With every output
    /// off, offering costs nothing.
    pub fn new(device: &'d mut D, outputs: &'o mut Outputs) -> Self {
        Self {
            device,
            outputs,
            pose: None,
        }
    }

    /// The last pose sent to the device (x, y in metres, yaw in radians), if any.
    #[must_use]
    pub fn pose(&self) -> Option<RobotPose> {
        self.pose
    }
}

impl<D: Device> Device for Publishing<'_, '_, D> {
    fn laser(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.device.laser(bytes)
    }

    fn send(&mut self, message: &Message<'_>) -> Result<u16, String> {
        if let Some(pose) = RobotPose::sent_in(message) {
            self.pose = Some(pose);
        }
        self.device.send(message)
    }

    fn wait_for(
        &mut self,
        what: &str,
        done: impl FnMut(&HostLink, Option<&LinkEvent>) -> bool,
    ) -> Result<(), String> {
        let result = self.device.wait_for(what, done);
        // Rate-limited and non-blocking: the outputs never hold the device up.
        self.outputs.offer(self.device.link().mirror(), self.pose);
        result
    }

    fn link(&self) -> &HostLink {
        self.device.link()
    }

    fn frames_sent(&self) -> u64 {
        self.device.frames_sent()
    }

    fn idle(&mut self) {
        self.device.idle();
    }

    fn back_off(&mut self, round: u32) {
        self.device.back_off(round);
    }
}

//! The main computer's side of terrain-pyramid, as a library for the `pyramid` command, its
//! tests and the lab (`lab/`): the host link's decoder and mirror, the devices a host drives
//! (the library's co-processor in process, or the firmware on QEMU), the recording player,
//! the map export, and each command of `pyramid`.
//!
//! Nothing here simulates, injects faults or runs experiments: that is the lab's.

pub mod clock_sync;
pub mod decay;
pub mod decode;
pub mod design;
pub mod device;
pub mod emulator;
pub mod export;
pub mod ground_height;
pub mod json_line;
pub mod link;
pub mod listen;
pub mod play;
pub mod pose_input;
pub mod publish;
pub mod pyramid_args;
pub mod record;
pub mod record3dtk;
pub mod replay;
pub mod rig;
pub mod rigfile;
pub mod rule;
pub mod run;
pub mod serial;
pub mod stdout;
pub mod summary_args;
pub mod uos;

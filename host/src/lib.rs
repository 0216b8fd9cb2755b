//! The main computer's side of terrain-pyramid, as a library for the `pyramid` command and its
//! tests: the host link's decoder and layer mirror.

pub mod link;

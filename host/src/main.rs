//! `pyramid`: the main computer's command-line tool for terrain-pyramid.
fn main() {}

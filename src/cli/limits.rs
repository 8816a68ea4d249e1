//! The limits of the command line's own buffers, which its errors and arguments both name.

/// The most configurations `bench` takes.
pub(super) const MAX_BENCH_CONFIGURATIONS: usize = 1 << 16;

/// The most link frames (configurations times links) `bench` keeps: 2²³, 768 MiB of frames, so
/// that a robot with many links cannot make the batch rows exhaust memory.
pub(super) const MAX_BENCH_FRAMES: usize = 1 << 23;

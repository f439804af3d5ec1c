//! CPU time of the calling thread, for benches on a shared machine (where wall time overstates
//! the cost): Linux `/proc/thread-self/schedstat`, which may lag by a scheduler tick per read,
//! falling back to wall time elsewhere.

use std::time::{Duration, Instant};

/// CPU time the calling thread has run so far, when the OS tells (Linux).
fn thread_cpu_time() -> Option<Duration> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let nanos = text.split_whitespace().next()?.parse().ok()?;
    Some(Duration::from_nanos(nanos))
}

/// Runs `f` `iters` times on the calling thread and returns its CPU time (wall time when the
/// CPU time is not available).
pub fn cpu_time_of(iters: u64, mut f: impl FnMut()) -> Duration {
    let (cpu, wall) = (thread_cpu_time(), Instant::now());
    for _ in 0..iters {
        f();
    }
    match (cpu, thread_cpu_time()) {
        (Some(before), Some(after)) => after.saturating_sub(before),
        _ => wall.elapsed(),
    }
}

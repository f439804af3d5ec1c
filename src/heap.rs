//! Giving freed heap memory back to the operating system (docs/DECISIONS.md "Interreflection",
//! "Memory of the open-plan floor").
//!
//! The engine's links are built as thousands of runs on the worker threads and freed once the
//! operator holds them; glibc keeps such freed blocks in its per-thread arenas, where they count
//! towards the resident memory until something reuses them (on the open-plan floor ≈ 0.2 GB
//! that the larger blocks allocated later never reuse). [`release_free_memory`] asks the
//! allocator to return them. Elsewhere (other C libraries, other systems) it does nothing.

/// Returns the allocator's free memory to the operating system where the allocator supports it
/// (glibc's `malloc_trim`); costs a walk over the free lists (milliseconds).
pub fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    #[allow(unsafe_code)] // the crate's one foreign call (Cargo.toml denies unsafe code elsewhere)
    // SAFETY: `malloc_trim` only walks the allocator's own free lists and releases pages of free
    // chunks; it takes no pointers from us and is thread-safe (it locks each arena).
    unsafe {
        libc::malloc_trim(0);
    }
}

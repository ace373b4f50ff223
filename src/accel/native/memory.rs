//! Large arrays of the tree on huge pages: a 10^6-triangle tree spans tens
//! of megabytes, and with 4 KB pages most node visits miss the TLB.
//! Transparent huge pages are asked for with `madvise` before the memory is
//! first touched (Embree does the same for its own allocations).

/// An empty vector with room for `capacity` items; large ones ask the
/// kernel for 2 MB pages. Only a hint: nothing changes if it is refused.
pub fn reserve<T>(capacity: usize) -> Vec<T> {
    let v: Vec<T> = Vec::with_capacity(capacity);
    advise_huge_pages(v.as_ptr().cast(), capacity * std::mem::size_of::<T>());
    v
}

const HUGE_PAGE: usize = 2 << 20;

#[cfg(target_os = "linux")]
fn advise_huge_pages(start: *const u8, bytes: usize) {
    if bytes < 2 * HUGE_PAGE {
        return;
    }
    // The 2 MB-aligned part of the allocation.
    let begin = (start as usize).next_multiple_of(HUGE_PAGE);
    let end = (start as usize + bytes) / HUGE_PAGE * HUGE_PAGE;
    if end > begin {
        // SAFETY: the range lies inside a live allocation of `bytes` bytes
        // that this process owns; MADV_HUGEPAGE only changes how the kernel
        // backs it, never its contents, and a failure is harmless.
        unsafe {
            libc::madvise(begin as *mut libc::c_void, end - begin, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_start: *const u8, _bytes: usize) {}

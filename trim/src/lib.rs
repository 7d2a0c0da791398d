//! What a process hands back to the system when one of its phases is over
//! (the compile, the check, the start-up of a flight): the heap that phase
//! freed, and the pages of the program's code it ran.
//!
//! Most of an `eamos` process's resident set is the program's own code,
//! mapped from its file. The kernel counts every page a process has
//! touched (and the 64 kB around each, its fault-around) until the
//! process exits, although the page belongs to the page cache and comes
//! back from there as readily as at start-up. A ground station of 250
//! drones had mapped 16.5 MB of code by its flight, much of it the
//! parser's, the net compiler's and the checker's, which the flight never
//! runs again; the compile of the stress mission held the front end's
//! code through the net compiler and the slicer.
//!
//! This crate must never release a page the program wrote: only segments
//! loaded read-only from the file and never written are let go.

/// Hands back the heap freed so far and the program's read-only pages:
/// called at the end of a phase, once what the phase made and the next
/// does not need is dropped.
///
/// - The heap: glibc keeps freed memory for the process to reuse, and the
///   next phase reuses little of it: a ground station of 250 drones held
///   the check's 15 MB resident for the whole flight.
/// - The code: see [`release_code_pages`].
pub fn after_phase() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `malloc_trim` only hands free pages of the heap back to the
    // system; it may be called at any time, from any thread.
    unsafe {
        libc::malloc_trim(0);
    }
    release_code_pages();
}

/// Unmaps this program's read-only pages (code, constants, unwinding
/// tables) from the process; the page cache keeps them, and the next call
/// into a released page maps it again, as at start-up. What the next
/// phase runs comes back in its first moments; what only the phases
/// before ran stays out.
///
/// Only segments the program never writes are released (`PT_LOAD` without
/// `PF_W`): their pages are the file's, so dropping them loses nothing.
/// The relocated read-only data (RELRO) is written at start-up and then
/// write-protected: it belongs to a writable segment, and is kept. (A
/// debugger's breakpoint set in the code before this call is lost with its
/// page.)
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub fn release_code_pages() {
    /// For the first object of the list, the program itself.
    unsafe extern "C" fn release(
        info: *mut libc::dl_phdr_info,
        _size: libc::size_t,
        _data: *mut libc::c_void,
    ) -> libc::c_int {
        // SAFETY: the C library hands a valid record of a loaded object,
        // whose `dlpi_phnum` program headers start at `dlpi_phdr`.
        let info = unsafe { &*info };
        let headers = unsafe { std::slice::from_raw_parts(info.dlpi_phdr, info.dlpi_phnum.into()) };
        // SAFETY: sysconf only reads a constant of the system.
        let page = usize::try_from(unsafe { libc::sysconf(libc::_SC_PAGESIZE) }).unwrap_or(4096);
        for h in headers {
            if h.p_type != libc::PT_LOAD || h.p_flags & libc::PF_W != 0 {
                continue;
            }
            let (start, end) = whole_pages(info.dlpi_addr + h.p_vaddr, h.p_memsz, page);
            if end > start {
                // SAFETY: the range lies inside a loaded segment that is
                // mapped read-only from the program's file and never
                // written, so its pages read back unchanged from the file.
                unsafe {
                    libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_DONTNEED);
                }
            }
        }
        1 // the program only, not its shared libraries
    }
    // SAFETY: `release` reads only what the C library hands it.
    unsafe {
        libc::dl_iterate_phdr(Some(release), std::ptr::null_mut());
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub fn release_code_pages() {}

/// The pages that lie wholly inside a segment of `size` bytes at `address`:
/// a page shared with a neighbouring segment is not this one's to release.
#[cfg_attr(not(all(target_os = "linux", target_env = "gnu")), allow(dead_code))]
fn whole_pages(address: u64, size: u64, page: usize) -> (usize, usize) {
    let (address, size) = (address as usize, size as usize);
    (
        address.div_ceil(page) * page,
        (address + size) / page * page,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_pages_wholly_inside_a_segment_are_released() {
        assert_eq!(whole_pages(0x1000, 0x3000, 0x1000), (0x1000, 0x4000));
        assert_eq!(whole_pages(0x1280, 0x3000, 0x1000), (0x2000, 0x4000));
        assert_eq!(whole_pages(0x1280, 0x100, 0x1000), (0x2000, 0x1000));
    }
}

//! What a command that flies hands back to the system at the end of each
//! phase before the flight: the heap the compile and the check freed, and
//! the program's code pages that they and the start-up mapped.
//!
//! Most of a flying process's resident set is the program's own code,
//! mapped from its file: the kernel counts every page a process has
//! touched (and the 64 kB around each, its fault-around) until the process
//! exits. A ground station of 250 drones had mapped 16.5 MB of code by
//! its flight, a third of it the parser's, the net compiler's and the
//! checker's, which the flight never runs again.

use std::sync::atomic::{AtomicUsize, Ordering};

use eamos_exec::event::{Event, Kind, Sink};

/// Returns to the system what the compile and the check no longer use:
/// called by a command that flies once it has dropped what the flight does
/// not need of its mission (the net above all).
///
/// - The heap: glibc keeps freed memory for the process to reuse, and the
///   flight reuses little of it: a ground station of 250 drones held the
///   check's 15 MB resident for the whole flight. Called right after the
///   check instead, it left the net's memory resident: 34 MB while flying
///   against 23.
/// - The code: see [`release_code_pages`].
pub fn give_back_freed_memory() {
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
/// into a released page maps it again, as at start-up. What the flight
/// runs comes back within its first seconds; what only the compile and
/// the check ran stays out. A ground station of 250 drones flew at 21.3
/// MB instead of 24.2.
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

/// Does something once the flight is under way: when each of `executors`
/// has said it started. `eamos run` releases the code pages again then
/// ([`release_code_pages`]): starting up (the links, the peers'
/// liveliness, a router's sessions) runs code the flight does not run
/// again; a ground station of 250 drones flew at 16.6-18.4 MB instead of
/// 21.4.
pub struct OnceStarted<F> {
    waiting: AtomicUsize,
    then: F,
}

impl<F: Fn() + Send + Sync> OnceStarted<F> {
    pub fn new(executors: usize, then: F) -> Self {
        Self {
            waiting: AtomicUsize::new(executors),
            then,
        }
    }
}

impl<F: Fn() + Send + Sync> Sink for OnceStarted<F> {
    fn event(&self, e: &Event) {
        if matches!(e.kind, Kind::Started { .. })
            && self.waiting.fetch_sub(1, Ordering::Relaxed) == 1
        {
            (self.then)();
        }
    }
}

/// The pages that lie wholly inside a segment of `size` bytes at `address`:
/// a page shared with a neighbouring segment is not this one's to release.
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

    fn at(kind: Kind) -> Event {
        Event {
            time: 0.0,
            drone: "D1".into(),
            kind,
        }
    }

    fn started() -> Event {
        at(Kind::Started {
            mission: "M".into(),
            mission_id: "M-1".into(),
            places: 1,
            transitions: 1,
            bridges_in: 0,
            bridges_out: 0,
        })
    }

    #[test]
    fn it_acts_once_every_executor_has_started_and_never_again() {
        let acted = AtomicUsize::new(0);
        let sink = OnceStarted::new(3, || {
            acted.fetch_add(1, Ordering::Relaxed);
        });
        sink.event(&started());
        sink.event(&at(Kind::MissionEnded { by: "D1".into() }));
        sink.event(&started());
        assert_eq!(
            acted.load(Ordering::Relaxed),
            0,
            "one executor still starting"
        );
        sink.event(&started());
        assert_eq!(acted.load(Ordering::Relaxed), 1);
        sink.event(&started());
        assert_eq!(acted.load(Ordering::Relaxed), 1, "once");
    }

    #[test]
    fn only_pages_wholly_inside_a_segment_are_released() {
        assert_eq!(whole_pages(0x1000, 0x3000, 0x1000), (0x1000, 0x4000));
        assert_eq!(whole_pages(0x1280, 0x3000, 0x1000), (0x2000, 0x4000));
        assert_eq!(whole_pages(0x1280, 0x100, 0x1000), (0x2000, 0x1000));
    }

    /// Resident kilobytes of this program's executable mappings.
    #[cfg(target_os = "linux")]
    fn resident_code_kib() -> u64 {
        let exe = std::fs::read_link("/proc/self/exe").expect("Linux names the program");
        let smaps = std::fs::read_to_string("/proc/self/smaps").expect("Linux has smaps");
        let mut total = 0;
        let mut counting = false;
        for line in smaps.lines() {
            let fields: Vec<&str> = line.split_whitespace().collect();
            if fields
                .first()
                .is_some_and(|f| f.contains('-') && !f.ends_with(':'))
            {
                counting = fields.get(1) == Some(&"r-xp")
                    && fields.get(5).map(std::path::Path::new) == Some(exe.as_path());
            } else if counting && fields.first() == Some(&"Rss:") {
                total += fields[1].parse::<u64>().expect("a number of kB");
            }
        }
        total
    }

    /// The survey example compiled and checked: the compiler's and the
    /// checker's code, run once.
    fn survey_checked() -> String {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/survey.go");
        let text = std::fs::read_to_string(&path).expect("the example is in the repository");
        let source = eamos_lang::SourceFile::new(path.display().to_string(), text);
        let profiles = eamos_profile::builtin();
        let compiled = eamos_lang::compile(&source, &profiles).expect("the example compiles");
        let net = eamos_petri::compile(&compiled.mission, &profiles);
        let options = eamos_verify::Options::default();
        let report = eamos_verify::check_net(&net, &profiles, Some(&source.text), &options);
        format!("{} {:?}", net.graph.node_count(), report.findings)
    }

    #[test]
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    fn released_code_leaves_the_resident_set_and_the_program_runs_on() {
        let first = survey_checked();
        let before = resident_code_kib();
        release_code_pages();
        let after = resident_code_kib();
        assert!(
            after + 1024 < before,
            "{before} kB of code resident before, {after} kB after"
        );
        // The compiler and the checker come back from the file, and their
        // calls through vtables and function tables (relocated read-only
        // data, which is kept) land where they did.
        assert_eq!(survey_checked(), first);
    }
}

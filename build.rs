//! Link options of the `eamos` binary.
//!
//! Packed relative relocations (`DT_RELR`): the binary is a position-
//! independent executable whose pointers in read-only data (vtables, string
//! tables) are relocated at every start. As classic `RELA` entries they were
//! 42,000 records of 24 bytes, a megabyte that every process read before
//! `main`, and some 1.3 MB of every process's resident memory; packed, they
//! are 12 kB. Address randomisation is unchanged.
//!
//! glibc loads such a binary since 2.36, and refuses it before (the linker
//! records a version dependency on `GLIBC_ABI_DT_RELR`, so an older system
//! says so instead of crashing). The option is therefore given only for a
//! native build on a glibc that has it; a cross build, musl or another
//! system links as before.

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    if packed_relocations_load_here() {
        println!("cargo:rustc-link-arg-bins=-Wl,-z,pack-relative-relocs");
    }
}

/// Whether the binary being built runs on this machine's glibc, and that
/// glibc is 2.36 or newer.
fn packed_relocations_load_here() -> bool {
    let var = |k: &str| std::env::var(k).unwrap_or_default();
    if var("HOST") != var("TARGET")
        || var("CARGO_CFG_TARGET_OS") != "linux"
        || var("CARGO_CFG_TARGET_ENV") != "gnu"
    {
        return false;
    }
    glibc_version().is_some_and(|v| v >= (2, 36))
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn glibc_version() -> Option<(u32, u32)> {
    // SAFETY: glibc returns a pointer to a static, NUL-terminated string.
    let text = unsafe { std::ffi::CStr::from_ptr(libc::gnu_get_libc_version()) };
    let mut parts = text.to_str().ok()?.split('.');
    let major = parts.next()?.parse().ok()?;
    let minor = parts.next()?.parse().ok()?;
    Some((major, minor))
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn glibc_version() -> Option<(u32, u32)> {
    None
}

//! The `kinechain` command; everything it does lives in [`kinechain::cli`].

fn main() -> std::process::ExitCode {
    kinechain::cli::main_with(stdout::was_closed())
}

/// Whether the process started with its standard output closed (`kinechain fk ... >&-`). The
/// standard library reopens a closed standard output on `/dev/null` before `main`, after which
/// writes to it succeed and the results are lost without a word; a function in `.init_array`
/// runs before that and looks first.
#[cfg(target_os = "linux")]
mod stdout {
    use std::sync::atomic::{AtomicBool, Ordering};

    static CLOSED: AtomicBool = AtomicBool::new(false);

    extern "C" fn record() {
        // SAFETY: `fcntl(F_GETFD)` only asks about a descriptor number; it fails with EBADF
        // when nothing is open there.
        if unsafe { libc::fcntl(1, libc::F_GETFD) } == -1 {
            CLOSED.store(true, Ordering::Relaxed);
        }
    }

    #[used]
    #[unsafe(link_section = ".init_array")]
    static RECORD: extern "C" fn() = record;

    pub fn was_closed() -> bool {
        CLOSED.load(Ordering::Relaxed)
    }
}

#[cfg(not(target_os = "linux"))]
mod stdout {
    pub fn was_closed() -> bool {
        false
    }
}

//! The `kinechain` command; everything it does lives in [`kinechain::cli`].

fn main() -> std::process::ExitCode {
    kinechain::cli::main()
}

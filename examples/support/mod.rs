//! What every example shares: its robots' paths, and how it reports an error.

use std::path::PathBuf;
use std::process::ExitCode;

/// The bundled robot file `name` (in `robots/`), found from any working directory.
pub fn robot(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("robots")
        .join(name)
}

/// Runs an example's body; an error is printed with its causes, as the command line prints it.
pub fn main(run: fn() -> Result<(), Box<dyn std::error::Error>>) -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", kinechain::error::error_chain(e.as_ref()));
            ExitCode::FAILURE
        }
    }
}

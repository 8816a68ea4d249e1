//! The `kinechain` command line: argument parsing, library calls, output. `main.rs` only calls
//! [`main_with`]; each command is a file, and `run` dispatches to them.

mod args;
mod bag;
mod batch;
mod bench;
mod common;
mod error;
mod fk;
mod format;
mod ik;
mod info;
mod limits;
mod query;
mod regression;
mod run;

pub use run::{main, main_with};

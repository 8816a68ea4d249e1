//! The integration tests, one module per topic, in one test binary (one link of the library
//! instead of one per file). Tests that change process-wide state (the forced instruction
//! set, the global allocator) are test binaries of their own beside this one.

#[path = "../common/mod.rs"]
mod common;

#[cfg(feature = "logs")]
mod bag;
mod ball;
mod batch;
mod batch_arrays;
mod batch_jacobians;
mod batch_rates;
mod book_examples;
mod builder;
#[cfg(feature = "cli")]
mod cli;
mod convert;
#[cfg(feature = "cli")]
mod csv;
#[cfg(feature = "cli")]
mod docs;
mod evaluation_modes;
mod floating;
mod free;
mod fuzz_pass;
mod ik;
mod interop;
mod k_crosscheck;
mod layering;
mod loading_errors;
mod mjcf;
#[cfg(feature = "cli")]
mod outputs;
mod rates;
mod reference;
#[cfg(feature = "cli")]
mod regression;
mod relative;
mod render;
mod robots;
mod rotation;
mod state_errors;
#[cfg(feature = "reference")]
mod stress;
#[cfg(feature = "logs")]
mod tf;
mod urdf_reading;
mod view;
mod xacro;

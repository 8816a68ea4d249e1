//! The number layer under every kernel: the number traits, the lane and vector types of each
//! instruction set, `sin`/`cos`, and the runtime choice of instruction set. It uses nothing else
//! of the crate; inside it, each file uses only those listed before it.

pub(crate) mod fused;
pub(crate) mod isa;
pub(crate) mod lanes;
pub(crate) mod portable;
pub(crate) mod traits;
pub(crate) mod trig;

//! The compiled chain, as the kernels read it: its bodies ([`body`]), stored frames and rates
//! ([`stored`]), limit tables ([`limits`]) and the [`Chain`](chain::Chain) that holds them. Built
//! by [`crate::eval::compile`]; nothing here calls a kernel.

pub(crate) mod body;
pub mod chain;
pub(crate) mod limits;
pub(crate) mod stored;

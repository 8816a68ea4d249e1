//! The evaluation kernels: one body's step, in both vector forms. On lanes (`*_lanes`: eight
//! configurations at once, generic over the [`Num`](crate::eval::simd::traits::Num) they compute
//! with) for the batches, and on padded columns (`*_columns`: one configuration, four entries of
//! a frame per vector) for single configurations. One body is evaluated as
//! `frame = parent · pre · M(θ, d) · post` (eq. 2.119 for `M`).

pub(crate) mod ball;
pub(crate) mod floating;
pub(crate) mod frame;
pub(crate) mod joint;
pub(crate) mod pose_columns;
pub(crate) mod pose_lanes;
pub(crate) mod rates_columns;
pub(crate) mod rates_lanes;

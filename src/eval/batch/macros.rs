//! Macros the batch modules share: result-view lengths, a batch as a [`BlockEval`](super::fold::BlockEval),
//! and the limit-policy methods of the batch buffers.

/// `len` and `is_empty` of result views whose `data` counts the batch's configurations.
macro_rules! batch_len {
    ($($view:ident),*) => {
        $(
            impl $view<'_> {
                /// Number of configurations.
                #[must_use]
                pub fn len(&self) -> usize {
                    self.data.len
                }

                /// True for an empty batch.
                #[must_use]
                pub fn is_empty(&self) -> bool {
                    self.data.len == 0
                }
            }
        )*
    };
}

/// `$name`, the batch of the module invoking this, as [`BlockEval`]: its `BatchData`,
/// `BatchPoses` and `forward_kinematics_batch`, `$width` configurations per pass in frames of
/// `$frame`.
macro_rules! block_eval {
    ($name:ident, $width:expr, $frame:ty) => {
        struct $name;

        impl $crate::eval::batch::fold::BlockEval for $name {
            type Data = BatchData;
            type Poses<'a> = BatchPoses<'a>;
            const WIDTH: usize = $width;
            const CHUNK_BYTES: usize = std::mem::size_of::<$frame>();
            fn data(chain: &Chain, policy: LimitPolicy) -> BatchData {
                BatchData::new(chain).with_limit_policy(policy)
            }
            fn poses<'a>(
                chain: &'a Chain,
                data: &'a mut BatchData,
                qs: &[f64],
            ) -> Result<BatchPoses<'a>, BatchError> {
                forward_kinematics_batch(chain, data, qs)
            }
        }
    };
}

/// The limit-policy methods of a `BatchData` (`f64` or `f32`), inside its `impl` block; the
/// type keeps its policy in a field `limit_policy`.
macro_rules! limit_policy_methods {
    () => {
        /// These buffers, with evaluations checking joint limits under `policy` (as
        /// [`BatchData::set_limit_policy`] sets it), in one expression:
        /// `BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore)`.
        #[must_use]
        pub fn with_limit_policy(mut self, policy: LimitPolicy) -> Self {
            self.set_limit_policy(policy);
            self
        }

        /// Chooses whether evaluations check joint limits (default [`LimitPolicy::Enforce`]).
        pub fn set_limit_policy(&mut self, policy: LimitPolicy) {
            self.limit_policy = policy;
        }

        /// The limit policy in force.
        #[must_use]
        pub fn limit_policy(&self) -> LimitPolicy {
            self.limit_policy
        }
    };
}

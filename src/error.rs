//! Typed errors: what loading a file can fail with ([`LoadError`]), what building a chain can
//! fail with ([`ModelError`]), what an evaluation can fail with ([`StateError`]), a name a chain
//! does not have ([`NameError`]); and [`Error`], any of them, for `?` across all.

pub use crate::eval::error::StateError;
pub use crate::io::error::{FieldProblem, LoadError, LoadErrorKind};
pub use crate::model::error::{
    MAX_SUGGESTED_NAME, ModelError, NameError, closest_name, escape_controls,
};

/// An error and its sources on one line, `error: source: source…`, with any line breaks of
/// their messages turned into spaces.
///
/// Each error of this crate displays only its own layer (a [`LoadError`] says which file, its
/// source what went wrong in it), as Rust errors do; this is the whole story for a log line or
/// a message to a user.
///
/// ```
/// let e = kinechain::Chain::from_file("no/such/robot.urdf").unwrap_err();
/// assert_eq!(e.to_string(), "cannot load no/such/robot.urdf");
/// let line = kinechain::error::error_chain(&e);
/// assert!(line.starts_with("cannot load no/such/robot.urdf: "), "{line}");
/// ```
#[must_use]
pub fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text.push_str(": ");
        text.push_str(&s.to_string());
        source = s.source();
    }
    escape_controls(&text.replace('\n', " ")).into_owned()
}

/// Any error of the crate, so that `?` works across loading, evaluating, batches, joint vectors
/// read from text and writing URDF. Each variant holds the specific error, for those who match
/// on it; its message is that error's.
///
/// ```
/// fn tool_height(path: &str) -> Result<f64, kinechain::Error> {
///     let chain = kinechain::Chain::from_file(path)?; // LoadError
///     let mut data = kinechain::Data::new(&chain);
///     let q = kinechain::io::input::joint_vector_from_str(&chain, "0 0 0 0 0 0", "q")?;
///     let poses = kinechain::forward_kinematics(&chain, &mut data, &q)?; // StateError
///     Ok(poses.world_from_link(chain.link_id("link6")?).translation().z) // NameError
/// }
/// assert!(tool_height("robots/puma560.yaml")? > 0.0);
/// assert!(matches!(tool_height("robots/missing.yaml"), Err(kinechain::Error::Load(_))));
/// # Ok::<(), kinechain::Error>(())
/// ```
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A robot file could not be loaded.
    #[error(transparent)]
    Load(#[from] LoadError),
    /// A description handed to the builder is not a valid chain.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A configuration cannot be evaluated.
    #[error(transparent)]
    State(#[from] StateError),
    /// A batch of configurations cannot be evaluated.
    #[error(transparent)]
    Batch(#[from] crate::eval::batch::BatchError),
    /// A link or joint name the chain does not have.
    #[error(transparent)]
    Name(#[from] NameError),
    /// A joint-space vector could not be read from text.
    #[error(transparent)]
    Input(#[from] crate::io::input::InputError),
    /// The chain cannot be written as URDF.
    #[error(transparent)]
    Convert(#[from] crate::io::convert::ConvertError),
    /// A regression record, verification or comparison could not be made.
    #[error(transparent)]
    Regression(#[from] crate::regression::RegressionError),
    /// An inverse-kinematics problem or solve that cannot be posed.
    #[error(transparent)]
    Ik(#[from] crate::ik::IkError),
}

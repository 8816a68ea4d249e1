//! What an evaluation can fail with: a joint-space vector that cannot be evaluated.

/// A joint-space vector (`q`, `q_dot`, `q_ddot`) cannot be evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StateError {
    /// The vector has the wrong number of entries.
    #[error("{what} has {got} entries, the chain has {expected} degrees of freedom")]
    WrongLength {
        /// `q`, `q_dot` or `q_ddot`.
        what: &'static str,
        /// Entries expected (the chain's dof).
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// A vector of a chain with a floating or ball joint has the wrong number of entries.
    #[error(
        "{what} has {got} entries; the chain takes {expected}: {}{} for the others",
        shares(parts),
        expected - parts.iter().map(|p| p.1).sum::<usize>()
    )]
    WrongLengthParts {
        /// `q`, `q_dot` or `q_ddot`.
        what: &'static str,
        /// Entries expected ([`Model::nq`](crate::Model::nq) or [`Model::nv`](crate::Model::nv)).
        expected: usize,
        /// Entries given.
        got: usize,
        /// The joints that take several entries each for one rotation (the floating joint: 7 of
        /// `q`, 6 of a rate; a ball joint: 4 and 3), with their kinds and entries.
        parts: Vec<(String, usize, &'static str)>,
    },
    /// A floating or ball joint's quaternion is not one the kernels evaluate: zero, or off unit length
    /// by more than [`QUATERNION_TOLERANCE`](crate::QUATERNION_TOLERANCE).
    #[error(
        "the quaternion of {kind} joint '{joint}' (q[{first}..{}], w x y z) has norm {norm}: it must be within {tolerance} of 1 (it is then normalised)",
        first + 4
    )]
    BadQuaternion {
        /// The floating or ball joint.
        joint: String,
        /// `floating` or `ball`.
        kind: &'static str,
        /// The index of the quaternion's first entry (w) in `q`.
        first: usize,
        /// The quaternion's norm.
        norm: f64,
        /// How far from 1 the norm may be.
        tolerance: f64,
    },
    /// A vector in another library's layout has the wrong number of entries.
    #[error("{what} in the {layout} layout has {got} entries; the chain takes {expected} there")]
    LayoutLength {
        /// The layout (`pinocchio`, `mujoco`).
        layout: &'static str,
        /// `q`, `q_dot` or `q_ddot`.
        what: &'static str,
        /// Entries expected.
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// A joint asked for as a screw (θ and d about one axis) that is not one.
    #[error("joint '{joint}' turns by a quaternion: its motion is not a screw about one axis")]
    NoScrew {
        /// The joint.
        joint: String,
    },
    /// An entry is NaN or infinite.
    #[error(
        "{what}[{index}] (joint '{joint}'{}) is {value}, not a finite number",
        component_suffix(component)
    )]
    NonFinite {
        /// `q`, `q_dot` or `q_ddot`.
        what: &'static str,
        /// Index in the vector.
        index: usize,
        /// The joint this entry drives.
        joint: String,
        /// For a joint of several entries, the component (`theta` or `d` of a cylindrical joint,
        /// `x` … `qz` or `vx` … `wz` of a floating one).
        component: Option<&'static str>,
        /// The value given.
        value: f64,
    },
    /// A batch's `q_dot` or `q_ddot` does not hold one row of the chain's dof per configuration
    /// of its `q`.
    #[error(
        "{what} has {got} entries, the batch's q has {rows} configurations, each of {dof} entries in {what}"
    )]
    WrongRows {
        /// `q_dot` or `q_ddot`.
        what: &'static str,
        /// Configurations in `q`.
        rows: usize,
        /// Entries of `q_dot` (and `q_ddot`) per configuration: the chain's dof.
        dof: usize,
        /// Entries given.
        got: usize,
    },
    /// A caller's output buffer for a batch has the wrong length.
    #[error("the output has {got} entries, the batch needs {expected}")]
    OutputLength {
        /// Entries needed.
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// A batch for a chain without moving joints: its configurations have no entries, so a flat
    /// batch cannot say how many it holds. Evaluate such a chain once, with
    /// [`forward_kinematics`](crate::forward_kinematics).
    #[error(
        "the chain has no moving joints, so a batch cannot tell how many configurations it holds \
         (evaluate it once with forward_kinematics)"
    )]
    NoDegreesOfFreedom,
    /// A joint value is outside the joint's limits.
    #[error("joint '{joint}'{} = {value} is outside its limits [{lower}, {upper}]{}", component_suffix(component), hint(*value, *lower, *upper, *angular))]
    OutOfLimits {
        /// The joint.
        joint: String,
        /// For a cylindrical joint, `theta` or `d`.
        component: Option<&'static str>,
        /// Whether the coordinate is an angle (rad) rather than a length (m). Only an angle's
        /// message suggests that the value may have been given in degrees.
        angular: bool,
        /// The value (for a mimic joint, the value implied by its primary joint).
        value: f64,
        /// Lower limit.
        lower: f64,
        /// Upper limit.
        upper: f64,
    },
}

/// `7 for the floating joint 'root', 4 for the ball joint 'hip', ` (each part and a comma).
fn shares(parts: &[(String, usize, &'static str)]) -> String {
    parts
        .iter()
        .map(|(joint, n, kind)| format!("{n} for the {kind} joint '{joint}', "))
        .collect()
}

fn component_suffix(c: &Option<&'static str>) -> String {
    c.map(|c| format!(" {c}")).unwrap_or_default()
}

/// The degrees hint: for an angle beyond a full turn whose value read as degrees is within the
/// limits.
fn hint(value: f64, lower: f64, upper: f64, angular: bool) -> &'static str {
    let deg = value.to_radians();
    if angular && value.abs() > 2.0 * std::f64::consts::PI && deg >= lower && deg <= upper {
        " (the value looks like degrees; angles are in radians)"
    } else {
        ""
    }
}

//! Writing a chain as URDF (`kinechain convert`): DH tables (standard, modified) and the axis
//! form become URDF joints whose link frames are exactly those of the original, so the two
//! models agree link for link.
//!
//! Each joint becomes a URDF joint with origin `origin · Rot(v, θ₀) · Trans(v d₀)` (the offsets
//! at q = 0; they commute with the motion along the same axis), so its URDF joint value is `q`.
//! A constant placement after the motion (standard DH: `Tx(a) Rx(α)`) becomes a fixed joint from
//! a massless link `<joint>_motion` to the original child link. A cylindrical joint becomes a
//! revolute joint `<joint>` and a prismatic joint `<joint>_d` on the same axis through a massless
//! link `<joint>_theta` (its two entries of `q` keep their order). A root placement becomes a fixed
//! joint from a new root link. Limits are carried over; mimic joints keep their mimic element.
//!
//! The model holds kinematics only: links are written without `<inertial>` (URDF's massless
//! frame), and a `<limit>`'s required effort and velocity as 0, which a comment at the top of the
//! file states. Fixed and continuous joints get no `<limit>`, and fixed joints no `<axis>`.

use crate::eval::Chain;

use crate::model::builder::JointSpec;
use crate::model::joint::{JointKind, Limits};
use crate::model::transform::Transform;
use crate::orientation::Rpy;
use crate::orientation::normalize_axis;
use nalgebra::{Unit, Vector3};
use std::fmt::Write as _;

/// A chain that URDF cannot express.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ConvertError {
    /// URDF requires limits on prismatic joints.
    #[error(
        "joint '{joint}': a prismatic coordinate without limits cannot be written as URDF (add limits)"
    )]
    UnlimitedPrismatic {
        /// The joint.
        joint: String,
    },
    /// URDF has no ball joint.
    #[error(
        "joint '{joint}' is a ball joint, which URDF cannot write (it has no joint that turns by a quaternion)"
    )]
    BallJoint {
        /// The joint.
        joint: String,
    },
    /// A name holds a character that an XML file cannot contain.
    #[error(
        "the name {name:?} holds the character U+{:04X}, which an XML file cannot contain",
        u32::from(*character)
    )]
    NotXml {
        /// The name.
        name: String,
        /// The character.
        character: char,
    },
    /// A generated link or joint name collides with an existing one.
    #[error("the generated name '{name}' is already used in the model")]
    NameClash {
        /// The name.
        name: String,
    },
    /// The URDF would be larger than [`MAX_FILE_BYTES`](crate::io::MAX_FILE_BYTES), the most
    /// kinechain reads back.
    #[error(
        "the URDF would be {size} bytes, more than the {limit} bytes that kinechain reads back (MAX_FILE_BYTES): not written",
        limit = crate::io::MAX_FILE_BYTES
    )]
    TooLarge {
        /// Its size in bytes.
        size: usize,
    },
}

/// `(xyz, rpy)` of a rigid transform, rpy as URDF reads it (`R = Rz(yaw) Ry(pitch) Rx(roll)`);
/// at pitch = ±π/2 exactly, roll is set to 0 and yaw carries the whole rotation about z.
fn xyz_rpy(t: &Transform) -> ([f64; 3], [f64; 3]) {
    let a = t.rotation();
    let rpy = match Rpy::from_matrix(&a) {
        Ok(r) => [r.roll, r.pitch, r.yaw],
        Err(_) => {
            // R = Rz(y) Ry(±π/2) with roll 0: a12 = −sin y, a22 = cos y.
            let pitch = if a[(2, 0)] < 0.0 {
                std::f64::consts::FRAC_PI_2
            } else {
                -std::f64::consts::FRAC_PI_2
            };
            [0.0, pitch, (-a[(0, 1)]).atan2(a[(1, 1)])]
        }
    };
    (t.p, rpy)
}

/// Three numbers as a URDF attribute value, each the shortest text that reads back as the same
/// `f64`; `+ 0.0` turns −0 into 0, which would otherwise show as `-0`.
fn triple(x: [f64; 3]) -> String {
    let [a, b, c] = x.map(|x| x + 0.0);
    format!("{a} {b} {c}")
}

/// `text` for an attribute value ([`crate::io::xml::escape`]).
///
/// # Errors
/// [`ConvertError::NotXml`] for a character that no XML 1.0 document can hold.
fn escaped(text: &str) -> Result<String, ConvertError> {
    crate::io::xml::escape(text).map_err(|character| ConvertError::NotXml {
        name: text.to_string(),
        character,
    })
}

/// The transform `Rot(v, θ) Trans(v d)` of a motion with constant θ and d.
fn screw(axis: [f64; 3], theta: f64, d: f64) -> Transform {
    let v = normalize_axis(axis).unwrap_or([0.0, 0.0, 1.0]);
    let u = Unit::new_unchecked(Vector3::from(v));
    Transform::from_parts(
        &crate::orientation::rotation_matrix(&u, theta),
        &(u.into_inner() * d),
    )
}

/// The URDF joint types a chain is written with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum UrdfType {
    Revolute,
    Continuous,
    Prismatic,
    Fixed,
    Floating,
}

impl UrdfType {
    fn name(self) -> &'static str {
        match self {
            UrdfType::Revolute => "revolute",
            UrdfType::Continuous => "continuous",
            UrdfType::Prismatic => "prismatic",
            UrdfType::Fixed => "fixed",
            UrdfType::Floating => "floating",
        }
    }
}

/// The links and joints written so far, as URDF text, and the names taken.
struct Writer {
    links: String,
    joints: String,
    names: std::collections::HashSet<String>,
}

impl Writer {
    fn fresh_link(&mut self, name: String) -> Result<String, ConvertError> {
        if !self.names.insert(format!("link:{name}")) {
            return Err(ConvertError::NameClash { name });
        }
        let _ = writeln!(self.links, "  <link name=\"{}\"/>", escaped(&name)?);
        Ok(name)
    }

    /// Writes a joint: its `<axis>` unless it is fixed, a `<limit>` when it has limits (a
    /// revolute or prismatic joint), and its `<mimic>`.
    #[allow(clippy::too_many_arguments)]
    fn joint(
        &mut self,
        name: String,
        kind: UrdfType,
        parent: &str,
        child: &str,
        origin: &Transform,
        axis: [f64; 3],
        limits: Option<Limits>,
        mimic: Option<&crate::model::builder::MimicSpec>,
    ) -> Result<(), ConvertError> {
        if !self.names.insert(format!("joint:{name}")) {
            return Err(ConvertError::NameClash { name });
        }
        // (Writing to a `String` cannot fail.)
        let (xyz, rpy) = xyz_rpy(origin);
        let text = &mut self.joints;
        let _ = write!(
            text,
            "  <joint name=\"{}\" type=\"{}\">\n    <origin xyz=\"{}\" rpy=\"{}\"/>\n    \
             <parent link=\"{}\"/>\n    <child link=\"{}\"/>\n",
            escaped(&name)?,
            kind.name(),
            triple(xyz),
            triple(rpy),
            escaped(parent)?,
            escaped(child)?,
        );
        if !matches!(kind, UrdfType::Fixed | UrdfType::Floating) {
            let _ = writeln!(text, "    <axis xyz=\"{}\"/>", triple(axis));
        }
        if let Some(Limits { lower, upper }) = limits {
            let _ = writeln!(
                text,
                "    <limit lower=\"{lower}\" upper=\"{upper}\" effort=\"0\" velocity=\"0\"/>"
            );
        }
        if let Some(m) = mimic {
            let _ = writeln!(
                text,
                "    <mimic joint=\"{}\" multiplier=\"{}\" offset=\"{}\"/>",
                escaped(&m.joint)?,
                m.multiplier,
                m.offset
            );
        }
        text.push_str("  </joint>\n");
        Ok(())
    }
}

fn moving_kind(
    kind: JointKind,
    limits: Option<Limits>,
    joint: &str,
) -> Result<UrdfType, ConvertError> {
    Ok(match (kind, limits) {
        (JointKind::Prismatic, Some(_)) => UrdfType::Prismatic,
        (JointKind::Prismatic, None) => {
            return Err(ConvertError::UnlimitedPrismatic {
                joint: joint.to_string(),
            });
        }
        (_, Some(_)) => UrdfType::Revolute,
        (_, None) => UrdfType::Continuous,
    })
}

/// The chain as URDF text; its links keep their names and poses.
///
/// # Errors
/// [`ConvertError`] for a ball joint (URDF has none), a prismatic joint without limits (URDF requires them), a generated
/// name that clashes with an existing one, or a name holding a character that XML cannot (a
/// control character other than tab, line feed and carriage return), or a URDF larger than
/// [`MAX_FILE_BYTES`](crate::io::MAX_FILE_BYTES), which kinechain would not read back.
pub fn to_urdf(chain: &Chain) -> Result<String, ConvertError> {
    let d = chain.description();
    let mut w = Writer {
        links: String::new(),
        joints: String::new(),
        names: std::collections::HashSet::new(),
    };
    for l in d.links() {
        w.fresh_link(l.clone())?;
    }
    if let Some(root) = d.root_placement().filter(|t| *t != Transform::IDENTITY) {
        let root_link = chain.links()[0].name().to_string();
        let world = w.fresh_link(format!("{root_link}_world"))?;
        w.joint(
            format!("{root_link}_placement"),
            UrdfType::Fixed,
            &world,
            &root_link,
            &root,
            [1.0, 0.0, 0.0],
            None,
            None,
        )?;
    }
    for js in d.joints() {
        write_joint(&mut w, js)?;
    }
    let text = format!(
        "<robot name=\"{}\">\n{KINEMATICS_ONLY}{}{}</robot>\n",
        escaped(chain.name())?,
        w.links,
        w.joints
    );
    if text.len() as u64 > crate::io::MAX_FILE_BYTES {
        return Err(ConvertError::TooLarge { size: text.len() });
    }
    Ok(text)
}

/// The comment at the top of every file [`to_urdf`] writes, so that a reader of the file alone
/// (a planner taking its velocity limits, say) learns that the zeros are not data.
const KINEMATICS_ONLY: &str = "  <!-- Kinematics only, as written by kinechain convert: links carry no \
     mass or inertia, and each limit's effort and velocity are 0 because the model has none \
     (URDF requires the attributes). -->\n";

/// What the URDF `text` holds that [`to_urdf`] does not write, since the model keeps kinematics
/// only: visual and collision elements, links' masses and inertias, joints' effort and velocity
/// limits, dynamics, calibration and safety controllers, and materials. `None` when it holds none
/// of these (a file that `to_urdf` wrote, for one) or cannot be read. The command line's
/// `convert` prints it, so that the user knows what the written file leaves out.
#[cfg(feature = "cli")]
pub(crate) fn dropped_from_urdf(text: &str) -> Option<String> {
    beyond_kinematics(text)
}

fn write_joint(w: &mut Writer, js: &JointSpec) -> Result<(), ConvertError> {
    let axis = normalize_axis(js.axis).unwrap_or([0.0, 0.0, 1.0]);
    let origin = js.origin * screw(axis, js.theta, js.d);
    let has_post = js.post != Transform::IDENTITY;
    if js.kind == JointKind::Fixed {
        return w.joint(
            js.name.clone(),
            UrdfType::Fixed,
            &js.parent,
            &js.child,
            &(origin * js.post),
            [1.0, 0.0, 0.0],
            None,
            None,
        );
    }
    // The frame right after the motion: the child itself, or a massless link before `post`.
    let after_motion = if has_post {
        w.fresh_link(format!("{}_motion", js.name))?
    } else {
        js.child.clone()
    };
    if js.kind == JointKind::Cylindrical {
        let middle = w.fresh_link(format!("{}_theta", js.name))?;
        let kind = moving_kind(JointKind::Revolute, js.limits[0], &js.name)?;
        w.joint(
            js.name.clone(),
            kind,
            &js.parent,
            &middle,
            &origin,
            axis,
            js.limits[0],
            None,
        )?;
        let d_name = format!("{}_d", js.name);
        let kind = moving_kind(JointKind::Prismatic, js.limits[1], &d_name)?;
        w.joint(
            d_name,
            kind,
            &middle,
            &after_motion,
            &Transform::IDENTITY,
            axis,
            js.limits[1],
            None,
        )?;
    } else if js.kind == JointKind::Ball {
        return Err(ConvertError::BallJoint {
            joint: js.name.clone(),
        });
    } else if js.kind == JointKind::Floating {
        w.joint(
            js.name.clone(),
            UrdfType::Floating,
            &js.parent,
            &after_motion,
            &origin,
            axis,
            None,
            None,
        )?;
    } else {
        let kind = moving_kind(js.kind, js.limits[0], &js.name)?;
        w.joint(
            js.name.clone(),
            kind,
            &js.parent,
            &after_motion,
            &origin,
            axis,
            js.limits[0],
            js.mimic.as_ref(),
        )?;
    }
    if has_post {
        w.joint(
            format!("{}_post", js.name),
            UrdfType::Fixed,
            &after_motion,
            &js.child,
            &js.post,
            [1.0, 0.0, 0.0],
            None,
            None,
        )?;
    }
    Ok(())
}

/// Counts what a URDF file holds beyond its kinematics (visual and collision elements, masses,
/// materials, transmissions, Gazebo and other extension elements, joints' effort and velocity
/// limits and their dynamics, calibration and safety data), as a phrase such as `"12 visual
/// elements, 3 materials"`; `None` when it holds none of these or cannot be read.
#[cfg(feature = "cli")]
fn beyond_kinematics(source: &str) -> Option<String> {
    use roxmltree::{Document, Node};
    let doc = Document::parse(source).ok()?;
    let robot = doc.root_element();
    let count = |n: usize, what: &str| (n > 0).then(|| format!("{n} {what}"));
    let children = |node: Node<'_, '_>, name: &str| {
        node.children()
            .filter(move |c| c.is_element() && c.tag_name().name() == name)
            .count()
    };
    let elements = |name: &str| children(robot, name);
    let links = || {
        robot
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "link")
    };
    let joints = || {
        robot
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "joint")
    };
    let parts: Vec<String> = [
        count(
            links().map(|l| children(l, "visual")).sum(),
            "visual elements",
        ),
        count(
            links().map(|l| children(l, "collision")).sum(),
            "collision elements",
        ),
        count(
            links()
                .filter(|l| {
                    // A link whose masses and inertias are all zero holds no data to drop.
                    l.descendants().filter(Node::is_element).any(|e| {
                        e.attributes().any(|a| {
                            ["value", "ixx", "ixy", "ixz", "iyy", "iyz", "izz"].contains(&a.name())
                                && e.ancestors().any(|p| p.tag_name().name() == "inertial")
                                && a.value().trim().parse::<f64>() != Ok(0.0)
                        })
                    })
                })
                .count(),
            "links' masses and inertias",
        ),
        count(
            joints()
                .filter(|j| {
                    j.children().any(|c| {
                        c.is_element()
                            && c.tag_name().name() == "limit"
                            && ["effort", "velocity"].iter().any(|a| {
                                c.attribute(*a)
                                    .is_some_and(|v| v.trim().parse::<f64>() != Ok(0.0))
                            })
                    })
                })
                .count(),
            "joints' effort and velocity limits",
        ),
        count(
            joints()
                .filter(|j| {
                    ["dynamics", "calibration", "safety_controller"]
                        .iter()
                        .any(|e| children(*j, e) > 0)
                })
                .count(),
            "joints' dynamics, calibration or safety controller elements",
        ),
        count(elements("material"), "materials"),
        count(elements("transmission"), "transmissions"),
        count(
            robot
                .children()
                .filter(|c| {
                    c.is_element()
                        && !["link", "joint", "material", "transmission"]
                            .contains(&c.tag_name().name())
                })
                .count(),
            "other elements (Gazebo, ros2_control and the like)",
        ),
    ]
    .into_iter()
    .flatten()
    .collect();
    (!parts.is_empty()).then(|| parts.join(", "))
}

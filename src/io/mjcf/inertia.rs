//! MuJoCo's free-joint alignment (`<compiler alignfree>`, `<freejoint align>`): a body whose only
//! joint is free and that has no child bodies gets its inertial frame as its body frame, and
//! what it holds moves the other way, so that everything stays where it was at `qpos0` but the
//! body's own frame (and `qpos`) is the inertial one.
//!
//! The inertial frame is read as MuJoCo's compiler makes it: the `<inertial>` element's `pos`
//! and orientation, or, when the inertia comes from the geoms (no `<inertial>`, or
//! `inertiafromgeom="true"`), the frame of the one geom that has mass (in the groups
//! `inertiagrouprange` names). Where MuJoCo would compute it from principal axes (a
//! `fullinertia`, several geoms with mass) or from a mesh's own frame, kinechain refuses the
//! model with an error naming the body: it neither guesses that frame nor leaves the body where
//! MuJoCo does not put it.

use super::attrs::{Kind, Pose, boolean, fromto, placement, reals};
use super::scene::{Body, Item, Source};
use super::tree::Problem;

/// Smallest mass MuJoCo counts for a geom (`mjEPS`).
const MIN_MASS: f64 = 1e-14;

/// The inertial frame `body` is moved onto (in its own frame), if the alignment applies to it.
pub(super) fn align(body: &Body<'_>, source: &Source) -> Result<Option<Pose>, Problem> {
    let [joint] = body.joints.as_slice() else {
        return Ok(None);
    };
    if body.children > 0 || !is_free(joint, source) {
        return Ok(None);
    }
    let wanted = match joint.el.attribute("align") {
        Some(("auto", _)) | None => source.compiler.alignfree,
        Some((v, at)) => boolean(v, at, "align")?,
    };
    if !wanted {
        return Ok(None);
    }
    inertial_frame(body, source).map(Some)
}

fn is_free(joint: &Item<'_>, source: &Source) -> bool {
    if joint.el.name == "freejoint" {
        return true;
    }
    let class = joint
        .el
        .attribute("class")
        .map_or(joint.class.as_str(), |(c, _)| c);
    source
        .defaults
        .value(joint.el, Kind::Joint, class, "type")
        .is_some_and(|(t, _)| t == "free")
}

/// Where the body's inertial frame is in its body frame.
fn inertial_frame(body: &Body<'_>, source: &Source) -> Result<Pose, Problem> {
    let name = body
        .item
        .name
        .as_ref()
        .map_or_else(|| "unnamed".to_string(), |n| format!("'{n}'"));
    let refuse = |at, why: String| {
        Problem::at(
            at,
            format!(
                "body {name}: its free joint is aligned with its inertial frame (alignfree), and {why}; \
                 kinechain does not compute principal axes: give the body an <inertial> with pos and \
                 an orientation, or align=\"false\""
            ),
        )
    };
    let from_geoms = match source.compiler.inertiafromgeom {
        Some(always) => always,
        None => body.inertial.is_none(),
    };
    if !from_geoms {
        let Some(inertial) = &body.inertial else {
            return Err(refuse(
                body.item.el.at,
                "it has no <inertial> and inertiafromgeom is false".to_string(),
            ));
        };
        let el = inertial.el;
        if let Some((_, at)) = el.attribute("fullinertia") {
            return Err(refuse(
                at,
                "its <inertial> gives a fullinertia, whose principal axes are that frame"
                    .to_string(),
            ));
        }
        let (p, q) = placement(el, |a| el.attribute(a), &source.compiler)?;
        return Ok(inertial.frame.then(&Pose { p, q }));
    }
    let mut massive = Vec::new();
    for geom in &body.geoms {
        if let Some(frame) = massive_geom(geom, source)? {
            massive.push((geom, frame));
        }
    }
    match massive.as_slice() {
        [(_, frame)] => Ok(*frame),
        [] => Err(refuse(body.item.el.at, "no geom gives it mass".to_string())),
        [_, (second, _), ..] => Err(refuse(
            second.el.at,
            format!("{} geoms give it mass", massive.len()),
        )),
    }
}

/// The frame of `geom` in its body if it counts for the body's inertia (its group within
/// `inertiagrouprange`, a mass above `mjEPS`), else `None`.
fn massive_geom(geom: &Item<'_>, source: &Source) -> Result<Option<Pose>, Problem> {
    let el = geom.el;
    let class = source.defaults.class_of(el, &geom.class)?;
    let get = |n: &str| source.defaults.value(el, Kind::Geom, class, n);
    let number = |n: &str, default: f64| -> Result<f64, Problem> {
        match get(n) {
            Some((v, at)) => Ok(reals::<1>(v, at, n)?[0]),
            None => Ok(default),
        }
    };
    let group = number("group", 0.0)?;
    let [lo, hi] = source.compiler.inertiagrouprange;
    if group < lo as f64 || group > hi as f64 {
        return Ok(None);
    }
    let kind = get("type").map_or("sphere", |(t, _)| t);
    let size = match get("size") {
        Some((v, at)) => {
            let mut s = super::attrs::real_list(v, at, "size")?;
            s.resize(3, 0.0);
            [s[0], s[1], s[2]]
        }
        None => [0.0; 3],
    };
    let placed = match get("fromto") {
        Some((v, at)) => {
            let pose = fromto(v, at)?;
            let half = {
                let [a, b, c, d, e, f] = reals::<6>(v, at, "fromto")?;
                ((a - d).powi(2) + (b - e).powi(2) + (c - f).powi(2)).sqrt() / 2.0
            };
            Some((pose, half))
        }
        None => None,
    };
    // Whether the geom has a volume (or an area, for shell inertia) to carry a density.
    let extent = |s: [f64; 3]| match kind {
        "sphere" => s[0] > 0.0,
        "capsule" | "cylinder" => s[0] > 0.0 && s[1] >= 0.0,
        "ellipsoid" | "box" => s.iter().all(|&x| x > 0.0),
        _ => false,
    };
    let size = match (placed, kind) {
        (Some((_, half)), "capsule" | "cylinder") => [size[0], half, 0.0],
        (Some((_, half)), "box" | "ellipsoid") => [size[0], size[0], half],
        _ => size,
    };
    let mass = match get("mass") {
        Some((v, at)) => reals::<1>(v, at, "mass")?[0],
        None if matches!(kind, "mesh" | "sdf" | "hfield") || get("mesh").is_some() => {
            number("density", 1000.0)?
        }
        None if extent(size) => number("density", 1000.0)?,
        None => 0.0,
    };
    if mass <= MIN_MASS {
        return Ok(None);
    }
    if matches!(kind, "mesh" | "sdf" | "hfield") || get("mesh").is_some() {
        return Err(Problem::at(
            el.at,
            "a free body aligned with its inertial frame (alignfree) has a mesh geom with mass: \
             its inertial frame is the mesh's, which kinechain does not read; give the body an \
             <inertial> with pos and an orientation, or align=\"false\"",
        ));
    }
    let pose = match placed {
        Some((pose, _)) => pose,
        None => {
            let (p, q) = placement(el, get, &source.compiler)?;
            Pose { p, q }
        }
    };
    Ok(Some(geom.frame.then(&pose)))
}

//! `kinechain view`: one self-contained HTML page that draws the robot as a stick figure with
//! every link's frame, evaluates the chain itself from the constants written into it (so its
//! joint sliders and its timeline move the robot without a server), and says in its DOM where
//! each link is, for tests and for a user who wants the numbers.
//!
//! The page holds the tree (`parent · origin · M(θ, d) · post` per joint, eq. 2.119, with the
//! joint's axis, offsets, `q` index and mimic coupling), the limits, the configuration to show
//! and, for a trajectory, its rows and times (each row of `q` once: a trajectory adds its
//! numbers and nothing else). It has no network access and no external file: the drawing is a
//! 2-D canvas with an orbiting orthographic camera.
//!
//! Joints the page evaluates: revolute, continuous, prismatic, cylindrical, fixed and mimic.
//! Floating and ball joints are refused ([`ViewError::Joint`]) until the page moves
//! quaternions.

use serde_json::{Value, json};

use crate::eval::Chain;
use crate::model::joint::JointKind;
use crate::model::transform::Transform;

/// Why a page was not made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ViewError {
    /// A joint the page cannot move yet.
    #[error(
        "joint {joint:?} is {kind}: the page moves revolute, continuous, prismatic, cylindrical, fixed and mimic joints"
    )]
    Joint {
        /// The joint.
        joint: String,
        /// Its kind.
        kind: &'static str,
    },
    /// A row of the wrong length or with a value that is not finite.
    #[error("row {row}: {what}")]
    Row {
        /// The row (0 for a single configuration).
        row: usize,
        /// What is wrong.
        what: String,
    },
    /// Times that do not match the rows.
    #[error("{times} times for {rows} rows")]
    Times {
        /// Times given.
        times: usize,
        /// Rows given.
        rows: usize,
    },
}

/// The page's JavaScript: evaluation, drawing, sliders, timeline.
const SCRIPT: &str = include_str!("view.js");

/// 4 × 4 rows of a transform, for the page.
fn rows(t: &Transform) -> Vec<f64> {
    t.to_rows().iter().flatten().copied().collect()
}

/// The page for `chain` showing `rows` (row-major configurations, at least one; more than one
/// is a trajectory with a timeline, stamped `times` in ns when given, else 0.1 s apart).
///
/// # Errors
/// [`ViewError`] for a joint the page cannot move, a row of the wrong length or not finite, or
/// times that do not match the rows.
pub fn page(chain: &Chain, rows_q: &[f64], times: Option<&[i64]>) -> Result<String, ViewError> {
    let nq = chain.nq();
    let n = rows_q.len().checked_div(nq).unwrap_or(1);
    if rows_q.len() != n * nq || n == 0 {
        return Err(ViewError::Row {
            row: 0,
            what: format!("{} values for rows of {nq}", rows_q.len()),
        });
    }
    if let Some((i, x)) = rows_q.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(ViewError::Row {
            row: i / nq.max(1),
            what: format!("q[{}] = {x} is not finite", i % nq.max(1)),
        });
    }
    if let Some(t) = times
        && t.len() != n
    {
        return Err(ViewError::Times {
            times: t.len(),
            rows: n,
        });
    }
    let mut joints = Vec::new();
    for spec in chain.description().joints() {
        let kind = spec.kind;
        if matches!(kind, JointKind::Floating | JointKind::Ball) {
            return Err(ViewError::Joint {
                joint: spec.name.clone(),
                kind: kind.as_str(),
            });
        }
        let id = chain.joint_id(&spec.name).ok();
        let q = id.and_then(|j| chain.joint(j).q_index());
        let mimic = id.and_then(|j| chain.joint(j).mimic()).map(|m| {
            json!({
                "q": chain.joint(m.primary).q_index(),
                "multiplier": m.multiplier,
                "offset": m.offset,
            })
        });
        joints.push(json!({
            "name": spec.name,
            "type": kind.as_str(),
            "parent": spec.parent,
            "child": spec.child,
            "axis": spec.axis,
            "origin": rows(&spec.origin),
            "post": rows(&spec.post),
            "theta": spec.theta,
            "d": spec.d,
            "q": q,
            "mimic": mimic,
        }));
    }
    let ranges: Vec<Value> = chain
        .admitted_ranges()
        .into_iter()
        .map(|(lo, hi)| {
            let (lo, hi) = crate::eval::sampling::range(lo, hi);
            json!([lo, hi])
        })
        .collect();
    let frames: Vec<&[f64]> = rows_q.chunks(nq.max(1)).collect();
    let times: Vec<i64> = match times {
        Some(t) => t.to_vec(),
        None => (0..n as i64).map(|i| i * 100_000_000).collect(),
    };
    let model = json!({
        "name": chain.name(),
        "links": chain.links().iter().map(|l| l.name()).collect::<Vec<_>>(),
        "joints": joints,
        "q_names": chain.variable_names(),
        "ranges": ranges,
        "frames": if nq == 0 { vec![Vec::new(); n] } else { frames.iter().map(|f| f.to_vec()).collect() },
        "times": times,
    });
    // `</` cannot end the script element early: JSON allows `<\/`.
    let data = model.to_string().replace("</", "<\\/");
    let title = html_escape(chain.name());
    Ok(format!(
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width\">\
         <title>{title} — kinechain</title><style>{STYLE}</style></head>\n<body>\
         <canvas id=\"view\"></canvas><div id=\"panel\"><h1>{title}</h1>\
         <div id=\"timeline\"></div><div id=\"sliders\"></div></div><div id=\"hover\"></div>\
         <pre id=\"poses\" hidden></pre>\n\
         <script id=\"model\" type=\"application/json\">{data}</script>\n\
         <script>\n{SCRIPT}</script>\n</body></html>\n"
    ))
}

/// The page's layout: the canvas fills the window, the panel of sliders on the right.
const STYLE: &str = "html,body{margin:0;height:100%;font:13px system-ui,sans-serif;background:#fafafa}\
#view{position:fixed;left:0;top:0;width:calc(100% - 300px);height:100%}\
#panel{position:fixed;right:0;top:0;width:290px;height:100%;overflow:auto;padding:5px;\
border-left:1px solid #ddd;background:#fff}#panel h1{font-size:15px;margin:4px 0 8px}\
.row{margin:4px 0}.row input{width:100%}.row span{float:right;font-variant-numeric:tabular-nums}\
#hover{position:fixed;pointer-events:none;background:#fffd;padding:1px 4px;border:1px solid #ccc}";

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

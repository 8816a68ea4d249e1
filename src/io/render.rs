//! An SVG drawing of a chain at one configuration (`kinechain render`): three orthographic views
//! and an isometric one, links as segments between frame origins, each moving joint's axis as a
//! short arrow (12% of the reach, the largest distance of a link origin from the world origin),
//! small RGB triads for the frames (8% of the reach), names on hover, a scale bar, base and tool
//! marked. The output depends only on its inputs (same chain and pose, same bytes).
//!
//! Projections, with `(u, v)` the drawing's horizontal and upward coordinates in metres, then
//! `svg_x = origin_x + scale · u`, `svg_y = origin_y − scale · v` (the values are written on each
//! panel as `data-origin-x`, `data-origin-y`, `data-scale`):
//! front `(x, z)`, side `(y, z)`, top `(x, y)`, isometric `((x − y) cos 30°, z + (x + y) sin 30°)`.
//!
//! Any finite pose is drawn, however far from the origin (joint values far outside their limits,
//! with the limits ignored): the geometry is laid out in units of a power of two near the largest
//! coordinate, which scales every step exactly and keeps squares and spans within `f64`.

use crate::eval::Chain;
use crate::eval::Poses;
use crate::io::xml::escape_shown;
use crate::model::chain::LinkId;
use nalgebra::{Point3, Vector3};
use std::fmt::Write as _;

/// The four views.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// Looking along −y: x to the right, z up.
    Front,
    /// Looking along +x: y to the right, z up.
    Side,
    /// Looking down −z: x to the right, y up.
    Top,
    /// Isometric: `((x − y) cos 30°, z + (x + y) sin 30°)`.
    Isometric,
}

impl View {
    /// All four, in drawing order (left to right, top to bottom).
    pub const ALL: [View; 4] = [View::Front, View::Side, View::Top, View::Isometric];

    /// Name used in the SVG (`data-view`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            View::Front => "front",
            View::Side => "side",
            View::Top => "top",
            View::Isometric => "isometric",
        }
    }

    /// The drawing coordinates `(u, v)` of a world point, in metres.
    #[must_use]
    pub fn project(self, p: &Point3<f64>) -> (f64, f64) {
        let (c30, s30) = (3f64.sqrt() / 2.0, 0.5);
        match self {
            View::Front => (p.x, p.z),
            View::Side => (p.y, p.z),
            View::Top => (p.x, p.y),
            View::Isometric => ((p.x - p.y) * c30, p.z + (p.x + p.y) * s30),
        }
    }
}

const PANEL: f64 = 360.0;
const MARGIN: f64 = 30.0;

/// A view's place on the canvas: the drawing point `mid` (in `unit` metres) at the pixel
/// `centre`, and `scale` pixels per `unit` metres.
struct Panel {
    view: View,
    centre: (f64, f64),
    mid: (f64, f64),
    scale: f64,
    unit: f64,
}

impl Panel {
    /// The pixel of `p`, from its offset to `mid` (a difference of nearby numbers, where
    /// `x0 + scale · u` would lose the offset to rounding once `scale · u` is large).
    fn at(&self, p: &Point3<f64>) -> (f64, f64) {
        let (u, v) = self.view.project(p);
        (
            self.centre.0 + self.scale * (u - self.mid.0),
            self.centre.1 - self.scale * (v - self.mid.1),
        )
    }

    /// The pixel of the world origin, `(x0, y0)` of the module's documentation.
    fn origin(&self) -> (f64, f64) {
        (
            self.centre.0 - self.scale * self.mid.0,
            self.centre.1 + self.scale * self.mid.1,
        )
    }
}

/// A round length (1, 2 or 5 × 10ⁿ m) close to `target`.
fn round_length(target: f64) -> f64 {
    let e = target.log10().floor();
    let base = 10f64.powf(e);
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * base)
        .filter(|l| *l <= target)
        .fold(base, f64::max)
}

/// A pose that cannot be drawn: an entry is not finite (joint values so large, with the limits
/// ignored or absent, that a position overflows `f64`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("the {what} of {place} overflows f64 (not finite): the joint values are too large to draw")]
pub struct NotFinite {
    /// `pose` (of a link) or `axis` (of a joint).
    pub what: &'static str,
    /// `link 'NAME'` or `joint 'NAME'`.
    pub place: String,
}

/// The chain at the configuration of `poses`, as an SVG document.
///
/// # Errors
/// [`NotFinite`] naming the first link whose pose, or joint whose axis, has an entry that is not
/// finite.
pub fn svg(chain: &Chain, poses: &Poses<'_>) -> Result<String, NotFinite> {
    let links: Vec<_> = (0..chain.links().len()).map(LinkId).collect();
    let frames: Vec<_> = links.iter().map(|&l| poses.world_from_link(l)).collect();
    if let Some(l) = frames
        .iter()
        .position(|f| f.to_rows().iter().flatten().any(|x| !x.is_finite()))
    {
        return Err(NotFinite {
            what: "pose",
            place: format!("link '{}'", chain.link(LinkId(l)).name()),
        });
    }
    let mut axes: Vec<(String, Point3<f64>, Vector3<f64>)> = Vec::new();
    for (i, j) in chain.joints().iter().enumerate() {
        if let Some((p, z)) = poses.joint_axis(crate::model::chain::JointId(i)) {
            if p.iter().chain(z.iter()).any(|x| !x.is_finite()) {
                return Err(NotFinite {
                    what: "axis",
                    place: format!("joint '{}'", j.name()),
                });
            }
            axes.push((j.name().to_string(), p, z));
        }
    }
    // Lengths in `unit` metres from here on (see the module's documentation): every coordinate
    // of an origin or axis point is then below 2 in magnitude, and no norm or span overflows.
    let largest = frames
        .iter()
        .map(|f| f.translation().amax())
        .chain(axes.iter().map(|(_, p, _)| p.coords.amax()))
        .fold(0.0, f64::max);
    let unit = power_of_two_below(largest);
    let origins: Vec<Point3<f64>> = frames
        .iter()
        .map(|f| Point3::from(f.translation() / unit))
        .collect();
    for (_, p, _) in &mut axes {
        *p /= unit;
    }
    let reach = origins
        .iter()
        .map(|p| p.coords.norm())
        .fold(0.0_f64, f64::max)
        .max(1e-9 / unit);
    let triad = 0.08 * reach;
    let arrow = 0.12 * reach;
    let mut points: Vec<Point3<f64>> = origins.clone();
    for (_, p, z) in &axes {
        points.extend([*p, p + z * arrow]);
    }
    let (panels, ortho) = layout(&points, unit);

    let mut s = String::new();
    let size = 2.0 * PANEL;
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{size}" height="{}" viewBox="0 0 {size} {}" font-family="sans-serif" font-size="11">"#,
        size + 40.0,
        size + 40.0
    );
    let _ = writeln!(s, "<title>{}</title>", escape_shown(chain.name()));
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    for (i, p) in panels.iter().enumerate() {
        write_panel(&mut s, chain, i, p, &origins, &axes, arrow);
    }
    // One group per link: its origin and triad in every panel, and its name on hover.
    let tools: Vec<LinkId> = links
        .iter()
        .copied()
        .filter(|l| chain.joints().iter().all(|j| j.parent() != *l))
        .collect();
    for (i, &l) in links.iter().enumerate() {
        let role = if l == LinkId(0) {
            " base"
        } else if tools.contains(&l) {
            " tool"
        } else {
            ""
        };
        let columns = [0, 1, 2].map(|k| frames[i].rotation().column(k) * triad);
        write_link(
            &mut s,
            chain.link(l).name(),
            role,
            &panels,
            &origins[i],
            &columns,
        );
    }
    write_legend(&mut s, size, ortho, unit);
    s.push_str("</svg>\n");
    Ok(s)
}

/// The largest power of two not above `x`, or 1 for a zero or subnormal `x` (whose points are
/// drawn at the smallest span anyway).
fn power_of_two_below(x: f64) -> f64 {
    let p = f64::from_bits(x.to_bits() & f64::INFINITY.to_bits());
    if p == 0.0 { 1.0 } else { p }
}

/// `x` as the drawing writes a scale or a length: the shortest decimal that reads back to `x`, in
/// exponent form far from 1 (where the decimal would run to hundreds of digits).
fn shortest(x: f64) -> String {
    if x == 0.0 || (1e-5..1e16).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// The four panels, each centred on the extent of `points` in its view: one scale for the three
/// orthographic views (so that the scale bar holds for all), returned as well, and another for
/// the isometric one; `points` in `unit` metres. A view's span is at least 1 nm, and at least
/// `f64::EPSILON` units (below that, far from the origin, the coordinates differ by their rounding
/// only, and pixels per unit would overflow).
fn layout(points: &[Point3<f64>], unit: f64) -> (Vec<Panel>, f64) {
    let least = (1e-9 / unit).max(f64::EPSILON);
    let extent = |v: View| {
        let (mut lo, mut hi) = ((f64::MAX, f64::MAX), (f64::MIN, f64::MIN));
        for p in points {
            let (u, w) = v.project(p);
            lo = (lo.0.min(u), lo.1.min(w));
            hi = (hi.0.max(u), hi.1.max(w));
        }
        (lo, hi)
    };
    let span = |v: View| {
        let (lo, hi) = extent(v);
        (hi.0 - lo.0).max(hi.1 - lo.1).max(least)
    };
    let ortho = (PANEL - 2.0 * MARGIN)
        / [View::Front, View::Side, View::Top]
            .map(span)
            .iter()
            .fold(0.0_f64, |m, s| m.max(*s));
    let iso = (PANEL - 2.0 * MARGIN) / span(View::Isometric);
    let panels = View::ALL
        .iter()
        .enumerate()
        .map(|(i, &view)| {
            let scale = if view == View::Isometric { iso } else { ortho };
            let (lo, hi) = extent(view);
            let (cx, cy) = (0.5 * (lo.0 + hi.0), 0.5 * (lo.1 + hi.1));
            let (px, py) = ((i % 2) as f64 * PANEL, (i / 2) as f64 * PANEL);
            Panel {
                view,
                centre: (px + PANEL / 2.0, py + PANEL / 2.0),
                mid: (cx, cy),
                scale,
                unit,
            }
        })
        .collect();
    (panels, ortho)
}

/// Panel `i`: its frame and title, the links as segments between the origins of each joint's
/// parent and child, and the joint axes as arrows of length `arrow` (lengths in the panel's unit).
fn write_panel(
    s: &mut String,
    chain: &Chain,
    i: usize,
    p: &Panel,
    origins: &[Point3<f64>],
    axes: &[(String, Point3<f64>, Vector3<f64>)],
    arrow: f64,
) {
    let (px, py) = ((i % 2) as f64 * PANEL, (i / 2) as f64 * PANEL);
    let (x0, y0) = p.origin();
    let _ = writeln!(
        s,
        r#"<g class="panel" data-view="{}" data-origin-x="{x0:.6}" data-origin-y="{y0:.6}" data-scale="{}">"#,
        p.view.name(),
        shortest(p.scale / p.unit)
    );
    let _ = writeln!(
        s,
        r##"<rect x="{px}" y="{py}" width="{PANEL}" height="{PANEL}" fill="none" stroke="#bbb"/><text x="{}" y="{}" fill="#555">{}</text>"##,
        px + 8.0,
        py + 16.0,
        match p.view {
            View::Front => "front (x →, z ↑)",
            View::Side => "side (y →, z ↑)",
            View::Top => "top (x →, y ↑)",
            View::Isometric => "isometric",
        }
    );
    // Links: segments from the parent link's origin to the child's, one per joint.
    for j in chain.joints() {
        let (a, b) = (p.at(&origins[j.parent().0]), p.at(&origins[j.child().0]));
        let _ = writeln!(
            s,
            r##"<line class="segment" x1="{:.3}" y1="{:.3}" x2="{:.3}" y2="{:.3}" stroke="#333" stroke-width="3" stroke-linecap="round"><title>{}</title></line>"##,
            a.0,
            a.1,
            b.0,
            b.1,
            escape_shown(j.name())
        );
    }
    // Joint axes: short arrows from the axis point along the axis.
    for (name, o, z) in axes {
        let (a, b) = (p.at(o), p.at(&(o + z * arrow)));
        let _ = writeln!(
            s,
            r##"<line class="axis" x1="{:.3}" y1="{:.3}" x2="{:.3}" y2="{:.3}" stroke="#c60" stroke-width="1.5" marker-end="url(#arrow)"><title>axis of {}</title></line>"##,
            a.0,
            a.1,
            b.0,
            b.1,
            escape_shown(name)
        );
    }
    let _ = writeln!(s, "</g>");
}

/// The group of the link `name` at `origin`: in every panel its triad (`columns`, the frame's
/// axes scaled to the triad's length), the marker of its `role` (`" base"`, `" tool"` or none)
/// and its origin.
fn write_link(
    s: &mut String,
    name: &str,
    role: &str,
    panels: &[Panel],
    origin: &Point3<f64>,
    columns: &[Vector3<f64>; 3],
) {
    let _ = writeln!(
        s,
        r#"<g class="link{role}" data-link="{shown}"><title>{shown}</title>"#,
        shown = escape_shown(name)
    );
    for p in panels {
        let o = p.at(origin);
        for (column, color) in columns.iter().zip(["#d00", "#080", "#00d"]) {
            let t = p.at(&(origin + column));
            let _ = writeln!(
                s,
                r#"<line x1="{:.3}" y1="{:.3}" x2="{:.3}" y2="{:.3}" stroke="{color}" stroke-width="1"/>"#,
                o.0, o.1, t.0, t.1
            );
        }
        let marker = match role {
            " base" => format!(
                r##"<rect x="{:.3}" y="{:.3}" width="10" height="10" fill="#444"/>"##,
                o.0 - 5.0,
                o.1 - 5.0
            ),
            " tool" => format!(
                r##"<circle cx="{:.3}" cy="{:.3}" r="5" fill="none" stroke="#c00" stroke-width="2"/>"##,
                o.0, o.1
            ),
            _ => String::new(),
        };
        let _ = writeln!(
            s,
            r##"{marker}<circle class="origin" data-view="{}" cx="{:.6}" cy="{:.6}" r="2.5" fill="#222"/>"##,
            p.view.name(),
            o.0,
            o.1
        );
    }
    let _ = writeln!(s, "</g>");
}

/// The scale bar of the orthographic views (drawn at `ortho` pixels per `unit` metres), the key,
/// and the arrowhead's definition, below the panels of a drawing `size` wide.
fn write_legend(s: &mut String, size: f64, ortho: f64, unit: f64) {
    let bar = round_length(0.25 * (PANEL - 2.0 * MARGIN) / ortho * unit);
    let pixels = bar / unit * ortho;
    let (bx, by) = (20.0, size + 20.0);
    let _ = writeln!(
        s,
        r##"<g class="scale-bar"><line x1="{bx}" y1="{by}" x2="{:.3}" y2="{by}" stroke="black" stroke-width="3"/><text x="{:.3}" y="{:.3}">{} m (front, side, top)</text></g>"##,
        bx + pixels,
        bx + pixels + 8.0,
        by + 4.0,
        shortest(bar)
    );
    let _ = writeln!(
        s,
        r##"<text x="{:.3}" y="{:.3}" fill="#555">■ base   ○ tool   frames: x red, y green, z blue   arrows: joint axes</text>"##,
        size / 2.0 - 60.0,
        by + 4.0
    );
    let _ = writeln!(
        s,
        r##"<defs><marker id="arrow" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="6" markerHeight="6" orient="auto-start-reverse"><path d="M 0 0 L 10 5 L 0 10 z" fill="#c60"/></marker></defs>"##
    );
}

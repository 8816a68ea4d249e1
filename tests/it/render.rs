//! `kinechain render`: the SVG parses, has one group per link, draws every link origin where the
//! stated projection puts its `fk` position, and is the same bytes every time.

use crate::common::*;
use kinechain::io::render::{View, svg};
use kinechain::{Chain, Data, LimitPolicy, forward_kinematics};

#[test]
fn drawn_origins_are_the_fk_positions_under_the_stated_projection() {
    let mut rng = rng(91);
    for name in [
        "puma560.yaml",
        "panda.urdf",
        "snake50.yaml",
        "cylindrical.yaml",
    ] {
        let chain = Chain::from_file(robots_dir().join(name)).unwrap();
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let q = random_q(&chain, &mut rng);
        let text = {
            let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
            svg(&chain, &poses).unwrap()
        };
        let again = {
            let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
            svg(&chain, &poses).unwrap()
        };
        assert_eq!(text, again, "{name}: not deterministic");
        let doc = roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
        let num = |n: &roxmltree::Node, a: &str| n.attribute(a).unwrap().parse::<f64>().unwrap();
        let panels: Vec<(String, f64, f64, f64)> = doc
            .descendants()
            .filter(|n| n.attribute("class") == Some("panel"))
            .map(|n| {
                (
                    n.attribute("data-view").unwrap().to_string(),
                    num(&n, "data-origin-x"),
                    num(&n, "data-origin-y"),
                    num(&n, "data-scale"),
                )
            })
            .collect();
        assert_eq!(panels.len(), 4);
        // Scales and the scale bar's length in plain decimals at a robot's size.
        for n in doc.descendants() {
            let scale = n.attribute("data-scale").unwrap_or("");
            assert!(!scale.contains('e'), "{name}: data-scale {scale}");
        }
        let bar = doc
            .descendants()
            .find(|n| n.attribute("class") == Some("scale-bar"))
            .and_then(|n| n.children().find(|c| c.has_tag_name("text")))
            .and_then(|t| t.text())
            .unwrap();
        let metres = bar.split(' ').next().unwrap();
        assert!(!metres.contains('e'), "{name}: {bar}");
        let groups: Vec<_> = doc
            .descendants()
            .filter(|n| {
                n.attribute("class")
                    .is_some_and(|c| c.split(' ').next() == Some("link"))
            })
            .collect();
        assert_eq!(
            groups.len(),
            chain.links().len(),
            "{name}: one group per link"
        );
        let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
        for g in &groups {
            let link = g.attribute("data-link").unwrap();
            let p = poses
                .world_from_link(chain.link_id(link).unwrap())
                .translation();
            let title = g.children().find(|c| c.has_tag_name("title")).unwrap();
            assert_eq!(title.text(), Some(link));
            for c in g
                .children()
                .filter(|c| c.attribute("class") == Some("origin"))
            {
                let view = c.attribute("data-view").unwrap();
                let (_, x0, y0, s) = panels.iter().find(|p| p.0 == view).unwrap();
                let v = View::ALL.iter().find(|v| v.name() == view).unwrap();
                let (u, w) = v.project(&p.into());
                assert!(
                    (num(&c, "cx") - (x0 + s * u)).abs() < 1e-5,
                    "{name} {link} {view}"
                );
                assert!(
                    (num(&c, "cy") - (y0 - s * w)).abs() < 1e-5,
                    "{name} {link} {view}"
                );
            }
        }
        // Base and tool are marked; every moving joint has an axis arrow in every panel.
        assert!(
            doc.descendants()
                .any(|n| n.attribute("class") == Some("link base"))
        );
        assert!(
            doc.descendants()
                .any(|n| n.attribute("class") == Some("link tool"))
        );
        let moving = chain
            .joints()
            .iter()
            .filter(|j| j.kind() != kinechain::JointKind::Fixed)
            .count();
        let arrows = doc
            .descendants()
            .filter(|n| n.attribute("class") == Some("axis"))
            .count();
        assert_eq!(arrows, 4 * moving, "{name}");
        assert!(
            doc.descendants()
                .any(|n| n.attribute("class") == Some("scale-bar"))
        );
    }
}

/// The projections are the ones the module documents, checked on one point.
#[test]
fn the_views_project_as_documented() {
    let p = kinechain::nalgebra::Point3::new(1.0, 2.0, 3.0);
    let c30 = 30f64.to_radians().cos();
    let want = [
        (View::Front, (1.0, 3.0)),
        (View::Side, (2.0, 3.0)),
        (View::Top, (1.0, 2.0)),
        (View::Isometric, (-c30, 4.5)),
    ];
    for (view, (u, v)) in want {
        let got = view.project(&p);
        assert!(
            (got.0 - u).abs() < 1e-15 && (got.1 - v).abs() < 1e-15,
            "{view:?}: {got:?}"
        );
    }
    assert_eq!(
        View::ALL.map(View::name),
        ["front", "side", "top", "isometric"]
    );
}

/// A point drawn at `(x, y)` in pixels.
type Px = (f64, f64);

fn attr(n: &roxmltree::Node, a: &str) -> f64 {
    let text = n.attribute(a).unwrap_or_else(|| panic!("no {a}"));
    text.parse().unwrap_or_else(|e| panic!("{a}={text}: {e}"))
}

fn line_ends(n: &roxmltree::Node) -> (Px, Px) {
    (
        (attr(n, "x1"), attr(n, "y1")),
        (attr(n, "x2"), attr(n, "y2")),
    )
}

/// `b − a` is along `d` (a direction in pixels): parallel and pointing the same way, unless `d`
/// is too short to have a direction at the written precision.
fn along(a: Px, b: Px, d: Px) -> bool {
    let (x, y) = (b.0 - a.0, b.1 - a.1);
    let len = d.0.hypot(d.1);
    len < 1.0 || ((x * d.1 - y * d.0).abs() <= 2e-3 * len && x * d.0 + y * d.1 > 0.0)
}

fn near(a: Px, b: Px) -> bool {
    (a.0 - b.0).abs() <= 1e-3 && (a.1 - b.1).abs() <= 1e-3
}

/// Where each piece of the drawing goes: every link is a segment between the origins of its
/// joint's parent and child, every axis arrow starts on the axis and points along it, every
/// triad line starts at its link's origin along the frame's axis (x red, y green, z blue), the
/// base and tool markers sit on their origins; the origins and arrows of each view fill its
/// panel's inner square (the largest orthographic extent and the isometric one span it, both
/// centred), and the scale bar is a round length drawn at the orthographic scale.
#[test]
fn every_piece_is_drawn_where_its_frame_puts_it_and_the_views_fill_their_panels() {
    let mut rng = rng(92);
    let files = robot_files();
    for (path, round) in files.iter().flat_map(|f| [(f, 0), (f, 1), (f, 2)]) {
        let chain = Chain::from_file(path).unwrap();
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let q = random_q(&chain, &mut rng);
        let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
        check_drawing(&format!("{} ({round})", chain.name()), &chain, &poses);
    }
}

/// Poses far outside any robot's workspace (a slide at 10¹⁰⁰ to 1.7·10³⁰⁸ m, the limits ignored)
/// are drawn like the others: finite numbers only, every piece where its frame puts it, the
/// scale bar a round length. Before, the reach's norm overflowed from about 10¹⁵⁴ m on and the
/// drawing was written with `NaN` coordinates.
#[test]
fn poses_far_from_the_origin_are_drawn_like_the_others() {
    let chain = Chain::from_file(robots_dir().join("stanford.yaml")).unwrap();
    let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    for slide in [1e100, 1e200, 1e300, 1e308, 1.7e308] {
        let q = [0.3, 0.2, slide, 0.1, 0.2, 0.3];
        let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
        let text = svg(&chain, &poses).unwrap();
        assert!(
            !text.contains("NaN") && !text.contains("inf"),
            "slide {slide:e}"
        );
        // Scales far from 1 in exponent form (not hundreds of digits).
        let doc = roxmltree::Document::parse(&text).unwrap();
        for n in doc.descendants().filter(|n| n.has_attribute("data-scale")) {
            let scale = n.attribute("data-scale").unwrap();
            assert!(
                scale.contains("e-") && scale.len() < 30,
                "slide {slide:e}: {scale}"
            );
        }
        // (At 1.7·10³⁰⁸ m the checks' own projection in metres overflows: the isometric view adds
        // the coordinates. The drawing projects in scaled units.)
        if slide <= 1e308 {
            check_drawing(&format!("stanford, slide {slide:e}"), &chain, &poses);
        }
    }
}

/// A drawing whose points all coincide (a chain without moving joints, all in one place) spans
/// 1 nm in every view: 3·10¹¹ pixels per metre, the point at each panel's centre. Far from the
/// origin, where 1 nm is below the coordinates' rounding, it spans `f64::EPSILON` of the
/// largest coordinate's power of two instead.
#[test]
fn a_chain_in_one_point_is_drawn_at_the_nanometre_scale() {
    use kinechain::{ChainBuilder, JointKind, JointSpec, Transform};
    for (x, span) in [
        (0.0, 1e-9),
        (0.7, 1e-9),
        (3.0, 1e-9),
        (1e3, 1e-9),
        (1e300, f64::EPSILON * 2f64.powi(996)),
    ] {
        let mut b = ChainBuilder::new("point");
        b.link("base").link("tip");
        b.joint(JointSpec::new("weld", JointKind::Fixed, "base", "tip"));
        b.world_from_root(Transform::from_xyz_rpy([x, 0.0, 0.0], [0.0; 3]));
        let chain = b.build().unwrap();
        let mut data = Data::new(&chain);
        let poses = forward_kinematics(&chain, &mut data, &[]).unwrap();
        let text = svg(&chain, &poses).unwrap();
        let doc = roxmltree::Document::parse(&text).unwrap();
        let panels: Vec<_> = doc
            .descendants()
            .filter(|n| n.attribute("class") == Some("panel"))
            .collect();
        for (i, panel) in panels.iter().enumerate() {
            let scale = attr(panel, "data-scale");
            assert!(
                (scale * span / 300.0 - 1.0).abs() < 1e-12,
                "x = {x}: {scale}"
            );
            let centre = (
                (i % 2) as f64 * 360.0 + 180.0,
                (i / 2) as f64 * 360.0 + 180.0,
            );
            let view = panel.attribute("data-view").unwrap();
            for c in doc
                .descendants()
                .filter(|c| c.attribute("class") == Some("origin"))
                .filter(|c| c.attribute("data-view") == Some(view))
            {
                assert!(
                    near((attr(&c, "cx"), attr(&c, "cy")), centre),
                    "x = {x}, {view}"
                );
            }
        }
    }
}

/// A pose that overflows `f64` cannot be drawn: the error names the first link whose pose is not
/// finite, as `fk` does.
#[test]
fn a_pose_that_overflows_is_an_error_naming_its_link() {
    let chain = Chain::from_dh_yaml_str(
        "name: two_slides\nconvention: standard\njoints:\n  \
         - {name: s1, link: l1, type: prismatic, a: 0, alpha: 0, d: 0, theta: 0}\n  \
         - {name: s2, link: l2, type: prismatic, a: 0, alpha: 0, d: 0, theta: 0}\n",
    )
    .unwrap();
    let mut data = Data::new(&chain);
    let poses = forward_kinematics(&chain, &mut data, &[1e308, 1e308]).unwrap();
    let err = svg(&chain, &poses).unwrap_err();
    assert_eq!((err.what, err.place.as_str()), ("pose", "link 'l2'"));
    assert_eq!(
        err.to_string(),
        "the pose of link 'l2' overflows f64 (not finite): the joint values are too large to draw"
    );
    let poses = forward_kinematics(&chain, &mut data, &[1e308, 7e307]).unwrap();
    assert!(svg(&chain, &poses).is_ok(), "1.7e308 is finite");
}

/// The checks of [`every_piece_is_drawn_where_its_frame_puts_it_and_the_views_fill_their_panels`]
/// on the drawing of `poses`.
fn check_drawing(name: &str, chain: &Chain, poses: &kinechain::Poses<'_>) {
    const PANEL: f64 = 360.0;
    const INNER: f64 = 300.0;
    let text = svg(chain, poses).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    // (Scaled before the norm, which would overflow for the far poses.)
    let reach = chain
        .links()
        .iter()
        .map(|l| {
            let t = poses
                .world_from_link(chain.link_id(l.name()).unwrap())
                .translation();
            let m = t.amax();
            if m == 0.0 { 0.0 } else { m * (t / m).norm() }
        })
        .fold(0.0, f64::max);
    // Lengths in metres of the triads and arrows, read back from the drawing where a line is
    // long enough (5 px) for its three written decimals to give it to 1e-3.
    let (mut triads, mut arrow_lengths) = (Vec::new(), Vec::new());
    let length = |(a, b): (Px, Px), d: Px| {
        let pixels = (b.0 - a.0).hypot(b.1 - a.1);
        (pixels >= 5.0).then(|| pixels / d.0.hypot(d.1))
    };
    let panels: Vec<_> = doc
        .descendants()
        .filter(|n| n.attribute("class") == Some("panel"))
        .collect();
    assert_eq!(panels.len(), 4, "{name}");
    let origin = |id: kinechain::LinkId| {
        kinechain::nalgebra::Point3::from(poses.world_from_link(id).translation())
    };
    let mut ortho_span: f64 = 0.0;
    for (i, (panel, view)) in panels.iter().zip(View::ALL).enumerate() {
        assert_eq!(panel.attribute("data-view"), Some(view.name()));
        let (x0, y0, s) = (
            attr(panel, "data-origin-x"),
            attr(panel, "data-origin-y"),
            attr(panel, "data-scale"),
        );
        let at = |p: &kinechain::nalgebra::Point3<f64>| {
            let (u, v) = view.project(p);
            (x0 + s * u, y0 - s * v)
        };
        let dir = |d: &kinechain::nalgebra::Vector3<f64>| {
            let (u, v) = view.project(&kinechain::nalgebra::Point3::from(*d));
            (s * u, -s * v)
        };
        let lines = |class: &str| -> Vec<(Px, Px)> {
            panel
                .children()
                .filter(|c| c.attribute("class") == Some(class))
                .map(|c| line_ends(&c))
                .collect()
        };
        let segments = lines("segment");
        assert_eq!(segments.len(), chain.joints().len(), "{name} {i}");
        for (j, (a, b)) in chain.joints().iter().zip(&segments) {
            assert!(near(*a, at(&origin(j.parent()))), "{name} {i} {}", j.name());
            assert!(near(*b, at(&origin(j.child()))), "{name} {i} {}", j.name());
        }
        let mut drawn = Vec::new();
        let moving = chain.joints().iter().filter_map(|j| {
            let id = chain.joint_id(j.name()).unwrap();
            poses.joint_axis(id)
        });
        let arrows = lines("axis");
        assert_eq!(arrows.len(), moving.clone().count(), "{name} {i}");
        for ((p, z), (a, b)) in moving.zip(arrows) {
            assert!(near(a, at(&p)), "{name} {i}");
            assert!(along(a, b, dir(&z)), "{name} {i}");
            arrow_lengths.extend(length((a, b), dir(&z)));
            drawn.extend([a, b]);
        }
        for (k, link) in chain.links().iter().enumerate() {
            let id = chain.link_id(link.name()).unwrap();
            let group = doc
                .descendants()
                .find(|n| n.attribute("data-link") == Some(link.name()))
                .unwrap();
            let o = at(&origin(id));
            // Per view: the triad's three lines, the base or tool marker if any, the origin.
            let elements: Vec<_> = group
                .children()
                .filter(|c| c.is_element() && !c.has_tag_name("title"))
                .collect();
            let chunks: Vec<_> = elements
                .split_inclusive(|c| c.attribute("class") == Some("origin"))
                .collect();
            assert_eq!(chunks.len(), 4, "{name} {k}");
            let (circle, rest) = chunks[i].split_last().unwrap();
            assert_eq!(circle.attribute("data-view"), Some(view.name()));
            assert!(
                near((attr(circle, "cx"), attr(circle, "cy")), o),
                "{name} {k}"
            );
            drawn.push(o);
            let (triad, marker) = rest.split_at(3);
            let rotation = poses.world_from_link(id).rotation();
            for (axis, (line, color)) in triad.iter().zip(["#d00", "#080", "#00d"]).enumerate() {
                assert!(line.has_tag_name("line"));
                assert_eq!(line.attribute("stroke"), Some(color));
                let (a, b) = line_ends(line);
                assert!(near(a, o), "{name} {k}");
                let column = rotation.column(axis).into_owned();
                assert!(along(a, b, dir(&column)), "{name} {k} axis {axis}");
                triads.extend(length((a, b), dir(&column)));
            }
            match (group.attribute("class").unwrap(), marker) {
                ("link base", [m]) => {
                    assert!(m.has_tag_name("rect"));
                    let c = (attr(m, "x") + 5.0, attr(m, "y") + 5.0);
                    assert!(near(c, o), "{name}: base marker");
                }
                ("link tool", [m]) => {
                    assert!(m.has_tag_name("circle"));
                    assert!(near((attr(m, "cx"), attr(m, "cy")), o), "{name}: tool");
                }
                ("link", []) => {}
                (class, marker) => panic!("{name} {k}: {class} with {} markers", marker.len()),
            }
        }
        // The panel's frame is its square of the 2 × 2 grid, and the origins and arrows span
        // its inner square, centred on it.
        let (px, py) = ((i % 2) as f64 * PANEL, (i / 2) as f64 * PANEL);
        let frame = panel.children().find(|c| c.has_tag_name("rect")).unwrap();
        let corners = ["x", "y", "width", "height"].map(|a| attr(&frame, a));
        assert_eq!(corners, [px, py, PANEL, PANEL], "{name} {i}");
        let (lo, hi) = drawn.iter().fold(
            ((f64::MAX, f64::MAX), (f64::MIN, f64::MIN)),
            |(lo, hi), p| {
                (
                    (lo.0.min(p.0), lo.1.min(p.1)),
                    (hi.0.max(p.0), hi.1.max(p.1)),
                )
            },
        );
        let centre = ((lo.0 + hi.0) / 2.0, (lo.1 + hi.1) / 2.0);
        assert!(
            (centre.0 - (px + PANEL / 2.0)).abs() < 2e-3
                && (centre.1 - (py + PANEL / 2.0)).abs() < 2e-3,
            "{name} {i}: centred at {centre:?}"
        );
        let span = (hi.0 - lo.0).max(hi.1 - lo.1);
        assert!(span <= INNER + 2e-3, "{name} {i}: {span}");
        if view == View::Isometric {
            assert!(
                (span - INNER).abs() < 2e-3,
                "{name}: isometric spans {span}"
            );
        } else {
            ortho_span = ortho_span.max(span);
            assert_eq!(
                s,
                attr(&panels[0], "data-scale"),
                "{name}: one orthographic scale"
            );
        }
    }
    assert!(
        (ortho_span - INNER).abs() < 2e-3,
        "{name}: orthographic spans {ortho_span}"
    );
    for (what, lengths, fraction) in [("triad", &triads, 0.08), ("arrow", &arrow_lengths, 0.12)] {
        assert!(
            !lengths.is_empty(),
            "{name}: no {what} long enough to measure"
        );
        for l in lengths {
            assert!(
                (l / reach - fraction).abs() < 1e-3,
                "{name}: {what} of {l} m"
            );
        }
    }
    // The scale bar: 1, 2 or 5 × 10ⁿ m, drawn between a tenth and a quarter of the inner
    // square at the orthographic scale.
    let bar = doc
        .descendants()
        .find(|n| n.attribute("class") == Some("scale-bar"))
        .unwrap();
    let line = bar.children().find(|c| c.has_tag_name("line")).unwrap();
    let ((x1, _), (x2, _)) = line_ends(&line);
    let label = bar.children().find(|c| c.has_tag_name("text")).unwrap();
    let metres: f64 = label
        .text()
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let mantissa = metres / 10f64.powf(metres.log10().floor());
    assert!(
        [1.0, 2.0, 5.0].iter().any(|m| (mantissa - m).abs() < 1e-9),
        "{name}: {metres} m"
    );
    let ortho = attr(&panels[0], "data-scale");
    assert!(
        ((x2 - x1) - metres * ortho).abs() < 2e-3,
        "{name}: bar of {metres} m"
    );
    assert!(
        (0.1 * INNER..=0.25 * INNER).contains(&(x2 - x1)),
        "{name}: {}",
        x2 - x1
    );
    // Its label follows it, and the canvas ends just below the legend.
    let label_x = attr(&label, "x");
    assert!(
        label_x > x2 && label_x < x2 + 20.0,
        "{name}: label at {label_x}"
    );
    let svg = doc.root_element();
    let (width, height) = (attr(&svg, "width"), attr(&svg, "height"));
    let bottom = attr(&label, "y");
    assert_eq!(width, 2.0 * PANEL, "{name}");
    assert!(
        bottom > 2.0 * PANEL && bottom < height && height <= bottom + 20.0,
        "{name}"
    );
    assert_eq!(
        svg.attribute("viewBox"),
        Some(&*format!("0 0 {width} {height}"))
    );
}

//! `kinechain render`: the SVG parses, has one group per link, draws every link origin where the
//! stated projection puts its `fk` position, and is the same bytes every time.

mod common;

use common::*;
use kinechain::render::{View, svg};
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
            svg(&chain, &poses)
        };
        let again = {
            let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
            svg(&chain, &poses)
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

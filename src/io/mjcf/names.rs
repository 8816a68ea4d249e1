//! The names kinechain gives the bodies, joints and sites of an MJCF model: the file's, and
//! for unnamed elements names made from their MuJoCo ids that no name of the file takes.

use super::scene::{self, Scene};
use super::tree::{self, Problem};
use std::collections::HashSet;

/// The names of a scene's bodies, joints and sites, by MuJoCo id: the file's names (with the
/// prefixes and suffixes of attachments and replicas), and for unnamed elements `body#ID`,
/// `joint#ID` and `site#ID` (MuJoCo's id of the element), with a `#` more for each time that
/// name is taken by an element of the file. A site's link is called `site:NAME` when a body has
/// its name.
pub(super) struct Names {
    pub(super) bodies: Vec<String>,
    pub(super) joints: Vec<String>,
    pub(super) sites: Vec<String>,
}

impl Names {
    pub(super) fn of(scene: &Scene<'_>) -> Result<Names, Problem> {
        // The names the file gives, each kind checked for repeats as MuJoCo does.
        let given = |items: &mut dyn Iterator<Item = &scene::Item<'_>>, kind: &str| {
            let mut seen: std::collections::HashMap<String, tree::At> = Default::default();
            for item in items {
                if let Some(n) = &item.name
                    && let Some(first) = seen.insert(n.clone(), item.el.at)
                {
                    return Err(Problem::at(
                        item.el.at,
                        format!(
                            "repeated name '{n}' in {kind} (the first is at line {}, column {}{})",
                            first.line,
                            first.column,
                            if first.file == item.el.at.file {
                                ""
                            } else {
                                " of another file"
                            }
                        ),
                    ));
                }
            }
            Ok(seen.into_keys().collect::<HashSet<String>>())
        };
        let bodies_given = given(&mut scene.bodies.iter().map(|b| &b.item), "body")?;
        let joints = || scene.bodies.iter().flat_map(|b| b.joints.iter());
        let sites = || scene.bodies.iter().flat_map(|b| b.sites.iter());
        let joints_given = given(&mut joints(), "joint")?;
        let sites_given = given(&mut sites(), "site")?;
        let links_given: HashSet<&String> = bodies_given.iter().chain(&sites_given).collect();
        let fresh = |kind: &str, id: usize, taken: &dyn Fn(&str) -> bool| {
            let mut hashes = "#".to_string();
            loop {
                let n = format!("{kind}{hashes}{id}");
                if !taken(&n) {
                    return n;
                }
                hashes.push('#');
            }
        };
        let link_taken = |n: &str| links_given.contains(&n.to_string());
        let bodies = scene
            .bodies
            .iter()
            .enumerate()
            .map(|(id, b)| match (&b.item.name, id) {
                (_, 0) => "world".to_string(),
                (Some(n), _) => n.clone(),
                (None, _) => fresh("body", id, &link_taken),
            })
            .collect();
        let joints = joints()
            .enumerate()
            .map(|(id, j)| match &j.name {
                Some(n) => n.clone(),
                None => fresh("joint", id, &|n| joints_given.contains(n)),
            })
            .collect();
        let sites = sites()
            .enumerate()
            .map(|(id, s)| match &s.name {
                Some(n) if bodies_given.contains(n) || n == "world" => fresh_site(n, &link_taken),
                Some(n) => n.clone(),
                None => fresh("site", id, &link_taken),
            })
            .collect();
        Ok(Names {
            bodies,
            joints,
            sites,
        })
    }

    pub(super) fn links(&self) -> impl Iterator<Item = String> + '_ {
        self.bodies.iter().chain(&self.sites).cloned()
    }
}

/// `site:NAME` for a site that has a body's name (with more `:` while that too is taken).
fn fresh_site(name: &str, taken: &dyn Fn(&str) -> bool) -> String {
    let mut colons = ":".to_string();
    loop {
        let n = format!("site{colons}{name}");
        if !taken(&n) {
            return n;
        }
        colons.push(':');
    }
}

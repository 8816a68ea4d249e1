//! What a link holds besides its name (visuals, collisions, inertial): none of it changes a
//! pose, so what is malformed in it draws a warning, never a refusal.

use super::{Reader, qualified_name};
use roxmltree::Node;

impl<'d, 'i> Reader<'d, 'i> {
    /// Warnings for what is malformed in a link's visuals, collisions and inertial (none of
    /// which changes a pose), and for text directly inside the link.
    pub(super) fn link_contents(&mut self, link: Node<'d, 'i>, name: &str) {
        let label = format!("link '{name}'");
        let mut inertials = 0;
        let text = format!("{label}: text inside <link> is not URDF and is ignored");
        for part in self.elements(link, &text) {
            match qualified_name(self.doc, part) {
                "inertial" => {
                    inertials += 1;
                    if inertials == 2 {
                        self.ignored(part, &label, "a second <inertial>");
                    }
                    self.inertial(part, &label);
                }
                "visual" => self.shape(part, &label, true),
                "collision" => self.shape(part, &label, false),
                _ => {}
            }
        }
    }

    /// A warning that `what`, at `node`, is not URDF and is ignored.
    fn ignored(&mut self, node: Node<'_, '_>, label: &str, what: &str) {
        self.notes.add(node.range().start, || {
            format!("{label}: {what} is not valid URDF; ignored (it does not change a pose)")
        });
    }

    /// Checks the numbers of an `<origin>` outside the kinematics.
    fn loose_origin(&mut self, origin: Node<'d, 'i>, label: &str) {
        for attr in ["xyz", "rpy"] {
            self.loose_numbers(origin, label, attr, 3);
        }
    }

    /// A warning when attribute `attr` of `node`, if present, is not `count` numbers.
    fn loose_numbers(&mut self, node: Node<'d, 'i>, label: &str, attr: &str, count: usize) {
        let Some(a) = node.attribute_node(attr) else {
            return;
        };
        let value = a.value();
        let tokens: Vec<&str> = value.split_whitespace().collect();
        if tokens.len() != count || tokens.iter().any(|t| t.parse::<f64>().is_err()) {
            let element = qualified_name(self.doc, node);
            let what = if count == 1 {
                "a number".to_string()
            } else {
                format!("{count} numbers")
            };
            self.notes.add(a.range().start, || {
                format!(
                    "{label}: <{element}> attribute {attr}=\"{value}\" is not {what}; ignored (it does not change a pose)"
                )
            });
        }
    }

    /// Checks an `<inertial>`: its origin, mass and inertia.
    fn inertial(&mut self, inertial: Node<'d, 'i>, label: &str) {
        for part in inertial.children().filter(Node::is_element) {
            match qualified_name(self.doc, part) {
                "origin" => self.loose_origin(part, label),
                "mass" => self.loose_numbers(part, label, "value", 1),
                "inertia" => {
                    for attr in ["ixx", "ixy", "ixz", "iyy", "iyz", "izz"] {
                        self.loose_numbers(part, label, attr, 1);
                    }
                }
                _ => {}
            }
        }
    }

    /// Checks a `<visual>` or `<collision>`: its origin, one geometry, and (visuals) at most one
    /// material.
    fn shape(&mut self, shape: Node<'d, 'i>, label: &str, visual: bool) {
        let (mut geometries, mut materials) = (0, 0);
        for part in shape.children().filter(Node::is_element) {
            match qualified_name(self.doc, part) {
                "origin" => self.loose_origin(part, label),
                "geometry" => {
                    geometries += 1;
                    if geometries == 2 {
                        self.ignored(part, label, "a second <geometry>");
                    }
                    self.geometry(part, label);
                }
                "material" if visual => {
                    materials += 1;
                    if materials == 2 {
                        self.ignored(part, label, "a second <material> in a <visual>");
                    }
                    for color in part
                        .children()
                        .filter(|c| c.is_element() && qualified_name(self.doc, *c) == "color")
                    {
                        self.loose_numbers(color, label, "rgba", 4);
                    }
                }
                _ => {}
            }
        }
        if geometries == 0 {
            let element = if visual { "<visual>" } else { "<collision>" };
            self.ignored(shape, label, &format!("a {element} without <geometry>"));
        }
    }

    /// Checks a `<geometry>`: one shape, with its numbers.
    fn geometry(&mut self, geometry: Node<'d, 'i>, label: &str) {
        let mut shapes = 0;
        for part in geometry.children().filter(Node::is_element) {
            let element = qualified_name(self.doc, part);
            match element {
                "box" => self.loose_numbers(part, label, "size", 3),
                "cylinder" | "capsule" => {
                    self.loose_numbers(part, label, "radius", 1);
                    self.loose_numbers(part, label, "length", 1);
                }
                "sphere" => self.loose_numbers(part, label, "radius", 1),
                "mesh" => self.loose_numbers(part, label, "scale", 3),
                other if other.contains(':') => continue,
                other => {
                    self.ignored(part, label, &format!("<{other}> inside <geometry>"));
                    continue;
                }
            }
            shapes += 1;
            if shapes == 2 {
                self.ignored(part, label, "a second shape in one <geometry>");
            }
        }
    }
}

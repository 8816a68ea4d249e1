//! `kinechain info`: the joints in `q` order, their limits, and the links.

use crate::cli::args::OutputFormat;
use crate::cli::common::write_line;
use crate::cli::error::CliError;
use crate::eval::Chain;
use serde_json::{Map, Value, json};
use std::io::Write;

pub(super) fn limits_json(joint: &crate::model::chain::Joint) -> Value {
    let one = |l: &Option<crate::model::joint::Limits>| match l {
        Some(l) => json!([l.lower, l.upper]),
        None => Value::Null,
    };
    match joint.limits() {
        [l] => one(l),
        [theta, d] => json!({"theta": one(theta), "d": one(d)}),
        _ => Value::Null,
    }
}

/// The limits column of `info --format table`: `[lower, upper]` or `none`, a cylindrical
/// joint's as `theta [..], d [..]`.
pub(super) fn limits_text(joint: &crate::model::chain::Joint) -> String {
    let one = |l: &Option<crate::model::joint::Limits>| match l {
        Some(l) => format!("[{}, {}]", l.lower, l.upper),
        None => "none".to_string(),
    };
    match joint.limits() {
        [l] => one(l),
        [theta, d] => format!("theta {}, d {}", one(theta), one(d)),
        _ => String::new(),
    }
}

pub(super) fn info(
    chain: &Chain,
    format: OutputFormat,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let independent = chain.joints().iter().filter(|j| j.dof() > 0);
    let passive = chain.joints().iter().filter(|j| j.dof() == 0);
    match format {
        OutputFormat::Json => {
            let joints: Vec<Value> = independent
                .map(|j| {
                    let mut m = Map::new();
                    m.insert("name".into(), json!(j.name()));
                    m.insert("type".into(), json!(j.kind().as_str()));
                    m.insert("dof".into(), json!(j.dof()));
                    if j.nq() != j.dof() {
                        m.insert("nq".into(), json!(j.nq()));
                    }
                    m.insert("limits".into(), limits_json(j));
                    tree_json(chain, j, &mut m);
                    Value::Object(m)
                })
                .collect();
            let passive: Vec<Value> = passive
                .map(|j| {
                    let mut m = Map::new();
                    m.insert("name".into(), json!(j.name()));
                    m.insert("type".into(), json!(j.kind().as_str()));
                    tree_json(chain, j, &mut m);
                    if let Some(mimic) = j.mimic() {
                        m.insert(
                            "mimic".into(),
                            json!({
                                "joint": chain.joint(mimic.primary).name(),
                                "multiplier": mimic.multiplier,
                                "offset": mimic.offset,
                            }),
                        );
                    }
                    Value::Object(m)
                })
                .collect();
            let links: Vec<&str> = chain.links().iter().map(|l| l.name()).collect();
            let keyframes: serde_json::Map<String, Value> = chain
                .keyframes()
                .iter()
                .map(|(name, q)| (name.clone(), json!(q)))
                .collect();
            let value = json!({
                "name": chain.name(),
                "dof": chain.dof(),
                "nq": chain.nq(),
                "nv": chain.nv(),
                "q_names": crate::regression::variable_names(chain),
                "v_names": crate::regression::velocity_names(chain),
                "joints": joints,
                "passive_joints": passive,
                "links": links,
                "keyframes": keyframes,
            });
            write_line(out, &value.to_string())
        }
        OutputFormat::Csv => Err(CliError::Csv(
            "is for fk results; info prints json or table",
        )),
        OutputFormat::Table => {
            let mut text = format!(
                "{}: {} degree{} of freedom{}\n",
                chain.name(),
                chain.dof(),
                if chain.dof() == 1 { "" } else { "s" },
                quaternion_note(chain)
            );
            text.push_str(&format!(
                "{:>5}  {:<28} {:<12} {}\n",
                "q", "joint", "type", "limits"
            ));
            for j in independent {
                let limits = limits_text(j);
                let first = j.q_index().unwrap_or(0);
                let q = match j.nq() {
                    1 => first.to_string(),
                    n => format!("{first}-{}", first + n - 1),
                };
                text.push_str(&format!(
                    "{:>5}  {:<28} {:<12} {}\n",
                    q,
                    j.name(),
                    j.kind().as_str(),
                    limits
                ));
            }
            for j in passive {
                let note = match j.mimic() {
                    Some(m) => format!(
                        "mimics {} (x{} {:+})",
                        chain.joint(m.primary).name(),
                        m.multiplier,
                        m.offset
                    ),
                    None => String::new(),
                };
                text.push_str(&format!(
                    "{:>5}  {:<28} {:<12} {}\n",
                    "-",
                    j.name(),
                    j.kind().as_str(),
                    note
                ));
            }
            text.push_str("links:");
            for l in chain.links() {
                text.push(' ');
                text.push_str(l.name());
            }
            if !chain.keyframes().is_empty() {
                text.push_str("\nkeyframes:");
                for (name, _) in chain.keyframes() {
                    text.push(' ');
                    text.push_str(name);
                }
            }
            write_line(out, &text)
        }
    }
}

/// What `q` holds beyond one entry per degree of freedom: the floating joint's position and
/// quaternion, each ball joint's quaternion (empty for chains without).
fn quaternion_note(chain: &crate::eval::Chain) -> String {
    let parts: Vec<String> = chain
        .quaternions()
        .iter()
        .map(|&(j, _)| {
            let joint = chain.joint(j);
            match joint.kind() {
                crate::model::joint::JointKind::Floating => format!(
                    "the floating joint '{}': x y z, then the quaternion qw qx qy qz",
                    joint.name()
                ),
                _ => format!("the ball joint '{}': qw qx qy qz", joint.name()),
            }
        })
        .collect();
    match parts.as_slice() {
        [] => String::new(),
        _ => format!("; q has {} entries ({})", chain.nq(), parts.join("; ")),
    }
}

/// The joint's place in the tree: its `parent` and `child` links, `axis` (joint frame), and
/// `origin` and `post` as 4 × 4 rows (the child's frame is `parent · origin · M(θ, d) · post`,
/// eq. 2.119), with `theta` and `d` at `q = 0`.
fn tree_json(chain: &Chain, j: &crate::model::chain::Joint, m: &mut Map<String, Value>) {
    m.insert("parent".into(), json!(chain.link(j.parent()).name()));
    m.insert("child".into(), json!(chain.link(j.child()).name()));
    m.insert("axis".into(), json!(j.axis()));
    if let Some(spec) = chain
        .description()
        .joints()
        .iter()
        .find(|s| s.name == j.name())
    {
        m.insert("origin".into(), json!(spec.origin.to_rows()));
        m.insert("post".into(), json!(spec.post.to_rows()));
        m.insert("theta".into(), json!(spec.theta));
        m.insert("d".into(), json!(spec.d));
    }
}

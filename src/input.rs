//! Reading joint-space vectors (`q`, `q_dot`, `q_ddot`) from JSON: a flat array in `q` order,
//! or an object keyed by joint name that names every independent joint exactly once
//! (`{"j1": 0.1, "j5": [0.2, 0.05]}`; a cylindrical joint takes `[θ, d]`).

use crate::chain::Chain;
use crate::joint::JointKind;
use serde_json::Value;

/// How [`InputError::ListEntry`] describes its entry.
fn list_entry(entry: &str) -> String {
    if entry.is_empty() {
        "empty entry in the list".to_string()
    } else {
        format!("'{entry}' is not a number")
    }
}

/// A joint-space vector given as text or JSON could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum InputError {
    /// The text starts as JSON (`[` or `{`) but is not valid JSON.
    #[error("{what}: not valid JSON ({message})")]
    Json {
        /// `q`, `qd` or `qdd`.
        what: &'static str,
        /// The parser's description.
        message: String,
    },
    /// The JSON is neither an array nor an object.
    #[error("{what}: expected an array of numbers or an object keyed by joint name, found {found}")]
    NotArrayOrObject {
        /// `q`, `qd` or `qdd`.
        what: &'static str,
        /// The JSON type found.
        found: &'static str,
    },
    /// An array with the wrong number of entries.
    #[error("{what}: {got} values given, the chain has {expected} degrees of freedom")]
    WrongLength {
        /// `q`, `qd` or `qdd`.
        what: &'static str,
        /// The chain's dof.
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// An entry of a comma- or space-separated list is empty or not a number.
    #[error("{what}[{index}]: {}", list_entry(entry))]
    ListEntry {
        /// `q`, `qd` or `qdd`.
        what: &'static str,
        /// Position in the list.
        index: usize,
        /// The entry as given (trimmed; empty for `1,,2`).
        entry: String,
    },
    /// An entry is not a number.
    #[error("{what}[{index}]: expected a number, found {found}")]
    NotANumber {
        /// `q`, `qd` or `qdd`.
        what: &'static str,
        /// Position in the flattened vector.
        index: usize,
        /// The JSON type found.
        found: &'static str,
    },
    /// An object names a joint the chain does not have.
    #[error("{what}: no joint named '{name}'")]
    UnknownJoint {
        /// `q`, `qd` or `qdd`.
        what: &'static str,
        /// The name given.
        name: String,
    },
    /// An object names a joint that takes no entry of `q` (fixed or mimic).
    #[error("{what}: joint '{name}' is {reason} and takes no value")]
    NotIndependent {
        /// `q`, `qd` or `qdd`.
        what: &'static str,
        /// The joint.
        name: String,
        /// `fixed` or `a mimic of '<primary>'`.
        reason: String,
    },
    /// An object leaves out an independent joint.
    #[error("{what}: no value for joint '{name}'")]
    MissingJoint {
        /// `q`, `qd` or `qdd`.
        what: &'static str,
        /// The joint left out.
        name: String,
    },
    /// A batch line is not a JSON object with a `q` member (and optionally `qd`, `qdd`).
    #[error("{0}")]
    BatchLine(&'static str),
    /// A joint's value has the wrong shape (a number for a cylindrical joint, or a list for a
    /// one-coordinate joint).
    #[error("{what}: joint '{name}' takes {expected}")]
    Shape {
        /// `q`, `qd` or `qdd`.
        what: &'static str,
        /// The joint.
        name: String,
        /// What it takes.
        expected: &'static str,
    },
}

fn type_name(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

fn number(v: &Value, what: &'static str, index: usize) -> Result<f64, InputError> {
    v.as_f64().ok_or(InputError::NotANumber {
        what,
        index,
        found: type_name(v),
    })
}

/// Reads a joint-space vector from JSON (array or name-keyed object) into `q` order.
///
/// Finiteness and limits are checked by the evaluation functions, not here.
///
/// # Errors
/// [`InputError`] naming the entry or joint at fault.
pub fn joint_vector_from_json(
    chain: &Chain,
    value: &Value,
    what: &'static str,
) -> Result<Vec<f64>, InputError> {
    match value {
        Value::Array(items) => {
            if items.len() != chain.dof() {
                return Err(InputError::WrongLength {
                    what,
                    expected: chain.dof(),
                    got: items.len(),
                });
            }
            items
                .iter()
                .enumerate()
                .map(|(i, v)| number(v, what, i))
                .collect()
        }
        Value::Object(map) => {
            let mut out = vec![0.0; chain.dof()];
            for (name, v) in map {
                let id = chain.joint_id(name).map_err(|_| InputError::UnknownJoint {
                    what,
                    name: name.clone(),
                })?;
                let joint = chain.joint(id);
                let Some(index) = joint.q_index() else {
                    let reason = match joint.mimic() {
                        Some(m) => format!("a mimic of '{}'", chain.joint(m.primary).name()),
                        None => "fixed".to_string(),
                    };
                    return Err(InputError::NotIndependent {
                        what,
                        name: name.clone(),
                        reason,
                    });
                };
                let shape = |expected| InputError::Shape {
                    what,
                    name: name.clone(),
                    expected,
                };
                if joint.kind() == JointKind::Cylindrical {
                    let pair = v
                        .as_array()
                        .filter(|a| a.len() == 2)
                        .ok_or_else(|| shape("[theta, d] (two numbers)"))?;
                    out[index] = number(&pair[0], what, index)?;
                    out[index + 1] = number(&pair[1], what, index + 1)?;
                } else {
                    if v.is_array() {
                        return Err(shape("one number"));
                    }
                    out[index] = number(v, what, index)?;
                }
            }
            // serde_json objects keep one value per key, so a repeated name cannot reach here;
            // check that every independent joint was named.
            for joint in chain.joints() {
                if joint.q_index().is_some() && !map.contains_key(joint.name()) {
                    return Err(InputError::MissingJoint {
                        what,
                        name: joint.name().to_string(),
                    });
                }
            }
            Ok(out)
        }
        other => Err(InputError::NotArrayOrObject {
            what,
            found: type_name(other),
        }),
    }
}

/// Reads a joint-space vector from text: JSON (array or object), or numbers separated by commas
/// and/or spaces (`0.1,0.2,-0.3`).
///
/// # Errors
/// [`InputError`] naming the entry or joint at fault.
pub fn joint_vector_from_str(
    chain: &Chain,
    text: &str,
    what: &'static str,
) -> Result<Vec<f64>, InputError> {
    let trimmed = text.trim();
    if trimmed.starts_with('[') || trimmed.starts_with('{') {
        let value: Value = serde_json::from_str(trimmed).map_err(|e| InputError::Json {
            what,
            message: e.to_string(),
        })?;
        return joint_vector_from_json(chain, &value, what);
    }
    // Entries separated by commas (each one number, spaces around it allowed), or by spaces
    // alone; an empty entry (`1,,2`, a trailing comma) is an error, not skipped.
    let tokens: Vec<&str> = if trimmed.contains(',') {
        trimmed.split(',').map(str::trim).collect()
    } else {
        trimmed.split_whitespace().collect()
    };
    let values = tokens
        .iter()
        .enumerate()
        .map(|(index, t)| {
            t.parse::<f64>().map_err(|_| InputError::ListEntry {
                what,
                index,
                entry: (*t).to_string(),
            })
        })
        .collect::<Result<Vec<f64>, _>>()?;
    if values.len() != chain.dof() {
        return Err(InputError::WrongLength {
            what,
            expected: chain.dof(),
            got: values.len(),
        });
    }
    Ok(values)
}

/// One line of a batch file: `{"q": .., "qd": .., "qdd": ..}`, with `qd` and `qdd` optional and
/// each vector an array in `q` order or an object keyed by joint name.
#[derive(Clone, Debug, PartialEq)]
pub struct BatchLine {
    /// Joint positions.
    pub q: Vec<f64>,
    /// Joint velocities, when given.
    pub q_dot: Option<Vec<f64>>,
    /// Joint accelerations, when given.
    pub q_ddot: Option<Vec<f64>>,
}

/// Reads one batch line.
///
/// # Errors
/// [`InputError`]: not JSON, not an object, an unknown or missing member, or a vector that
/// [`joint_vector_from_json`] refuses.
pub fn parse_batch_line(chain: &Chain, line: &str) -> Result<BatchLine, InputError> {
    let value: Value = serde_json::from_str(line).map_err(|e| InputError::Json {
        what: "line",
        message: e.to_string(),
    })?;
    let Value::Object(map) = value else {
        return Err(InputError::BatchLine(
            "expected a JSON object {\"q\": ..} on each line",
        ));
    };
    if map
        .keys()
        .any(|k| !matches!(k.as_str(), "q" | "qd" | "qdd"))
    {
        return Err(InputError::BatchLine(
            "unknown member (a line may have only \"q\", \"qd\" and \"qdd\")",
        ));
    }
    let q = map.get("q").ok_or(InputError::BatchLine("missing \"q\""))?;
    Ok(BatchLine {
        q: joint_vector_from_json(chain, q, "q")?,
        q_dot: map
            .get("qd")
            .map(|v| joint_vector_from_json(chain, v, "qd"))
            .transpose()?,
        q_ddot: map
            .get("qdd")
            .map(|v| joint_vector_from_json(chain, v, "qdd"))
            .transpose()?,
    })
}

//! Reading joint-space vectors (`q`, `q_dot`, `q_ddot`) from JSON: a flat array in `q` order,
//! or an object keyed by joint name that names every independent joint exactly once
//! (`{"j1": 0.1, "j5": [0.2, 0.05]}`; a cylindrical joint takes `[θ, d]`).

use crate::eval::Chain;
use crate::model::error::did_you_mean;

use serde::de::{self, DeserializeSeed, Deserializer, MapAccess, SeqAccess, Visitor};
use serde_json::Value;
use std::borrow::Cow;
use std::cell::RefCell;

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
        /// `q`, `qd`, `qdd`, or `header` ([`parse_batch_row`]).
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
    #[error("{what}: no joint named '{name}'{}", did_you_mean(.suggestion))]
    UnknownJoint {
        /// `q`, `qd` or `qdd`.
        what: &'static str,
        /// The name given.
        name: String,
        /// The chain's joint whose name is closest, if it is close enough to be a likely typo
        /// (see [`closest_name`](crate::model::error::closest_name)).
        suggestion: Option<String>,
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
    /// A batch line has a member other than `q`, `qd` and `qdd`.
    #[error("unknown member \"{name}\" (a line may have only \"q\", \"qd\" and \"qdd\")")]
    UnknownMember {
        /// The member's name.
        name: String,
    },
    /// A JSON object names a member twice (a joint in a vector keyed by joint name, or `q` on a
    /// batch line): which of the two was meant is not guessed.
    #[error("{what}: member \"{name}\" is given twice")]
    DuplicateMember {
        /// `q`, `qd`, `qdd`, or `line` for a batch line.
        what: &'static str,
        /// The member's name.
        name: String,
    },
    /// A joint's value has the wrong shape (a number for a cylindrical joint, or a list for a
    /// one-coordinate joint).
    #[error("{what}: joint '{name}' takes {expected}")]
    Shape {
        /// `q`, `qd` or `qdd`.
        what: &'static str,
        /// The joint.
        name: String,
        /// What it takes.
        expected: String,
    },
    /// A CSV header's quoted name is not closed, or text follows its closing quote.
    #[error(
        "{what}: column {column}: {problem} (a quoted name is \"...\", a quote inside it \"\")"
    )]
    Quoting {
        /// `header`.
        what: &'static str,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        problem: &'static str,
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
    let width = width(chain, what);
    match value {
        Value::Array(items) => {
            if items.len() != width {
                return Err(InputError::WrongLength {
                    what,
                    expected: width,
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
            let mut out = vec![0.0; width];
            for (name, v) in map {
                let (joint, index) = independent_joint(chain, name, what)?;
                let parts = joint_parts(joint, what);
                if parts.is_empty() {
                    if v.is_array() {
                        return Err(InputError::Shape {
                            what,
                            name: name.clone(),
                            expected: "one number".into(),
                        });
                    }
                    out[index] = number(v, what, index)?;
                } else {
                    let values =
                        v.as_array()
                            .filter(|a| a.len() == parts.len())
                            .ok_or_else(|| InputError::Shape {
                                what,
                                name: name.clone(),
                                expected: format!(
                                    "[{}] ({} numbers)",
                                    parts.join(", "),
                                    ["two", "three", "four", "five", "six", "seven"]
                                        .get(parts.len().wrapping_sub(2))
                                        .copied()
                                        .unwrap_or("several")
                                ),
                            })?;
                    for (k, x) in values.iter().enumerate() {
                        out[index + k] = number(x, what, index + k)?;
                    }
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

/// Whether `what` names joint positions (`q`, or a header of them) rather than rates (`qd`,
/// `qdd`, `q_dot`, `q_ddot`): positions have [`Model::nq`](crate::Model::nq) entries, rates
/// [`Model::nv`](crate::Model::nv) (they differ for a floating joint).
fn is_positions(what: &str) -> bool {
    !(what.starts_with("qd") || what.starts_with("q_d"))
}

/// Entries of a vector `what` of `chain`.
fn width(chain: &Chain, what: &str) -> usize {
    if is_positions(what) {
        chain.nq()
    } else {
        chain.nv()
    }
}

/// The names of a joint's entries in a vector `what` when it has more than one
/// ([`JointKind::components`](crate::JointKind::components)).
fn joint_parts(joint: &crate::model::chain::Joint, what: &str) -> &'static [&'static str] {
    let (q, v) = joint.kind().components();
    if is_positions(what) { q } else { v }
}

/// The joint named `name` and its first entry of the vector `what` (`q`, or a rate); an error
/// naming the joint unless it is one that takes values (not fixed, not a mimic).
fn independent_joint<'c>(
    chain: &'c Chain,
    name: &str,
    what: &'static str,
) -> Result<(&'c crate::model::chain::Joint, usize), InputError> {
    let id = chain.joint_id(name).map_err(|e| InputError::UnknownJoint {
        what,
        name: name.to_string(),
        suggestion: e.suggestion().map(str::to_string),
    })?;
    let joint = chain.joint(id);
    let first = if is_positions(what) {
        joint.q_index()
    } else {
        joint.v_index()
    };
    match first {
        Some(index) => Ok((joint, index)),
        None => Err(InputError::NotIndependent {
            what,
            name: name.to_string(),
            reason: match joint.mimic() {
                Some(m) => format!("a mimic of '{}'", chain.joint(m.primary).name()),
                None => "fixed".to_string(),
            },
        }),
    }
}

/// The entries of a list of numbers or names: separated by commas (each entry trimmed, an empty
/// one kept), or by spaces alone.
fn list_entries(trimmed: &str) -> impl Iterator<Item = &str> + Clone {
    let commas = trimmed.contains(',');
    trimmed
        .split(move |c: char| if commas { c == ',' } else { c.is_whitespace() })
        .map(str::trim)
        .filter(move |entry| commas || !entry.is_empty())
}

/// The numbers of a list ([`list_entries`]) as a vector of the chain's length, entry `k` at
/// `q[order[k]]` when an `order` ([`CsvHeader::columns`]) is given.
fn list_values(
    chain: &Chain,
    trimmed: &str,
    what: &'static str,
    order: Option<&[usize]>,
) -> Result<Vec<f64>, InputError> {
    let width = width(chain, what);
    let mut q = vec![0.0; width];
    let mut count = 0;
    for (index, entry) in list_entries(trimmed).enumerate() {
        let x = entry.parse::<f64>().map_err(|_| InputError::ListEntry {
            what,
            index,
            entry: entry.to_string(),
        })?;
        let slot = order.map_or(Some(index), |order| order.get(index).copied());
        if let Some(value) = slot.and_then(|i| q.get_mut(i)) {
            *value = x;
        }
        count += 1;
    }
    if count != width {
        return Err(InputError::WrongLength {
            what,
            expected: width,
            got: count,
        });
    }
    Ok(q)
}

/// The order of the columns of a file of joint values, read from its header row by
/// [`csv_header`]: entry `k` of each row below the header is `q[columns()[k]]`. Every entry of
/// the chain's `q` is one column.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CsvHeader {
    columns: Vec<usize>,
}

impl CsvHeader {
    /// The entry of `q` that each column holds, in the header's order.
    #[must_use]
    pub fn columns(&self) -> &[usize] {
        &self.columns
    }
}

/// Reads the header row of a file of joint values (CSV): a line of joint names, none of its
/// entries a number, separated as [`joint_vector_from_str`] separates numbers. Returns `None`
/// for a line that is not a header (empty, JSON, or with an entry that is a number), otherwise
/// the order of its columns, which [`parse_batch_row`] applies to the rows below it. The header
/// names every joint that takes values once; a cylindrical joint's name stands for two columns,
/// θ then d.
///
/// # Errors
/// [`InputError`] (its `what` is `header`): a name that is not a joint's, or a fixed or mimic
/// joint's, a joint named twice, or one left out.
///
/// ```
/// # use kinechain::{Chain, io::input::{csv_header, parse_batch_row}};
/// let chain = Chain::from_file("robots/planar3.yaml")?;
/// let header = csv_header(&chain, "j3,j1,j2").expect("a row of names")?;
/// assert_eq!(header.columns(), [2, 0, 1]);
/// assert_eq!(parse_batch_row(&chain, "0.3,0.1,0.2", Some(&header))?.q, [0.1, 0.2, 0.3]);
/// assert_eq!(csv_header(&chain, "0.1,0.2,0.3"), None);
/// assert!(csv_header(&chain, "j1,j2").is_some_and(|h| h.is_err()));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[must_use]
pub fn csv_header(chain: &Chain, line: &str) -> Option<Result<CsvHeader, InputError>> {
    const WHAT: &str = "header";
    let trimmed = line.trim();
    if trimmed.is_empty() || trimmed.starts_with('[') || trimmed.starts_with('{') {
        return None;
    }
    let names: Vec<Cow<'_, str>> = if trimmed.contains('"') {
        match quoted_entries(trimmed, WHAT) {
            Ok(names) => names,
            Err(e) => return Some(Err(e)),
        }
    } else {
        list_entries(trimmed).map(Cow::Borrowed).collect()
    };
    if names.iter().any(|n| n.parse::<f64>().is_ok()) {
        return None;
    }
    let read = || {
        let mut order = Vec::with_capacity(chain.nq());
        let mut named = vec![false; chain.nq()];
        for name in &names {
            let name = name.as_ref();
            let columns = header_columns(chain, name)?;
            if named[columns.clone()].iter().any(|&n| n) {
                return Err(InputError::DuplicateMember {
                    what: WHAT,
                    name: name.to_string(),
                });
            }
            named[columns.clone()].fill(true);
            order.extend(columns);
        }
        if let Some(joint) = chain.joints().iter().find(|j| {
            j.q_index()
                .is_some_and(|i| named[i..i + j.nq()].contains(&false))
        }) {
            return Err(InputError::MissingJoint {
                what: WHAT,
                name: joint.name().to_string(),
            });
        }
        Ok(CsvHeader { columns: order })
    };
    Some(read())
}

/// The entries of `q` a header's column name stands for: every entry of a joint named by its
/// name (a cylindrical joint's two, a floating joint's seven), or one entry of such a joint named
/// `JOINT.COMPONENT` (`root_joint.qw`, `slide.d`), as [`Model::variables`](crate::Model::variables)
/// names them.
fn header_columns(chain: &Chain, name: &str) -> Result<std::ops::Range<usize>, InputError> {
    const WHAT: &str = "header";
    if chain.joint_id(name).is_err()
        && let Some((joint_name, component)) = name.rsplit_once('.')
        && let Ok(id) = chain.joint_id(joint_name)
    {
        let joint = chain.joint(id);
        let parts = joint.kind().components().0;
        if let (Some(k), Some(first)) =
            (parts.iter().position(|&p| p == component), joint.q_index())
        {
            return Ok(first + k..first + k + 1);
        }
    }
    let (joint, index) = independent_joint(chain, name, WHAT)?;
    Ok(index..index + joint.nq())
}

/// The comma-separated entries of a CSV line in which entries may be quoted as RFC 4180 (and
/// Python's `csv` module) quote them: `"j,2"` is the name `j,2`, and `""` inside quotes is one `"`.
/// Spaces around an entry are dropped.
fn quoted_entries<'a>(line: &'a str, what: &'static str) -> Result<Vec<Cow<'a, str>>, InputError> {
    let mut entries = Vec::new();
    let mut rest = line;
    loop {
        let column = entries.len() + 1;
        let fail = |problem| InputError::Quoting {
            what,
            column,
            problem,
        };
        let start = rest.trim_start();
        if let Some(quoted) = start.strip_prefix('"') {
            let mut name = String::new();
            let mut chars = quoted.char_indices();
            let after = loop {
                match chars.next() {
                    None => return Err(fail("the quote is not closed")),
                    Some((i, '"')) => {
                        if quoted[i + 1..].starts_with('"') {
                            name.push('"');
                            chars.next();
                        } else {
                            break &quoted[i + 1..];
                        }
                    }
                    Some((_, c)) => name.push(c),
                }
            };
            entries.push(Cow::Owned(name));
            let after = after.trim_start();
            match after.strip_prefix(',') {
                Some(next) => rest = next,
                None if after.is_empty() => return Ok(entries),
                None => return Err(fail("text follows the closing quote")),
            }
        } else {
            let (entry, next) = match start.split_once(',') {
                Some((entry, next)) => (entry, Some(next)),
                None => (start, None),
            };
            if entry.contains('"') {
                return Err(fail("a quote inside a name that is not quoted"));
            }
            entries.push(Cow::Borrowed(entry.trim()));
            match next {
                Some(next) => rest = next,
                None => return Ok(entries),
            }
        }
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
        let value = parse_json(trimmed, what)?;
        return joint_vector_from_json(chain, &value, what);
    }
    // Entries separated by commas (each one number, spaces around it allowed), or by spaces
    // alone; an empty entry (`1,,2`, a trailing comma) is an error, not skipped.
    list_values(chain, trimmed, what, None)
}

/// One line of a batch file: `{"q": .., "qd": .., "qdd": ..}`, with `qd` and `qdd` optional and
/// each vector an array in `q` order or an object keyed by joint name; or `q` alone (see
/// [`parse_batch_line`]).
#[derive(Clone, Debug, PartialEq)]
pub struct BatchLine {
    /// Joint positions.
    pub q: Vec<f64>,
    /// Joint velocities, when given.
    pub q_dot: Option<Vec<f64>>,
    /// Joint accelerations, when given.
    pub q_ddot: Option<Vec<f64>>,
}

/// Reads one batch line: an object `{"q": .., "qd": .., "qdd": ..}` (`qd` and `qdd` optional),
/// or `q` alone in a form [`joint_vector_from_str`] reads (a JSON array, or numbers separated
/// by commas or spaces, as in a CSV file of joint values).
///
/// # Errors
/// [`InputError`]: not JSON, not an object, an unknown or missing member, or a vector that
/// [`joint_vector_from_json`] refuses; for a line that is not an object, what
/// [`joint_vector_from_str`] refuses.
pub fn parse_batch_line(chain: &Chain, line: &str) -> Result<BatchLine, InputError> {
    parse_batch_row(chain, line, None)
}

/// As [`parse_batch_line`], with the entries of a row of plain numbers (not JSON) in the order
/// of `header`, the [`csv_header`] of the file's first row (`None` for a file without one).
///
/// # Errors
/// As [`parse_batch_line`]; also [`InputError::WrongLength`] (its `what` is `header`) for a
/// header read for a chain with another number of degrees of freedom.
pub fn parse_batch_row(
    chain: &Chain,
    line: &str,
    header: Option<&CsvHeader>,
) -> Result<BatchLine, InputError> {
    let columns = match header {
        Some(h) if h.columns.len() != chain.nq() => {
            return Err(InputError::WrongLength {
                what: "header",
                expected: chain.nq(),
                got: h.columns.len(),
            });
        }
        h => h.map(CsvHeader::columns),
    };
    let trimmed = line.trim();
    if !trimmed.starts_with('{') {
        // A JSON array is in `q` order; a row of numbers in the header's.
        let q = if trimmed.starts_with('[') {
            joint_vector_from_str(chain, trimmed, "q")?
        } else {
            list_values(chain, trimmed, "q", columns)?
        };
        return Ok(BatchLine {
            q,
            q_dot: None,
            q_ddot: None,
        });
    }
    let value = parse_json(line, "line")?;
    let Value::Object(map) = value else {
        return Err(InputError::BatchLine(
            "expected a JSON object {\"q\": ..} on each line",
        ));
    };
    if let Some(name) = map
        .keys()
        .find(|k| !matches!(k.as_str(), "q" | "qd" | "qdd"))
    {
        return Err(InputError::UnknownMember { name: name.clone() });
    }
    let q = map.get("q").ok_or(InputError::BatchLine("missing \"q\""))?;
    if map.contains_key("qdd") && !map.contains_key("qd") {
        return Err(InputError::BatchLine(
            "\"qdd\" needs \"qd\" (accelerations depend on velocities)",
        ));
    }
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

/// Parses JSON text, refusing an object that names a member twice (`serde_json::Value` would
/// keep the last silently).
fn parse_json(text: &str, what: &'static str) -> Result<Value, InputError> {
    let duplicate = RefCell::new(None);
    let mut de = serde_json::Deserializer::from_str(text);
    let value = UniqueMembers(&duplicate)
        .deserialize(&mut de)
        .and_then(|v| de.end().map(|()| v))
        .map_err(|e| InputError::Json {
            what,
            message: e.to_string(),
        })?;
    match duplicate.into_inner() {
        Some(name) => Err(InputError::DuplicateMember { what, name }),
        None => Ok(value),
    }
}

/// Reads a JSON value as [`Value`] does, noting in its cell the first member name an object
/// repeats.
#[derive(Clone, Copy)]
struct UniqueMembers<'a>(&'a RefCell<Option<String>>);

impl<'de> DeserializeSeed<'de> for UniqueMembers<'_> {
    type Value = Value;

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<Value, D::Error> {
        deserializer.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for UniqueMembers<'_> {
    type Value = Value;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("a JSON value")
    }

    fn visit_bool<E: de::Error>(self, v: bool) -> Result<Value, E> {
        Ok(Value::Bool(v))
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Value, E> {
        Ok(Value::from(v))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Value, E> {
        Ok(Value::from(v))
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Value, E> {
        Ok(Value::from(v))
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<Value, E> {
        Ok(Value::String(v.to_string()))
    }

    fn visit_unit<E: de::Error>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }

    fn visit_seq<S: SeqAccess<'de>>(self, mut seq: S) -> Result<Value, S::Error> {
        let mut items = Vec::new();
        while let Some(item) = seq.next_element_seed(self)? {
            items.push(item);
        }
        Ok(Value::Array(items))
    }

    fn visit_map<M: MapAccess<'de>>(self, mut map: M) -> Result<Value, M::Error> {
        let mut members = serde_json::Map::new();
        while let Some(name) = map.next_key::<String>()? {
            let value = map.next_value_seed(self)?;
            if members.contains_key(&name) {
                self.0.borrow_mut().get_or_insert(name);
            } else {
                members.insert(name, value);
            }
        }
        Ok(Value::Object(members))
    }
}

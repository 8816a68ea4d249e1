//! `xacro.load_yaml`: a YAML file as xacro values, read the way ROS's xacro reads it (PyYAML's
//! safe loader: YAML 1.1 scalars, merge keys, anchors), with ROS's unit tags (`!degrees`,
//! `!radians`, `!meters`, `!millimeters`, `!foot`, `!inches`) whose text is an expression.

use super::expr;
use super::value::Value;
use granit_parser::{Event, Parser, ScalarStyle, Tag};
use std::collections::HashMap;
use std::rc::Rc;

/// Most nodes (scalars, sequences, mappings, aliases) one YAML file may hold.
const MAX_NODES: usize = 1_000_000;
/// Deepest nesting of sequences and mappings.
const MAX_DEPTH: usize = 256;

/// The value of the YAML text `text` (one document; an empty file is `None`).
///
/// # Errors
/// A message with the line and column of a syntax error, an unknown tag, a unit expression that
/// is not a number, more than one document, or a file beyond the bounds.
pub(crate) fn parse(text: &str) -> Result<Value, String> {
    let mut parser = Parser::new_from_str(text);
    let mut loader = Loader {
        anchors: HashMap::new(),
        nodes: 0,
    };
    let mut stack: Vec<Frame> = Vec::new();
    let mut document: Option<Value> = None;
    let mut documents = 0;
    while let Some(event) = parser.next_event() {
        let (event, span) = event.map_err(|e| e.to_string())?;
        let at = |message: String| {
            format!(
                "line {} column {}: {message}",
                span.start.line(),
                span.start.col() + 1
            )
        };
        let finished: Option<(Value, usize)> = match event {
            Event::DocumentStart(..) => {
                documents += 1;
                if documents > 1 {
                    return Err(at("the file holds more than one YAML document".into()));
                }
                None
            }
            Event::Scalar(text, style, anchor, tag) => {
                loader.count().map_err(at)?;
                let v = scalar(&text, style, tag.as_deref()).map_err(at)?;
                Some((v, anchor))
            }
            Event::SequenceStart(_, anchor, ref tag) | Event::MappingStart(_, anchor, ref tag) => {
                loader.count().map_err(at)?;
                if let Some(t) = tag.as_deref()
                    && !core_tag(t, &["seq", "map", "omap", "set"])
                {
                    return Err(at(format!("unknown tag '{}{}'", t.handle(), t.suffix())));
                }
                if stack.len() >= MAX_DEPTH {
                    return Err(at(format!("nested more than {MAX_DEPTH} deep")));
                }
                let mapping = matches!(event, Event::MappingStart(..));
                stack.push(Frame {
                    mapping,
                    anchor,
                    items: Vec::new(),
                    key: None,
                    pairs: Vec::new(),
                    merged: Vec::new(),
                });
                None
            }
            Event::SequenceEnd => stack
                .pop()
                .map(|f| (Value::List(Rc::new(f.items)), f.anchor)),
            Event::MappingEnd => stack.pop().map(|f| {
                // Merged keys (`<<: *base`) come first, and the mapping's own keys override
                // them, as PyYAML orders them.
                let mut pairs: Vec<(Value, Value)> = Vec::new();
                for (k, v) in f.merged.into_iter().chain(f.pairs) {
                    if let Some(slot) = pairs.iter_mut().find(|(k2, _)| k2.equals(&k)) {
                        slot.1 = v;
                    } else {
                        pairs.push((k, v));
                    }
                }
                (Value::Dict(Rc::new(pairs)), f.anchor)
            }),
            Event::Alias(id) => {
                loader.count().map_err(at)?;
                let v = loader
                    .anchors
                    .get(&id)
                    .cloned()
                    .ok_or_else(|| at("alias to an unknown anchor".into()))?;
                Some((v, 0))
            }
            _ => None,
        };
        let Some((value, anchor)) = finished else {
            continue;
        };
        if anchor != 0 {
            loader.anchors.insert(anchor, value.clone());
        }
        match stack.last_mut() {
            None => document = Some(value),
            Some(frame) if !frame.mapping => frame.items.push(value),
            Some(frame) => match frame.key.take() {
                None => frame.key = Some(value),
                Some(key) if matches!(&key, Value::Str(s) if &**s == "<<") => match value {
                    Value::Dict(d) => frame.merged.extend(d.iter().cloned()),
                    Value::List(list) => {
                        // The first mapping listed wins, so it is merged last.
                        for item in list.iter().rev() {
                            match item {
                                Value::Dict(d) => frame.merged.extend(d.iter().cloned()),
                                _ => return Err(at("a merge key '<<' takes mappings".into())),
                            }
                        }
                    }
                    _ => return Err(at("a merge key '<<' takes mappings".into())),
                },
                Some(key) => {
                    if let Some(slot) = frame.pairs.iter_mut().find(|(k, _)| k.equals(&key)) {
                        slot.1 = value;
                    } else {
                        frame.pairs.push((key, value));
                    }
                }
            },
        }
    }
    Ok(document.unwrap_or(Value::None))
}

struct Loader {
    anchors: HashMap<usize, Value>,
    nodes: usize,
}

impl Loader {
    fn count(&mut self) -> Result<(), String> {
        self.nodes += 1;
        if self.nodes > MAX_NODES {
            Err(format!("more than {MAX_NODES} YAML nodes"))
        } else {
            Ok(())
        }
    }
}

struct Frame {
    mapping: bool,
    anchor: usize,
    items: Vec<Value>,
    key: Option<Value>,
    pairs: Vec<(Value, Value)>,
    merged: Vec<(Value, Value)>,
}

/// Whether `tag` is the YAML core tag `!!NAME` for one of `names`.
fn core_tag(tag: &Tag, names: &[&str]) -> bool {
    tag.is_yaml_core_schema() && names.contains(&tag.suffix())
}

/// The unit tags ROS's xacro adds, with their factors to radians or metres.
const UNITS: [(&str, f64); 6] = [
    ("radians", 1.0),
    ("degrees", std::f64::consts::PI / 180.0),
    ("meters", 1.0),
    ("millimeters", 0.001),
    ("foot", 0.3048),
    ("inches", 0.0254),
];

fn scalar(text: &str, style: ScalarStyle, tag: Option<&Tag>) -> Result<Value, String> {
    if let Some(tag) = tag {
        if tag.is_yaml_core_schema() {
            return match tag.suffix() {
                "str" => Ok(Value::str(text)),
                "int" => resolve_int(text).ok_or_else(|| format!("'{text}' is not an int")),
                "float" => resolve_float(text)
                    .or_else(|| {
                        resolve_int(text)
                            .and_then(|v| v.number())
                            .map(|n| Value::Float(n.float()))
                    })
                    .ok_or_else(|| format!("'{text}' is not a float")),
                "bool" => resolve_bool(text).ok_or_else(|| format!("'{text}' is not a bool")),
                "null" => Ok(Value::None),
                other => Err(format!("unknown tag '!!{other}'")),
            };
        }
        if tag.handle() == "!" {
            if let Some((_, factor)) = UNITS.iter().find(|(name, _)| *name == tag.suffix()) {
                return unit(text, *factor).map_err(|e| format!("!{} {text}: {e}", tag.suffix()));
            }
            if tag.suffix().is_empty() {
                return Ok(Value::str(text));
            }
        }
        return Err(format!(
            "unknown tag '{}{}' (xacro's YAML knows !degrees, !radians, !meters, !millimeters, !foot and !inches)",
            tag.handle(),
            tag.suffix()
        ));
    }
    if style != ScalarStyle::Plain {
        return Ok(Value::str(text));
    }
    if matches!(text, "" | "~" | "null" | "Null" | "NULL") {
        return Ok(Value::None);
    }
    Ok(resolve_bool(text)
        .or_else(|| resolve_int(text))
        .or_else(|| resolve_float(text))
        .unwrap_or_else(|| Value::str(text)))
}

/// A unit-tagged scalar: its text evaluated as an expression, times the unit's factor (as ROS's
/// xacro computes it: `float(value) * factor`).
fn unit(text: &str, factor: f64) -> Result<Value, String> {
    struct Globals;
    impl expr::Scope for Globals {
        fn lookup(&mut self, name: &str) -> Result<Value, String> {
            expr::global(name).ok_or_else(|| format!("name '{name}' is not defined"))
        }
        fn namespace_get(&mut self, _: usize, name: &str) -> Result<Value, String> {
            Err(format!("name '{name}' is not defined"))
        }
        fn call_xacro(
            &mut self,
            name: &str,
            _: Vec<Value>,
            _: Vec<(Rc<str>, Value)>,
        ) -> Result<Value, String> {
            Err(format!("xacro.{name} cannot be called in a YAML unit"))
        }
        fn spend(&mut self, _: usize) -> Result<(), String> {
            Ok(())
        }
    }
    let v = expr::evaluate(text, &mut Globals)?;
    let x = v
        .number()
        .ok_or_else(|| format!("not a number but a {}", v.type_name()))?;
    Ok(Value::Float(x.float() * factor))
}

/// YAML 1.1 booleans (PyYAML's set).
fn resolve_bool(text: &str) -> Option<Value> {
    match text {
        "yes" | "Yes" | "YES" | "true" | "True" | "TRUE" | "on" | "On" | "ON" => {
            Some(Value::Bool(true))
        }
        "no" | "No" | "NO" | "false" | "False" | "FALSE" | "off" | "Off" | "OFF" => {
            Some(Value::Bool(false))
        }
        _ => None,
    }
}

/// YAML 1.1 integers: decimal, `0x` hexadecimal, `0b` binary and `0…` octal, with `_`
/// separators.
fn resolve_int(text: &str) -> Option<Value> {
    let (negative, body) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text.strip_prefix('+').unwrap_or(text)),
    };
    let clean: String = body.chars().filter(|&c| c != '_').collect();
    if clean.is_empty() || body.starts_with('_') {
        return None;
    }
    let (digits, radix) = if let Some(h) = clean.strip_prefix("0x") {
        (h, 16)
    } else if let Some(b) = clean.strip_prefix("0b") {
        (b, 2)
    } else if clean.len() > 1 && clean.starts_with('0') {
        (&clean[1..], 8)
    } else {
        (clean.as_str(), 10)
    };
    if digits.is_empty() || !digits.chars().all(|c| c.is_digit(radix)) {
        return None;
    }
    let magnitude = i64::from_str_radix(digits, radix).ok()?;
    Some(Value::Int(if negative { -magnitude } else { magnitude }))
}

/// YAML 1.1 floats as PyYAML resolves them: a decimal point is required and an exponent needs
/// its sign (`1.5e-3`, `.5`, `1.`; `1e-3` stays a string), `.inf`, `.nan`.
fn resolve_float(text: &str) -> Option<Value> {
    let (negative, body) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text.strip_prefix('+').unwrap_or(text)),
    };
    let special = match body {
        ".inf" | ".Inf" | ".INF" => Some(f64::INFINITY),
        ".nan" | ".NaN" | ".NAN" if text == body => Some(f64::NAN),
        _ => None,
    };
    if let Some(v) = special {
        return Some(Value::Float(if negative { -v } else { v }));
    }
    let (mantissa, exponent) = match body.find(['e', 'E']) {
        Some(i) => (&body[..i], Some(&body[i + 1..])),
        None => (body, None),
    };
    let (int_part, frac) = mantissa.split_once('.')?;
    let digits_ok = |s: &str| s.chars().all(|c| c.is_ascii_digit() || c == '_');
    if !digits_ok(int_part) || !digits_ok(frac) || (int_part.is_empty() && frac.is_empty()) {
        return None;
    }
    if int_part.starts_with('_') || (int_part.is_empty() && frac.starts_with('_')) {
        return None;
    }
    if let Some(e) = exponent {
        let digits = e.strip_prefix(['+', '-'])?;
        if digits.is_empty() || !digits.chars().all(|c| c.is_ascii_digit()) {
            return None;
        }
    }
    let clean: String = text.chars().filter(|&c| c != '_').collect();
    clean.parse().ok().map(Value::Float)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn repr(text: &str) -> String {
        match parse(text) {
            Ok(v) => v.repr(),
            Err(e) => format!("error: {e}"),
        }
    }

    #[test]
    fn pyyaml_scalars_and_units() {
        assert_eq!(
            repr("a: 1\nb: 1.5\nc: 1e-3\nd: yes\ne: ~\nf: '2'\ng: 0x1f\nh: 1.0e+2\n"),
            "{'a': 1, 'b': 1.5, 'c': '1e-3', 'd': True, 'e': None, 'f': '2', 'g': 31, 'h': 100.0}"
        );
        assert_eq!(
            repr("lim: !degrees 180\nr: !radians pi/2\nm: !millimeters 5"),
            format!(
                "{{'lim': {}, 'r': {}, 'm': 0.005}}",
                super::super::value::float_repr(180.0 * (std::f64::consts::PI / 180.0)),
                super::super::value::float_repr(std::f64::consts::PI / 2.0)
            )
        );
        assert_eq!(
            repr("base: &b {x: 1, y: 2}\nd:\n  <<: *b\n  y: 3"),
            "{'base': {'x': 1, 'y': 2}, 'd': {'x': 1, 'y': 3}}"
        );
        assert!(repr("a: !python/object x").starts_with("error"));
        assert!(repr("a: [1, 2").starts_with("error"));
        assert_eq!(repr(""), "None");
    }
}

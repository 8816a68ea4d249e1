//! The expansion itself: ROS 2 xacro's processing of a document (`eval_all`), element by element
//! in document order — properties (lazy by default), macros with their parameters and blocks,
//! includes, conditionals, arguments, `xacro:element` and `xacro:attribute`, `${…}` and `$(…)` in
//! attributes and text — with its scoping rules: a macro's body is evaluated in a scope below
//! its caller's, an include with `ns=` gets a namespace below the includer's scope.
//!
//! Longer than 800 lines: each xacro element's processing depends on the scoping rules and
//! bounds defined here, and the two views expressions have of the expander (`At`, `EvalAt`)
//! reach into its tables.

use super::dom::{self, Element, Node, Place};
use super::expr::{self, Scope};
use super::packages::Packages;
use super::value::{Func, Namespace, Value, parse_float, parse_int};
use super::yaml;
use crate::io::error::XacroError;
use std::collections::HashMap;
use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Deepest nesting of macro calls (a macro that calls itself without end stops here).
pub(crate) const MAX_CALL_DEPTH: usize = 100;
/// Deepest nesting of includes.
pub(crate) const MAX_INCLUDE_DEPTH: usize = 32;
/// Most files (includes and YAML files) one expansion may read.
pub(crate) const MAX_FILES: usize = 2048;
/// Deepest chain of lazy properties whose values name each other.
const MAX_LAZY_DEPTH: usize = 200;
/// Most XML nodes one expansion may make (macro bodies, blocks and includes copied in).
pub(crate) const MAX_NODES: usize = 2_000_000;
/// Units of work (expression steps, elements, characters / 16) one expansion may take: a bound
/// on its time.
pub(crate) const MAX_WORK: usize = 20_000_000;

/// The elements of a `.urdf` file whose failures are skipped with a warning rather than
/// refused: they do not place links.
const NON_KINEMATIC: [&str; 8] = [
    "visual",
    "collision",
    "material",
    "inertial",
    "gazebo",
    "transmission",
    "sensor",
    "ros2_control",
];

#[derive(Debug)]
enum Entry {
    Value(Value),
    /// A property's text, evaluated when first used.
    Lazy(Rc<str>),
}

#[derive(Debug, Default)]
struct Table {
    vars: HashMap<String, Entry>,
    parent: Option<usize>,
    /// The table of an include with `ns=`.
    namespace: bool,
    /// The lazy properties of this table being evaluated, outermost first.
    resolving: Vec<String>,
}

#[derive(Debug)]
struct Macro {
    name: String,
    params: Vec<String>,
    /// Each parameter's default: the name to forward (`:=^`) and the default text.
    defaults: HashMap<String, (Option<String>, Option<String>)>,
    body: Rc<Element>,
}

#[derive(Debug)]
enum MacroEntry {
    Macro(Rc<Macro>),
    Namespace(usize),
}

#[derive(Debug, Default)]
struct MacroTable {
    macros: HashMap<String, MacroEntry>,
    parent: Option<usize>,
}

/// The scope an element is evaluated in: its symbol table and macro table.
#[derive(Clone, Copy, Debug)]
struct Env {
    table: usize,
    macros: usize,
}

/// One expansion's state.
pub(crate) struct Expander {
    /// Every file read (the main file first), for places in messages.
    pub(crate) files: Vec<PathBuf>,
    /// The files being processed, the main one first, each with where it was included.
    file_stack: Vec<(usize, Place)>,
    /// The macro calls being expanded, outermost first.
    calls: Vec<(String, Place)>,
    args: HashMap<String, String>,
    tables: Vec<Table>,
    macro_tables: Vec<MacroTable>,
    blocks: Vec<Element>,
    work: usize,
    nodes: usize,
    lazy_depth: usize,
    pub(crate) warnings: Vec<String>,
    /// Lenient mode: a `.urdf` file's leftover xacro, where failures inside non-kinematic
    /// elements are skipped with a warning.
    lenient: bool,
    packages: Packages,
    /// Directories files may be read from (canonical).
    allowed: Vec<PathBuf>,
    here: Place,
    max_bytes: u64,
    /// Expressions parsed so far, by their text (macro bodies repeat theirs).
    parsed: HashMap<String, Rc<expr::Parsed>>,
    /// The directory of the last file asked for ([`Expander::current_dir`]).
    dir_cache: Option<(usize, PathBuf)>,
    /// Where xacro's one "stop" text node is ([`Stop`]).
    stop: Stop,
    /// Numbers the children lists being evaluated, for [`Stop::list`].
    lists: usize,
    /// The children list evaluated last (its nodes about to join another list).
    finished: usize,
}

/// xacro drops the comments right before a xacro element (they describe it), walking back
/// over comments and single line breaks, and then puts one text node of two line breaks after
/// the element (its expansion) so that a later walk stops there; there is one such node in a
/// document, moved each time. `list` is the children list it is in (0: none yet), `at` its
/// place in that list's output once the element's expansion is there (`None` before), `mark`
/// the walk that put it there.
#[derive(Debug, Default, Clone, Copy)]
struct Stop {
    list: usize,
    at: Option<usize>,
    mark: usize,
}

/// Most parsed expressions kept.
const MAX_PARSED: usize = 100_000;

type Result<T> = std::result::Result<T, XacroError>;

/// Attributes as (name, value) pairs.
type Attributes = Vec<(String, String)>;

impl Expander {
    pub(crate) fn new(
        main: PathBuf,
        args: &[(String, String)],
        package_paths: &[PathBuf],
        lenient: bool,
        max_bytes: u64,
    ) -> Expander {
        let dir = main
            .parent()
            .map(Path::to_path_buf)
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or_else(|| PathBuf::from("."));
        let mut allowed: Vec<PathBuf> = package_paths
            .iter()
            .chain(std::iter::once(&dir))
            .filter_map(|p| p.canonicalize().ok())
            .collect();
        // The package the main file is in, found by walking up to a `package.xml`.
        if let Ok(mut at) = dir.canonicalize() {
            for _ in 0..8 {
                if at.join("package.xml").is_file() {
                    allowed.push(at.clone());
                    break;
                }
                match at.parent() {
                    Some(p) => at = p.to_path_buf(),
                    None => break,
                }
            }
        }
        Expander {
            files: vec![main],
            file_stack: vec![(0, Place::default())],
            calls: Vec::new(),
            args: args.iter().cloned().collect(),
            tables: vec![Table::default()],
            macro_tables: vec![MacroTable::default()],
            blocks: Vec::new(),
            work: 0,
            nodes: 0,
            lazy_depth: 0,
            warnings: Vec::new(),
            lenient,
            packages: Packages::new(package_paths, Some(&dir)),
            allowed,
            here: Place::default(),
            max_bytes,
            parsed: HashMap::new(),
            dir_cache: None,
            stop: Stop::default(),
            lists: 0,
            finished: 0,
        }
    }

    /// Expands the document whose root is `root` (of the main file).
    pub(crate) fn run(&mut self, mut root: Element) -> Result<Element> {
        self.count_nodes(root.size())?;
        if let Some(target) = root.attr("xacro:targetNamespace").map(str::to_string) {
            root.remove_attr("xacro:targetNamespace");
            root.set_attr("xmlns".into(), target);
        }
        self.eval_all(
            root,
            Env {
                table: 0,
                macros: 0,
            },
        )
    }

    // -----------------------------------------------------------------------------------------
    // Errors and bounds

    /// An error at the element being processed, with the macro calls and includes that led
    /// there.
    fn fail(&self, message: impl Into<String>) -> XacroError {
        let mut stack = Vec::new();
        // A failure at a call itself (a wrong parameter) is placed there already.
        let calls = match self.calls.last() {
            Some((_, at)) if *at == self.here => &self.calls[..self.calls.len() - 1],
            _ => &self.calls[..],
        };
        for (name, at) in calls.iter().rev() {
            stack.push(format!("in macro `{name}` called at {}", self.show(*at)));
        }
        for (file, at) in self.file_stack.iter().skip(1).rev() {
            stack.push(format!(
                "in file {} included at {}",
                self.files[*file].display(),
                self.show(*at)
            ));
        }
        XacroError {
            file: self.files[self.here.file].clone(),
            line: Some(self.here.line),
            column: Some(self.here.column),
            stack,
            message: message.into(),
        }
    }

    fn show(&self, at: Place) -> String {
        let file = &self.files[at.file];
        let name = file.file_name().map_or_else(
            || file.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        format!("{name}:{}:{}", at.line, at.column)
    }

    fn check<T>(&self, r: std::result::Result<T, String>) -> Result<T> {
        r.map_err(|e| self.fail(e))
    }

    fn spend(&mut self, units: usize) -> std::result::Result<(), String> {
        self.work = self.work.saturating_add(units);
        if self.work > MAX_WORK {
            Err(format!(
                "the expansion takes more than {MAX_WORK} steps (a macro or property that grows without end?)"
            ))
        } else {
            Ok(())
        }
    }

    fn count_nodes(&mut self, n: usize) -> Result<()> {
        self.nodes = self.nodes.saturating_add(n);
        if self.nodes > MAX_NODES {
            return Err(self.fail(format!(
                "the expansion makes more than {MAX_NODES} XML nodes (a macro that copies itself without end?)"
            )));
        }
        let r = self.spend(n);
        self.check(r)
    }

    // -----------------------------------------------------------------------------------------
    // Symbols

    fn new_table(&mut self, parent: Option<usize>, namespace: bool) -> usize {
        self.tables.push(Table {
            parent,
            namespace,
            ..Table::default()
        });
        self.tables.len() - 1
    }

    fn new_macro_table(&mut self, parent: Option<usize>) -> usize {
        self.macro_tables.push(MacroTable {
            parent,
            ..MacroTable::default()
        });
        self.macro_tables.len() - 1
    }

    /// The table in `table`'s chain that holds `name`.
    fn holder(&self, table: usize, name: &str) -> Option<usize> {
        let mut t = Some(table);
        while let Some(i) = t {
            if self.tables[i].vars.contains_key(name) {
                return Some(i);
            }
            t = self.tables[i].parent;
        }
        None
    }

    /// Whether `name` is defined for `table` (a property in its chain, or a global).
    fn defined(&self, table: usize, name: &str) -> bool {
        self.holder(table, name).is_some() || expr::global(name).is_some()
    }

    /// The value of `name` seen from `table`.
    fn lookup(&mut self, table: usize, name: &str) -> std::result::Result<Value, String> {
        match self.holder(table, name) {
            Some(t) => self.resolve(t, name),
            None => expr::global(name).ok_or_else(|| format!("property `{name}` is not defined")),
        }
    }

    /// The value of `name` in table `t`, evaluating it first if it is lazy.
    fn resolve(&mut self, t: usize, name: &str) -> std::result::Result<Value, String> {
        let raw = match &self.tables[t].vars[name] {
            Entry::Value(v) => return Ok(v.clone()),
            Entry::Lazy(raw) => raw.clone(),
        };
        if self.tables[t].resolving.iter().any(|r| r == name) {
            let chain: Vec<&str> = self.tables[t]
                .resolving
                .iter()
                .map(String::as_str)
                .chain(std::iter::once(name))
                .collect();
            return Err(format!(
                "circular property definition: {} (set lazy_eval=\"false\" to evaluate a property where it is defined)",
                chain.join(" -> ")
            ));
        }
        if self.lazy_depth >= MAX_LAZY_DEPTH {
            return Err(format!(
                "properties refer to each other more than {MAX_LAZY_DEPTH} deep"
            ));
        }
        self.tables[t].resolving.push(name.to_string());
        self.lazy_depth += 1;
        let value = self.eval_text(&raw, t);
        self.lazy_depth -= 1;
        self.tables[t].resolving.pop();
        let value = literal(value.map_err(|e| format!("{e} (in property `{name}`)"))?);
        self.tables[t]
            .vars
            .insert(name.to_string(), Entry::Value(value.clone()));
        Ok(value)
    }

    /// Sets property `name` of table `t`: text that reads as a number or boolean becomes one;
    /// other text stays lazy when `lazy`.
    fn set(&mut self, t: usize, name: &str, value: Value, lazy: bool) {
        if expr::global(name).is_some() && !name.starts_with('*') {
            self.warnings.push(format!(
                "{}: property `{name}` redefines a global symbol",
                self.show(self.here)
            ));
        }
        let value = literal(value);
        let entry = match value {
            Value::Str(s) if lazy => Entry::Lazy(s),
            v => Entry::Value(v),
        };
        self.tables[t].vars.insert(name.to_string(), entry);
    }

    // -----------------------------------------------------------------------------------------
    // Text

    /// `text` with its `${…}` and `$(…)` evaluated: the value itself when the text is one
    /// expression, otherwise the pieces joined as a string.
    fn eval_text(&mut self, text: &str, table: usize) -> std::result::Result<Value, String> {
        if !text.contains('$') {
            return Ok(Value::str(text));
        }
        self.spend(1 + text.len() / 16)?;
        let mut pieces: Vec<Value> = Vec::new();
        let mut rest = text;
        while !rest.is_empty() {
            if rest.starts_with("$$") {
                let dollars = rest.bytes().take_while(|&b| b == b'$').count();
                match rest.as_bytes().get(dollars) {
                    Some(b'{' | b'(') => {
                        // `$${` → `${`, kept as text.
                        pieces.push(Value::str(&rest[1..=dollars]));
                        rest = &rest[dollars + 1..];
                        continue;
                    }
                    _ => return Err(format!("invalid expression: {rest}")),
                }
            }
            if let Some(body) = rest.strip_prefix("${") {
                let end = body
                    .find('}')
                    .ok_or_else(|| format!("'${{' without its '}}' in: {text}"))?;
                pieces.push(self.eval_expr(&body[..end], table)?);
                rest = &body[end + 1..];
            } else if let Some(body) = rest.strip_prefix("$(") {
                let end = body
                    .find(')')
                    .ok_or_else(|| format!("'$(' without its ')' in: {text}"))?;
                pieces.push(Value::str(&self.eval_extension(&body[..end], table)?));
                rest = &body[end + 1..];
            } else {
                // Text up to the next `$` that starts something (a `$` followed by other text
                // is text).
                let skip = usize::from(rest.starts_with('$'));
                let end = rest[skip..].find('$').map_or(rest.len(), |i| i + skip);
                pieces.push(Value::str(&rest[..end]));
                rest = &rest[end..];
            }
        }
        if pieces.len() == 1 {
            return Ok(pieces.pop().unwrap_or(Value::None));
        }
        let mut joined = String::new();
        for p in &pieces {
            joined.push_str(&p.to_text());
        }
        if joined.len() > expr::MAX_LEN {
            return Err(format!("text longer than {} characters", expr::MAX_LEN));
        }
        Ok(Value::str(&joined))
    }

    fn eval_expr(&mut self, body: &str, table: usize) -> std::result::Result<Value, String> {
        let inner = self.eval_text(body, table)?.to_text();
        let parsed = match self.parsed.get(&inner) {
            Some(p) => p.clone(),
            None => {
                let p = Rc::new(
                    expr::parse(&inner)
                        .map_err(|e| format!("{e} (in the expression '{}')", body.trim()))?,
                );
                if self.parsed.len() < MAX_PARSED {
                    self.parsed.insert(inner, p.clone());
                }
                p
            }
        };
        expr::run(&parsed, &mut At { x: self, table })
            .map_err(|e| format!("{e} (in the expression '{}')", body.trim()))
    }

    /// A `$(…)` substitution: `arg`, `find`, `env`, `optenv`, `dirname`, `eval`, `cwd`.
    fn eval_extension(&mut self, body: &str, table: usize) -> std::result::Result<String, String> {
        let inner = self.eval_text(body, table)?.to_text();
        if inner == "cwd" {
            return std::env::current_dir()
                .map(|d| d.display().to_string())
                .map_err(|e| format!("$(cwd): {e}"));
        }
        if let Some(code) = inner.strip_prefix("eval ") {
            if code.contains("__") {
                return Err("$(eval ...) may not contain double underscores".into());
            }
            let v = expr::evaluate(code, &mut EvalAt { x: self })
                .map_err(|e| format!("{e} (in $({inner}))"))?;
            return Ok(v.to_text());
        }
        let words: Vec<&str> = inner.split(' ').filter(|w| !w.is_empty()).collect();
        let resolved = match words.as_slice() {
            ["arg", name] => self.arg(name)?,
            ["arg", ..] => return Err(format!("$(arg NAME) takes one name: $({inner})")),
            ["find", pkg] => self.find(pkg)?,
            ["find", ..] => return Err(format!("$(find PKG) takes one package: $({inner})")),
            ["env", var] => std::env::var(var)
                .map_err(|_| format!("environment variable {var} is not set (in $({inner}))"))?,
            ["optenv", var, default @ ..] => {
                std::env::var(var).unwrap_or_else(|_| default.join(" "))
            }
            ["dirname"] => self.current_dir().display().to_string(),
            [command, ..] => {
                return Err(format!(
                    "unknown substitution $({command} ...): xacro knows arg, find, env, optenv, dirname, eval and cwd"
                ));
            }
            [] => return Err("empty substitution $()".into()),
        };
        // As roslaunch does: a `$(find …)` in what an argument gave is resolved too.
        let mut out = resolved;
        while let Some(start) = out.find("$(find ") {
            let Some(len) = out[start..].find(')') else {
                break;
            };
            let pkg = out[start + 7..start + len].trim().to_string();
            let dir = self.find(&pkg)?;
            out.replace_range(start..=start + len, &dir);
        }
        Ok(out)
    }

    fn arg(&self, name: &str) -> std::result::Result<String, String> {
        self.args.get(name).cloned().ok_or_else(|| {
            format!("argument `{name}` is not defined (give it with --arg {name}:=VALUE, or declare it with <xacro:arg name=\"{name}\" default=\"...\"/>)")
        })
    }

    fn find(&mut self, pkg: &str) -> std::result::Result<String, String> {
        let dir = self.packages.find(pkg)?;
        if let Ok(c) = dir.canonicalize()
            && !self.allowed.contains(&c)
        {
            self.allowed.push(c);
        }
        Ok(dir.display().to_string())
    }

    /// The directory of the file being processed.
    fn current_dir(&mut self) -> PathBuf {
        let index = self.file_stack.last().map_or(0, |f| f.0);
        if let Some((i, dir)) = &self.dir_cache
            && *i == index
        {
            return dir.clone();
        }
        let file = &self.files[index];
        let dir = file.parent().unwrap_or(Path::new("."));
        let dir = if dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            dir
        };
        let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
        self.dir_cache = Some((index, dir.clone()));
        dir
    }

    /// The text of file `path` (relative to the file being processed), which must be a regular
    /// file inside the allowed directories and within the size bound.
    fn read_file(&mut self, path: &Path) -> std::result::Result<(PathBuf, String), String> {
        let full = if path.is_absolute() {
            path.to_path_buf()
        } else {
            self.current_dir().join(path)
        };
        let canonical = full
            .canonicalize()
            .map_err(|e| format!("cannot read {}: {e}", full.display()))?;
        if !self.allowed.iter().any(|root| canonical.starts_with(root)) {
            return Err(format!(
                "{} is outside the directories xacro files may read (the main file's directory and package, --package-path directories, packages found by $(find)); add its package with --package-path",
                full.display()
            ));
        }
        let meta = std::fs::metadata(&canonical)
            .map_err(|e| format!("cannot read {}: {e}", full.display()))?;
        if !meta.is_file() {
            return Err(format!("{} is not a regular file", full.display()));
        }
        if self.files.len() >= MAX_FILES {
            return Err(format!("the expansion reads more than {MAX_FILES} files"));
        }
        let mut bytes = Vec::new();
        std::fs::File::open(&canonical)
            .and_then(|f| f.take(self.max_bytes + 1).read_to_end(&mut bytes))
            .map_err(|e| format!("cannot read {}: {e}", full.display()))?;
        if bytes.len() as u64 > self.max_bytes {
            return Err(format!(
                "{} is larger than {} bytes",
                full.display(),
                self.max_bytes
            ));
        }
        let text = String::from_utf8(bytes)
            .map_err(|_| format!("{} is not UTF-8 text", full.display()))?;
        self.spend(text.len() / 16)?;
        Ok((full, text))
    }

    // -----------------------------------------------------------------------------------------
    // Elements

    /// `e` with its attributes and children evaluated (its own name is not looked at).
    fn eval_all(&mut self, mut e: Element, env: Env) -> Result<Element> {
        self.here = e.at;
        let attrs = std::mem::take(&mut e.attrs);
        for (k, v) in attrs {
            if k.starts_with("xacro:") || k == "xmlns:xacro" {
                continue;
            }
            if !v.contains('$') {
                e.attrs.push((k, v));
                continue;
            }
            let value = self.eval_text(&v, env.table);
            let value = self.check(value)?.to_text();
            e.attrs.push((k, value));
        }
        let mut from_children = Vec::new();
        let children = std::mem::take(&mut e.children);
        e.children = self.eval_children(children, env, &mut from_children, e.at)?;
        for (k, v) in from_children {
            if k.starts_with("xmlns") && e.attr(&k).is_some() {
                continue;
            }
            e.set_attr(k, v);
        }
        Ok(e)
    }

    /// `children` evaluated in order; attributes that `xacro:attribute` or an include gives
    /// their parent are added to `parent_attrs`.
    fn eval_children(
        &mut self,
        children: Vec<Node>,
        env: Env,
        parent_attrs: &mut Vec<(String, String)>,
        parent_at: Place,
    ) -> Result<Vec<Node>> {
        let mut out = Vec::with_capacity(children.len());
        self.lists += 1;
        let list = self.lists;
        // `<!-- xacro:eval-comments -->` (or `:on`) has the comments after it evaluated until an
        // element, text that is not white space, `:off` or the end of the list.
        let mut eval_comments = false;
        let mut children = children.into_iter().peekable();
        while let Some(child) = children.next() {
            // xacro moves its stop node only before a next sibling.
            let last = children.peek().is_none();
            match child {
                Node::Text(t) if !t.contains('$') => {
                    eval_comments &= t.trim().is_empty();
                    out.push(Node::Text(t));
                }
                Node::Text(t) => {
                    self.here = parent_at;
                    let v = self.eval_text(&t, env.table);
                    let t = self.check(v)?.to_text();
                    eval_comments &= t.trim().is_empty();
                    out.push(Node::Text(t));
                }
                Node::Comment(c) if c.contains("xacro:eval-comments") => {
                    eval_comments = !c.contains("xacro:eval-comments:off");
                }
                Node::Comment(c) if eval_comments => {
                    self.here = parent_at;
                    let v = self.eval_text(&c, env.table);
                    out.push(Node::Comment(self.check(v)?.to_text()));
                }
                Node::Comment(c) => out.push(Node::Comment(c)),
                Node::Element(e) => {
                    eval_comments = false;
                    self.eval_element(e, env, &mut out, parent_attrs, (list, last))?;
                }
            }
        }
        self.finished = list;
        Ok(out)
    }

    /// The nodes of children list `from` join `out` of list `into` at its end: xacro's stop,
    /// if among them, comes along.
    fn splice(&mut self, out: &mut Vec<Node>, nodes: Vec<Node>, from: usize, into: usize) {
        if self.stop.list == from {
            self.stop.list = into;
            self.stop.at = self.stop.at.map(|at| at + out.len());
        }
        out.extend(nodes);
    }

    /// [`remove_previous_comments`] for a xacro element about to be expanded at the end of
    /// `out` (children list `list`, the element its last child when `last`); returns the
    /// walk's mark for [`Expander::place_stop`] when the stop moves after the element.
    fn drop_comments_before(
        &mut self,
        out: &mut Vec<Node>,
        (list, last): (usize, bool),
    ) -> Option<usize> {
        let floor = match self.stop {
            Stop {
                list: l,
                at: Some(at),
                ..
            } if l == list => Some(at),
            _ => None,
        };
        if remove_previous_comments(out, floor) && !last {
            // Stopped at a node: the stop goes after this element's expansion.
            self.stop.mark += 1;
            self.stop = Stop {
                list,
                at: None,
                mark: self.stop.mark,
            };
            Some(self.stop.mark)
        } else {
            None
        }
    }

    /// Puts the stop after the expansion now at the end of `out`, unless a walk inside the
    /// expansion has moved it since `mark`.
    fn place_stop(&mut self, mark: Option<usize>, out: &[Node]) {
        if mark.is_some_and(|m| m == self.stop.mark && self.stop.at.is_none()) {
            self.stop.at = Some(out.len());
        }
    }

    fn required<'e>(&self, e: &'e Element, name: &str) -> Result<&'e str> {
        e.attr(name)
            .ok_or_else(|| self.fail(format!("<{}> has no attribute '{name}'", e.name)))
    }

    fn text_of(&mut self, text: &str, table: usize) -> Result<String> {
        let v = self.eval_text(text, table);
        Ok(self.check(v)?.to_text())
    }

    fn eval_element(
        &mut self,
        mut e: Element,
        env: Env,
        out: &mut Vec<Node>,
        parent_attrs: &mut Vec<(String, String)>,
        list: (usize, bool),
    ) -> Result<()> {
        self.here = e.at;
        let r = self.spend(1);
        self.check(r)?;
        match e.name.as_str() {
            "xacro:insert_block" => {
                let name = self.required(&e, "name")?.to_string();
                let found = self
                    .holder(env.table, &format!("**{name}"))
                    .map(|t| (t, format!("**{name}"), true))
                    .or_else(|| {
                        self.holder(env.table, &format!("*{name}"))
                            .map(|t| (t, format!("*{name}"), false))
                    });
                let Some((t, key, content_only)) = found else {
                    return Err(self.fail(format!("undefined block `{name}`")));
                };
                let Entry::Value(Value::Block(i)) = &self.tables[t].vars[&key] else {
                    return Err(self.fail(format!("`{name}` is not a block")));
                };
                let block = self.blocks[*i].clone();
                self.count_nodes(block.size())?;
                let block = self.eval_all(block, env)?;
                if content_only {
                    out.extend(block.children);
                } else {
                    out.push(Node::Element(block));
                }
            }
            "xacro:include" => {
                let (nodes, namespaces) = self.include(&e, env)?;
                let from = self.finished;
                let mark = self.drop_comments_before(out, list);
                self.splice(out, nodes, from, list.0);
                self.place_stop(mark, out);
                parent_attrs.extend(namespaces);
            }
            "xacro:property" => {
                let mark = self.drop_comments_before(out, list);
                self.place_stop(mark, out);
                self.property(e, env)?;
            }
            "xacro:macro" => {
                let mark = self.drop_comments_before(out, list);
                self.place_stop(mark, out);
                self.define_macro(e, env)?;
            }
            "xacro:arg" => {
                let mark = self.drop_comments_before(out, list);
                self.place_stop(mark, out);
                let name = self.required(&e, "name")?.to_string();
                let default = self.required(&e, "default")?.to_string();
                if !self.args.contains_key(&name) {
                    let v = self.text_of(&default, env.table)?;
                    self.args.insert(name, v);
                }
            }
            "xacro:element" => {
                let raw = self.required(&e, "xacro:name")?.to_string();
                let name = self.text_of(&raw, env.table)?;
                if name.is_empty() {
                    return Err(self.fail("xacro:element: empty name"));
                }
                e.remove_attr("xacro:name");
                e.name = name;
                return self.eval_element(e, env, out, parent_attrs, list);
            }
            "xacro:attribute" => {
                let name = self.required(&e, "name")?.to_string();
                let value = self.required(&e, "value")?.to_string();
                let name = self.text_of(&name, env.table)?;
                let value = self.text_of(&value, env.table)?;
                if name.is_empty() {
                    return Err(self.fail("xacro:attribute: empty name"));
                }
                parent_attrs.push((name, value));
            }
            "xacro:if" | "xacro:unless" => {
                // The stop goes after the branch before it is evaluated (a walk in it moves it).
                let mark = self.drop_comments_before(out, list);
                let cond = self.required(&e, "value")?.to_string();
                let v = self.eval_text(&cond, env.table);
                let v = self.check(v)?;
                let keep = self.check(boolean(&v, &cond))? == (e.name == "xacro:if");
                let before = out.len();
                self.place_stop(mark, out);
                if keep {
                    // What the branch gives its parent (xacro:attribute) stays with the
                    // branch, as in xacro.
                    let mut lost = Vec::new();
                    let nodes = self.eval_children(e.children, env, &mut lost, e.at)?;
                    let stop_here = self.stop.list == list.0 && self.stop.at == Some(before);
                    let from = self.finished;
                    self.splice(out, nodes, from, list.0);
                    // Still where it was put: after the branch's nodes.
                    if stop_here {
                        self.stop.at = Some(out.len());
                    }
                }
            }
            "xacro:call" => {
                let raw = self.required(&e, "macro")?.to_string();
                let name = self.text_of(&raw, env.table)?;
                e.remove_attr("macro");
                e.name = format!("xacro:{name}");
                self.call(e, env, out, parent_attrs, list)?;
            }
            name if name.starts_with("xacro:") => {
                self.call(e, env, out, parent_attrs, list)?;
            }
            name if self.lenient && NON_KINEMATIC.contains(&name) => {
                let name = name.to_string();
                let at = e.at;
                let depth = (self.calls.len(), self.file_stack.len());
                match self.eval_all(e, env) {
                    Ok(done) => out.push(Node::Element(done)),
                    Err(err) => {
                        self.calls.truncate(depth.0);
                        self.file_stack.truncate(depth.1);
                        self.warnings.push(format!(
                            "{}: <{name}> skipped: {}",
                            self.show(at),
                            err.message
                        ));
                    }
                }
            }
            _ => {
                let done = self.eval_all(e, env)?;
                out.push(Node::Element(done));
            }
        }
        Ok(())
    }

    fn property(&mut self, e: Element, env: Env) -> Result<()> {
        let raw_name = self.required(&e, "name")?.to_string();
        let name = self.text_of(&raw_name, env.table)?;
        if !is_identifier(&name) {
            return Err(self.fail(format!(
                "property names must be Python identifiers: '{name}'"
            )));
        }
        if name.starts_with("__") {
            return Err(self.fail(format!(
                "property names must not start with two underscores: '{name}'"
            )));
        }
        let remove_text = e.attr("remove").unwrap_or("false").to_string();
        let remove_value = self.eval_text(&remove_text, env.table);
        let remove = self.check(remove_value.and_then(|v| boolean(&v, &remove_text)))?;
        let value = e.attr("value").map(str::to_string);
        let default = e.attr("default").map(str::to_string);
        if usize::from(value.is_some()) + usize::from(default.is_some()) + usize::from(remove) > 1 {
            return Err(self.fail(format!(
                "property `{name}`: default, value and remove exclude each other"
            )));
        }
        if remove {
            // As xacro: removed from every table up to the global one.
            let mut t = Some(env.table);
            while let Some(i) = t {
                self.tables[i].vars.remove(&name);
                t = self.tables[i].parent;
            }
            return Ok(());
        }
        let scope = e.attr("scope").map(str::to_string);
        let mut value = match (value, default) {
            (Some(v), _) => Value::str(&v),
            (None, Some(d)) => {
                if self.defined(env.table, &name) {
                    return Ok(());
                }
                Value::str(&d)
            }
            (None, None) => Value::Block(usize::MAX),
        };
        let mut key = name.clone();
        if matches!(value, Value::Block(_)) {
            key = format!("**{name}");
            self.blocks.push(e.clone());
            value = Value::Block(self.blocks.len() - 1);
        }
        let lazy_text = e.attr("lazy_eval").unwrap_or("true").to_string();
        let lazy_value = self.eval_text(&lazy_text, env.table);
        let mut lazy = self.check(lazy_value.and_then(|v| boolean(&v, &lazy_text)))?;
        let target = match scope.as_deref() {
            Some("global") => {
                lazy = false;
                0
            }
            Some("parent") => {
                lazy = false;
                let Some(mut p) = self.tables[env.table].parent else {
                    self.warnings.push(format!(
                        "{}: property `{name}`: there is no parent scope at the global scope",
                        self.show(e.at)
                    ));
                    return Ok(());
                };
                if !self.tables[env.table].namespace {
                    // In a macro's scope: past any include namespaces to the caller's.
                    while self.tables[p].namespace {
                        match self.tables[p].parent {
                            Some(q) => p = q,
                            None => break,
                        }
                    }
                }
                p
            }
            _ => env.table,
        };
        if !lazy && let Value::Str(text) = &value {
            let text = text.clone();
            let v = self.eval_text(&text, env.table);
            value = self.check(v)?;
        }
        self.set(target, &key, value, lazy);
        Ok(())
    }

    fn define_macro(&mut self, e: Element, env: Env) -> Result<()> {
        let mut name = self.required(&e, "name")?.to_string();
        if name == "call" {
            return Err(self.fail("a macro may not be called 'call'"));
        }
        if name.contains('.') {
            return Err(self.fail(format!(
                "macro names may not contain '.' (it separates namespaces): '{name}'"
            )));
        }
        if let Some(stripped) = name.strip_prefix("xacro:") {
            self.warnings.push(format!(
                "{}: macro names should not start with 'xacro:': '{name}'",
                self.show(e.at)
            ));
            name = stripped.to_string();
        }
        let mut params = Vec::new();
        let mut defaults = HashMap::new();
        let mut rest = e.attr("params").unwrap_or("").to_string();
        while !rest.trim().is_empty() {
            let (param, default, more) = parse_param(&rest);
            if let Some(d) = default {
                defaults.insert(param.clone(), d);
            }
            params.push(param);
            rest = more;
        }
        let body = Rc::new(e);
        self.macro_tables[env.macros].macros.insert(
            name.clone(),
            MacroEntry::Macro(Rc::new(Macro {
                name,
                params,
                defaults,
                body,
            })),
        );
        Ok(())
    }

    /// The macro `name` seen from `env`, with the scope its body is evaluated below (the
    /// caller's, or the namespace's for `ns.name`).
    fn resolve_macro(&self, name: &str, env: Env) -> Option<(Rc<Macro>, Env)> {
        fn find<'t>(
            tables: &'t [MacroTable],
            mut t: Option<usize>,
            name: &str,
        ) -> Option<&'t MacroEntry> {
            while let Some(i) = t {
                if let Some(m) = tables[i].macros.get(name) {
                    return Some(m);
                }
                t = tables[i].parent;
            }
            None
        }
        if let Some(MacroEntry::Macro(m)) = find(&self.macro_tables, Some(env.macros), name) {
            return Some((m.clone(), env));
        }
        let mut parts: Vec<&str> = name.split('.').collect();
        let last = parts.pop()?;
        if parts.is_empty() {
            return None;
        }
        let mut scope = env;
        for ns in parts {
            let MacroEntry::Namespace(mt) = find(&self.macro_tables, Some(scope.macros), ns)?
            else {
                return None;
            };
            let t = self.holder(scope.table, ns)?;
            let Entry::Value(Value::Namespace(Namespace::Table(st))) = &self.tables[t].vars[ns]
            else {
                return None;
            };
            scope = Env {
                table: *st,
                macros: *mt,
            };
        }
        match self.macro_tables[scope.macros].macros.get(last)? {
            MacroEntry::Macro(m) => Some((m.clone(), scope)),
            MacroEntry::Namespace(_) => None,
        }
    }

    /// Expands the macro call `call` into `out`; the namespace declarations its expansion
    /// brings (from the macro element and from includes in its body) go to the call's parent,
    /// `parent_attrs`, as xacro lifts them.
    fn call(
        &mut self,
        call: Element,
        env: Env,
        out: &mut Vec<Node>,
        parent_attrs: &mut Vec<(String, String)>,
        list: (usize, bool),
    ) -> Result<()> {
        let name = call.name["xacro:".len()..].to_string();
        let Some((m, scope)) = self.resolve_macro(&name, env) else {
            return Err(self.fail(format!("unknown macro name: xacro:{name}")));
        };
        if self.calls.len() >= MAX_CALL_DEPTH {
            return Err(self.fail(format!(
                "macro calls nest deeper than {MAX_CALL_DEPTH} (a macro that calls itself without end?)"
            )));
        }
        let marks = (
            self.tables.len(),
            self.macro_tables.len(),
            self.namespaces(),
        );
        self.calls.push((m.name.clone(), call.at));
        let result = self.expand_call(&m, call, env, scope);
        self.calls.pop();
        // The call's scopes are gone unless an include namespace was made in them.
        if self.namespaces() == marks.2 {
            self.tables.truncate(marks.0);
            self.macro_tables.truncate(marks.1);
        }
        let (nodes, namespaces) = result?;
        let from = self.finished;
        // xacro drops the comments before the call once the body is expanded.
        let mark = self.drop_comments_before(out, list);
        self.splice(out, nodes, from, list.0);
        self.place_stop(mark, out);
        parent_attrs.extend(namespaces);
        Ok(())
    }

    fn namespaces(&self) -> usize {
        self.tables.iter().filter(|t| t.namespace).count()
    }

    /// The nodes of `m`'s body for `call`, and the namespace declarations the expansion lifts
    /// to the call's parent.
    fn expand_call(
        &mut self,
        m: &Macro,
        call: Element,
        env: Env,
        scope: Env,
    ) -> Result<(Vec<Node>, Attributes)> {
        let table = self.new_table(Some(scope.table), false);
        let macros = self.new_macro_table(Some(scope.macros));
        let mut params = m.params.clone();
        for (k, v) in &call.attrs {
            if k.starts_with("xmlns") {
                continue;
            }
            if !params.contains(k) {
                return Err(self.fail(format!("macro `{}` has no parameter `{k}`", m.name)));
            }
            params.retain(|p| p != k);
            let value = self.eval_text(v, env.table);
            let value = self.check(value)?;
            self.set(table, k, value, false);
        }
        // Blocks are the call's child elements, evaluated in the caller's scope, in order.
        let mut lost = Vec::new();
        let children = self.eval_children(call.children, env, &mut lost, call.at)?;
        let mut blocks = children.into_iter().filter_map(|c| match c {
            Node::Element(e) => Some(e),
            _ => None,
        });
        for p in params.clone() {
            if p.starts_with('*') {
                let Some(block) = blocks.next() else {
                    return Err(
                        self.fail(format!("macro `{}`: not enough blocks for `{p}`", m.name))
                    );
                };
                params.retain(|q| *q != p);
                self.blocks.push(block);
                let i = self.blocks.len() - 1;
                self.tables[table]
                    .vars
                    .insert(p, Entry::Value(Value::Block(i)));
            }
        }
        if let Some(extra) = blocks.next() {
            return Err(self.fail(format!("macro `{}`: unused block <{}>", m.name, extra.name)));
        }
        for p in params.clone() {
            let Some((forward, default)) = m.defaults.get(&p) else {
                continue;
            };
            let value = match (forward, default) {
                (None, None) => continue,
                (None, Some(d)) => {
                    let v = self.eval_text(d, env.table);
                    self.check(v)?
                }
                (Some(f), d) => {
                    if self.defined(env.table, f) {
                        let v = self.lookup(env.table, f);
                        self.check(v)?
                    } else if let Some(d) = d {
                        let v = self.eval_text(d, env.table);
                        self.check(v)?
                    } else {
                        return Err(self.fail(format!(
                            "macro `{}`: property `{f}` to forward is not defined",
                            m.name
                        )));
                    }
                }
            };
            self.set(table, &p, value, false);
            params.retain(|q| *q != p);
        }
        if !params.is_empty() {
            return Err(self.fail(format!(
                "macro `{}`: parameters not given: {}",
                m.name,
                params.join(", ")
            )));
        }
        let body = (*m.body).clone();
        self.count_nodes(body.size())?;
        let mut given = Vec::new();
        let nodes =
            self.eval_children(body.children, Env { table, macros }, &mut given, body.at)?;
        // What the body gives the macro element, xacro keeps only the namespace declarations
        // of (with the macro element's own).
        let namespaces = body
            .attrs
            .into_iter()
            .chain(given)
            .filter(|(k, _)| k.starts_with("xmlns:") && k != "xmlns:xacro")
            .collect();
        Ok((nodes, namespaces))
    }

    /// The nodes an include stands for and the namespace declarations it brings to its parent.
    fn include(&mut self, e: &Element, env: Env) -> Result<(Vec<Node>, Attributes)> {
        let raw = self.required(e, "filename")?.to_string();
        let filename = self.text_of(&raw, env.table)?;
        let optional = e
            .attr("optional")
            .is_some_and(|o| matches!(o, "true" | "True" | "1"));
        let target = match e.attr("ns") {
            Some(ns) if !ns.is_empty() => {
                let ns = self.text_of(ns, env.table)?;
                let macros = self.new_macro_table(None);
                self.macro_tables[env.macros]
                    .macros
                    .insert(ns.clone(), MacroEntry::Namespace(macros));
                let table = self.new_table(Some(env.table), true);
                self.tables[env.table]
                    .vars
                    .insert(ns, Entry::Value(Value::Namespace(Namespace::Table(table))));
                Env { table, macros }
            }
            _ => env,
        };
        let paths = self.include_paths(&filename)?;
        let mut nodes = Vec::new();
        let mut namespaces = Vec::new();
        for path in paths {
            if self.file_stack.len() > MAX_INCLUDE_DEPTH {
                return Err(self.fail(format!(
                    "includes nest deeper than {MAX_INCLUDE_DEPTH} files (a file that includes itself?)"
                )));
            }
            let (full, text) = match self.read_file(&path) {
                Ok(read) => read,
                Err(_) if optional && !self.current_dir().join(&path).exists() => continue,
                Err(err) => return Err(self.fail(err)),
            };
            let file = self.files.len();
            self.files.push(full);
            let root = match dom::parse(&text, file) {
                Ok(root) => root,
                Err((at, message)) => {
                    self.file_stack.push((file, e.at));
                    self.here = at;
                    let err = self.fail(format!("not well-formed XML: {message}"));
                    self.file_stack.pop();
                    return Err(err);
                }
            };
            self.count_nodes(root.size())?;
            self.file_stack.push((file, e.at));
            let done = self.eval_all(root, target)?;
            self.file_stack.pop();
            self.here = e.at;
            namespaces.extend(
                done.attrs
                    .iter()
                    .filter(|(k, _)| k.starts_with("xmlns:"))
                    .cloned(),
            );
            nodes.extend(done.children);
        }
        Ok((nodes, namespaces))
    }

    /// The files an include's file name names: itself, or what its wildcards (`*`, `?`, `[…]`
    /// in the last component) match, sorted.
    fn include_paths(&mut self, filename: &str) -> Result<Vec<PathBuf>> {
        let path = PathBuf::from(filename);
        let last = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if !filename.contains(['*', '?', '[']) {
            return Ok(vec![path]);
        }
        if path
            .parent()
            .is_some_and(|p| p.to_string_lossy().contains(['*', '?', '[']))
        {
            return Err(self.fail(format!(
                "wildcards are read in the last part of an include's file name only: {filename}"
            )));
        }
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => {
                if p.is_absolute() {
                    p.to_path_buf()
                } else {
                    self.current_dir().join(p)
                }
            }
            _ => self.current_dir(),
        };
        let mut found: Vec<PathBuf> = std::fs::read_dir(&dir)
            .map(|r| {
                r.filter_map(std::result::Result::ok)
                    .filter(|d| wildcard(&last, &d.file_name().to_string_lossy()))
                    .map(|d| d.path())
                    .collect()
            })
            .unwrap_or_default();
        found.sort();
        if found.is_empty() {
            self.warnings.push(format!(
                "{}: include '{filename}' matched no files",
                self.show(self.here)
            ));
        }
        Ok(found)
    }

    fn load_yaml(&mut self, file: &str) -> std::result::Result<Value, String> {
        let (full, text) = self.read_file(Path::new(file))?;
        self.files.push(full.clone());
        yaml::parse(&text).map_err(|e| format!("in {}: {e}", full.display()))
    }
}

/// What text becomes when it is stored as a property (xacro's `_eval_literal`): `'quoted'`
/// text loses its quotes, a number or `true`/`false` becomes one, other text stays text (and
/// text with `_` stays text).
fn literal(value: Value) -> Value {
    let Value::Str(s) = &value else {
        return value;
    };
    if s.len() >= 2 && s.starts_with('\'') && s.ends_with('\'') {
        return Value::str(&s[1..s.len() - 1]);
    }
    if s.contains('_') {
        return value;
    }
    if let Some(i) = parse_int(s) {
        return Value::Int(i);
    }
    if let Some(f) = parse_float(s) {
        return Value::Float(f);
    }
    match &**s {
        "true" | "True" => Value::Bool(true),
        "false" | "False" => Value::Bool(false),
        _ => value,
    }
}

/// xacro's reading of a condition's value: `true`/`True`/`false`/`False`, an integer's truth,
/// or a non-text value's truth.
fn boolean(value: &Value, condition: &str) -> std::result::Result<bool, String> {
    match value {
        Value::Str(s) => match &**s {
            "true" | "True" => Ok(true),
            "false" | "False" => Ok(false),
            other => parse_int(&other.replace('_', "")).map(|i| i != 0).ok_or_else(|| {
                format!(
                    "the condition \"{condition}\" evaluated to \"{other}\", which is not a boolean"
                )
            }),
        },
        v => Ok(v.truth()),
    }
}

const KEYWORDS: [&str; 35] = [
    "False", "None", "True", "and", "as", "assert", "async", "await", "break", "class", "continue",
    "def", "del", "elif", "else", "except", "finally", "for", "from", "global", "if", "import",
    "in", "is", "lambda", "nonlocal", "not", "or", "pass", "raise", "return", "try", "while",
    "with", "yield",
];

fn is_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_alphabetic() || c == '_')
        && chars.all(|c| c.is_alphanumeric() || c == '_')
        && !KEYWORDS.contains(&name)
}

/// The first parameter of a macro's `params` text: its name, its default (the property to
/// forward for `:=^`, and the default text), and the rest of the text.
#[allow(clippy::type_complexity)]
fn parse_param(text: &str) -> (String, Option<(Option<String>, Option<String>)>, String) {
    let s = text.trim_start();
    let name_end = s
        .find(|c: char| c.is_whitespace() || c == ':' || c == '=')
        .unwrap_or(s.len());
    let name = &s[..name_end];
    let after = s[name_end..].trim_start();
    let assign = after.strip_prefix(":=").or_else(|| after.strip_prefix('='));
    let (Some(value), false) = (assign, name.is_empty()) else {
        let (first, rest) = s.split_once(char::is_whitespace).unwrap_or((s, ""));
        return (first.to_string(), None, rest.to_string());
    };
    let value = value.trim_start();
    let (forward, value) = if let Some(v) = value.strip_prefix("^|") {
        (true, v)
    } else if let Some(v) = value.strip_prefix('^') {
        (true, v)
    } else {
        (false, value)
    };
    let len = default_len(value);
    let default = &value[..len];
    let rest = &value[len..];
    (
        name.to_string(),
        Some((
            forward.then(|| name.to_string()),
            (!default.is_empty()).then(|| default.to_string()),
        )),
        rest.to_string(),
    )
}

/// The length of a parameter default at the start of `text`: a `${…}` or `$(…)` ending before
/// white space, or a run of quoted strings and other non-space text.
fn default_len(text: &str) -> usize {
    let ends_word = |i: usize| text[i..].chars().next().is_none_or(char::is_whitespace);
    for (open, close) in [("${", '}'), ("$(", ')')] {
        if text.starts_with(open) {
            let mut from = 0;
            while let Some(j) = text[from..].find(close) {
                let end = from + j + 1;
                if ends_word(end) {
                    return end;
                }
                from = end;
            }
        }
    }
    let bytes = text.as_bytes();
    let mut i = 0;
    while i < bytes.len() && !bytes[i].is_ascii_whitespace() {
        if bytes[i] == b'\'' || bytes[i] == b'"' {
            match text[i + 1..].find(bytes[i] as char) {
                Some(j) => i += j + 2,
                None => return 0,
            }
        } else {
            i += 1;
        }
    }
    i
}

/// Whether `name` matches the wildcard `pattern` (`*`, `?`, `[abc]`).
fn wildcard(pattern: &str, name: &str) -> bool {
    let p: Vec<char> = pattern.chars().collect();
    let n: Vec<char> = name.chars().collect();
    fn go(p: &[char], n: &[char]) -> bool {
        match p.first() {
            None => n.is_empty(),
            Some('*') => (0..=n.len()).any(|k| go(&p[1..], &n[k..])),
            Some('?') => !n.is_empty() && go(&p[1..], &n[1..]),
            Some('[') => match p.iter().position(|&c| c == ']') {
                Some(close) if !n.is_empty() => {
                    p[1..close].contains(&n[0]) && go(&p[close + 1..], &n[1..])
                }
                _ => false,
            },
            Some(c) => n.first() == Some(c) && go(&p[1..], &n[1..]),
        }
    }
    go(&p, &n)
}

/// Drops the comments right before a xacro element at the end of `out`, as xacro does (they
/// describe it): walking back over comments, each after at most one white-space text of at
/// most one line break, down to `stop` (where xacro's stop node is in this list, if it is).
/// True if the walk stopped at a node (the stop, or what is not a comment; xacro then moves
/// its stop after the element), false if it reached the start of the list.
fn remove_previous_comments(out: &mut Vec<Node>, stop: Option<usize>) -> bool {
    let floor = stop.unwrap_or(0);
    let mut i = out.len();
    loop {
        if i <= floor {
            return stop.is_some() || i > 0;
        }
        let mut j = i - 1;
        if let Node::Text(t) = &out[j]
            && t.trim().is_empty()
            && t.matches('\n').count() <= 1
        {
            if j <= floor {
                return stop.is_some() || j > 0;
            }
            j -= 1;
        }
        if matches!(out[j], Node::Comment(_)) {
            out.remove(j);
            i = j;
        } else {
            return true;
        }
    }
}

/// An expression's view of the expander from a table.
struct At<'a> {
    x: &'a mut Expander,
    table: usize,
}

impl Scope for At<'_> {
    fn lookup(&mut self, name: &str) -> std::result::Result<Value, String> {
        self.x.lookup(self.table, name)
    }

    fn namespace_get(&mut self, table: usize, name: &str) -> std::result::Result<Value, String> {
        match self.x.holder(table, name) {
            Some(t) => self.x.resolve(t, name),
            None => Err(format!("the namespace has no property `{name}`")),
        }
    }

    fn call_xacro(
        &mut self,
        name: &str,
        args: Vec<Value>,
        kwargs: Vec<(Rc<str>, Value)>,
    ) -> std::result::Result<Value, String> {
        let text_arg = |i: usize| -> std::result::Result<String, String> {
            match args.get(i) {
                Some(Value::Str(s)) => Ok(s.to_string()),
                Some(other) => Err(format!(
                    "xacro.{name}() needs a string, not {}",
                    other.type_name()
                )),
                None => Err(format!("xacro.{name}() needs an argument")),
            }
        };
        match name {
            "load_yaml" => self.x.load_yaml(&text_arg(0)?),
            "abs_filename" => Ok(Value::str(
                &self
                    .x
                    .current_dir()
                    .join(text_arg(0)?)
                    .display()
                    .to_string(),
            )),
            "dotify" => args
                .into_iter()
                .next()
                .ok_or_else(|| "xacro.dotify() needs an argument".to_string()),
            "arg" => self.x.arg(&text_arg(0)?).map(|v| Value::str(&v)),
            "message" | "warning" | "error" | "print_location" => {
                let text: Vec<String> = args.iter().map(Value::to_text).collect();
                let here = self.x.show(self.x.here);
                self.x
                    .warnings
                    .push(format!("{here}: xacro.{name}: {}", text.join(" ")));
                Ok(Value::str(""))
            }
            "fatal" => {
                let text: Vec<String> = args.iter().map(Value::to_text).collect();
                Err(format!("xacro.fatal: {}", text.join(" ")))
            }
            "tokenize" => {
                let s = text_arg(0)?;
                let mut sep = ",; ".to_string();
                let mut skip_empty = true;
                if let Some(Value::Str(s)) = args.get(1) {
                    sep = s.to_string();
                }
                if let Some(v) = args.get(2) {
                    skip_empty = v.truth();
                }
                for (k, v) in &kwargs {
                    match (&**k, v) {
                        ("sep", Value::Str(s)) => sep = s.to_string(),
                        ("skip_empty", v) => skip_empty = v.truth(),
                        _ => return Err(format!("xacro.tokenize() takes no argument '{k}'")),
                    }
                }
                let parts = s
                    .split(|c| sep.contains(c))
                    .filter(|p| !skip_empty || !p.is_empty())
                    .map(Value::str)
                    .collect();
                Ok(Value::List(Rc::new(parts)))
            }
            _ => Err(format!("xacro.{name} is not offered")),
        }
    }

    fn spend(&mut self, units: usize) -> std::result::Result<(), String> {
        self.x.spend(units)
    }
}

/// The view of `$(eval …)`: the arguments by name (read as numbers or booleans where they are
/// such text), `arg()`, `find()`, `env()`, `optenv()`, `dirname()` and the math names.
struct EvalAt<'a> {
    x: &'a mut Expander,
}

impl Scope for EvalAt<'_> {
    fn lookup(&mut self, name: &str) -> std::result::Result<Value, String> {
        match name {
            "true" | "True" => Ok(Value::Bool(true)),
            "false" | "False" => Ok(Value::Bool(false)),
            "arg" => Ok(Value::Func(Func::Xacro("arg"))),
            "find" => Ok(Value::Func(Func::Xacro("find"))),
            "env" => Ok(Value::Func(Func::Xacro("env"))),
            "optenv" => Ok(Value::Func(Func::Xacro("optenv"))),
            "dirname" => Ok(Value::Func(Func::Xacro("dirname"))),
            _ => {
                if let Some(v) = self.x.args.get(name) {
                    return Ok(auto(v));
                }
                expr::global(name)
                    .filter(|v| matches!(v, Value::Float(_) | Value::Func(Func::Math(_))))
                    .ok_or_else(|| format!("name '{name}' is not defined"))
            }
        }
    }

    fn namespace_get(&mut self, _: usize, name: &str) -> std::result::Result<Value, String> {
        Err(format!("name '{name}' is not defined"))
    }

    fn call_xacro(
        &mut self,
        name: &str,
        args: Vec<Value>,
        _: Vec<(Rc<str>, Value)>,
    ) -> std::result::Result<Value, String> {
        let text: Vec<String> = args.iter().map(Value::to_text).collect();
        match (name, text.as_slice()) {
            ("arg", [n]) => self.x.arg(n).map(|v| auto(&v)),
            ("find", [p]) => self.x.find(p).map(|d| Value::str(&d)),
            ("env", [v]) => std::env::var(v)
                .map(|s| Value::str(&s))
                .map_err(|_| format!("environment variable {v} is not set")),
            ("optenv", [v, rest @ ..]) => Ok(Value::str(
                &std::env::var(v).unwrap_or_else(|_| rest.join(" ")),
            )),
            ("dirname", []) => Ok(Value::str(&self.x.current_dir().display().to_string())),
            _ => Err(format!("{name}() is called with the wrong arguments")),
        }
    }

    fn spend(&mut self, units: usize) -> std::result::Result<(), String> {
        self.x.spend(units)
    }
}

/// roslaunch's reading of an argument in `$(eval …)`: a number if it reads as one (with a `.`,
/// a float), `true`/`false` in any case as a boolean, otherwise the text.
fn auto(text: &str) -> Value {
    if text.contains('.') {
        if let Some(f) = parse_float(text) {
            return Value::Float(f);
        }
    } else if let Some(i) = parse_int(text) {
        return Value::Int(i);
    }
    match text.to_ascii_lowercase().as_str() {
        "true" => Value::Bool(true),
        "false" => Value::Bool(false),
        _ => Value::str(text),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn macro_parameters_parse_as_xacro_reads_them() {
        let (p, d, rest) = parse_param("prefix:='' *origin joint:=^|${pi} x");
        assert_eq!(
            (p.as_str(), d, rest.as_str()),
            (
                "prefix",
                Some((None, Some("''".into()))),
                " *origin joint:=^|${pi} x"
            )
        );
        let (p, d, rest) = parse_param(rest.as_str());
        assert_eq!(
            (p.as_str(), d, rest.trim()),
            ("*origin", None, "joint:=^|${pi} x")
        );
        let (p, d, _) = parse_param("joint:=^|${pi} x");
        assert_eq!(
            (p.as_str(), d),
            ("joint", Some((Some("joint".into()), Some("${pi}".into()))))
        );
        let (p, d, _) = parse_param("a:=${b+c}_x y");
        assert_eq!(
            (p.as_str(), d),
            ("a", Some((None, Some("${b+c}_x".into()))))
        );
        // With spaces, a `${…}` default ends before white space, as xacro's pattern reads it.
        let (p, d, _) = parse_param("a:=${b + c} y");
        assert_eq!(
            (p.as_str(), d),
            ("a", Some((None, Some("${b + c}".into()))))
        );
        let (p, d, _) = parse_param("a:=^ y");
        assert_eq!((p.as_str(), d), ("a", Some((Some("a".into()), None))));
    }

    #[test]
    fn wildcards() {
        assert!(wildcard("*.xacro", "arm.xacro"));
        assert!(wildcard("arm_[12].urdf", "arm_2.urdf"));
        assert!(!wildcard("a?c", "ac"));
    }
}

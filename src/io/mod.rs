//! Loading robot files: DH YAML (`.yaml`, `.yml`), URDF (`.urdf`), xacro (`.xacro`) and MJCF
//! (`.xml`).

#[cfg(feature = "logs")]
pub mod bag;
pub mod convert;
mod dh;
pub mod error;
pub mod input;
mod mjcf;
pub mod output;
pub mod render;
#[cfg(feature = "logs")]
pub mod tf;
mod urdf;
pub mod view;
pub mod xacro;
pub(crate) mod xml;

use crate::eval::Chain;
use crate::io::error::{LoadError, LoadErrorKind};
use std::io::Read;
use std::path::Path;

pub use error::MAX_FILE_BYTES;

/// The formats kinechain reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Format {
    /// Denavit–Hartenberg YAML (standard, modified or axis convention).
    DhYaml,
    /// URDF (XML).
    Urdf,
    /// MJCF, MuJoCo's XML (an `.xml` file whose root element is `<mujoco>`; one whose root is
    /// `<robot>` is read as URDF).
    Mjcf,
    /// xacro (`.xacro`, `.urdf.xacro`): expanded into URDF ([`xacro`]), then read as URDF.
    Xacro,
}

impl Format {
    /// The format a file name's extension says (`.yaml`/`.yml`: DH YAML, `.urdf`: URDF,
    /// `.xml`/`.mjcf`: MJCF, `.xacro`: xacro).
    #[must_use]
    pub fn from_path(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "yaml" | "yml" => Some(Format::DhYaml),
            "urdf" => Some(Format::Urdf),
            "xml" | "mjcf" => Some(Format::Mjcf),
            "xacro" => Some(Format::Xacro),
            _ => None,
        }
    }
}

/// How a robot file is loaded, beyond what it says.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct LoadOptions {
    /// Add a floating joint between the world and the robot's root link
    /// ([`ChainBuilder::floating_base`](crate::ChainBuilder::floating_base)): the base of a
    /// humanoid or a quadruped, whose pose leads `q`.
    pub floating_base: bool,
    /// The directory an MJCF file's `<include>`s are looked up in first (by default the main
    /// file's; for text given as a string, the current directory).
    pub base_dir: Option<std::path::PathBuf>,
    /// MJCF: make each linear `<equality><joint>` coupling (`y − y0 = a0 + a1 (x − x0)`) a mimic
    /// joint following its leader, so that `q` holds the leaders only (by default `q` is
    /// MuJoCo's `qpos` and the couplings are reported, not applied, as `mj_kinematics` does).
    pub couplings: bool,
    /// xacro: the arguments and package directories a `.xacro` file is expanded with (also
    /// used for leftover xacro elements in a `.urdf` file).
    pub xacro: xacro::XacroOptions,
}

impl LoadOptions {
    /// With a floating base (see [`LoadOptions::floating_base`]).
    #[must_use]
    pub fn with_floating_base(mut self, floating_base: bool) -> Self {
        self.floating_base = floating_base;
        self
    }

    /// With MJCF joint couplings applied (see [`LoadOptions::couplings`]).
    #[must_use]
    pub fn with_couplings(mut self, couplings: bool) -> Self {
        self.couplings = couplings;
        self
    }

    /// With the xacro arguments and package directories `xacro`.
    #[must_use]
    pub fn with_xacro(mut self, xacro: xacro::XacroOptions) -> Self {
        self.xacro = xacro;
        self
    }

    /// With xacro argument `name` set to `value` (`--arg NAME:=VALUE`).
    #[must_use]
    pub fn with_xacro_arg(mut self, name: impl Into<String>, value: impl Into<String>) -> Self {
        self.xacro.args.push((name.into(), value.into()));
        self
    }

    /// With `dir` searched first for the ROS packages a xacro file's `$(find PKG)` names
    /// (`--package-path DIR`).
    #[must_use]
    pub fn with_package_path(mut self, dir: impl Into<std::path::PathBuf>) -> Self {
        self.xacro.package_paths.push(dir.into());
        self
    }

    /// With `dir` as the directory includes are looked up in (see [`LoadOptions::base_dir`]).
    #[must_use]
    pub fn with_base_dir(mut self, dir: impl Into<std::path::PathBuf>) -> Self {
        self.base_dir = Some(dir.into());
        self
    }
}

impl Chain {
    /// [`Chain::from_file`] with `options`.
    ///
    /// # Errors
    /// As [`Chain::from_file`].
    ///
    /// # Examples
    /// ```
    /// use kinechain::{Chain, io::LoadOptions};
    /// let chain = Chain::from_file_with("robots/panda.urdf", &LoadOptions::default().with_floating_base(true))?;
    /// assert_eq!((chain.nq(), chain.nv()), (15, 14));
    /// # Ok::<(), kinechain::LoadError>(())
    /// ```
    pub fn from_file_with(
        path: impl AsRef<Path>,
        options: &LoadOptions,
    ) -> Result<Chain, LoadError> {
        let path = path.as_ref();
        let text = read_robot_file(path)?;
        Chain::from_file_text_with(path, &text, options)
    }

    /// The chain of a xacro [`Expansion`](xacro::Expansion) of file `path` (read as URDF, with
    /// the expansion's warnings): what [`Chain::from_file_with`] gives for a `.xacro` file, for
    /// a caller that keeps the URDF text too.
    ///
    /// # Errors
    /// [`LoadError`] naming `path`: the URDF could not be read.
    pub fn from_xacro_expansion(
        path: &Path,
        expansion: &xacro::Expansion,
        options: &LoadOptions,
    ) -> Result<Chain, LoadError> {
        let with_options = |mut b: crate::model::builder::ChainBuilder| {
            if options.floating_base {
                b.floating_base();
            }
            b
        };
        load_urdf(&expansion.urdf, &expansion.warnings, with_options)
            .map_err(|e| LoadError::new(path, LoadErrorKind::Expanded(Box::new(e))))
    }

    /// [`Chain::from_file_text`] with `options`.
    ///
    /// # Errors
    /// As [`Chain::from_file_text`].
    pub fn from_file_text_with(
        path: &Path,
        text: &str,
        options: &LoadOptions,
    ) -> Result<Chain, LoadError> {
        let fail = |kind| LoadError::new(path, kind);
        let format = format_of(path)?;
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("robot");
        parse(text, format, stem, options, Some(path)).map_err(fail)
    }

    /// [`Chain::from_str_named`] with `options`.
    ///
    /// # Errors
    /// As [`Chain::from_str_named`].
    pub fn from_str_with(
        text: &str,
        format: Format,
        default_name: &str,
        options: &LoadOptions,
    ) -> Result<Chain, LoadError> {
        parse(text, format, default_name, options, None)
            .map_err(|k| LoadError::new(Path::new("<string>"), k))
    }

    /// Loads a robot file, its format chosen by extension (`.yaml`/`.yml`: DH YAML, `.urdf`:
    /// URDF, `.xml`: MJCF, or URDF when its root element is `<robot>`). Files larger than [`MAX_FILE_BYTES`] are refused.
    ///
    /// # Errors
    /// [`LoadError`] naming the file and, where it applies, the line, joint and field.
    ///
    /// # Examples
    /// ```
    /// let chain = kinechain::Chain::from_file("robots/puma560.yaml")?;
    /// assert_eq!(chain.dof(), 6);
    /// # Ok::<(), kinechain::LoadError>(())
    /// ```
    pub fn from_file(path: impl AsRef<Path>) -> Result<Chain, LoadError> {
        let path = path.as_ref();
        let text = read_robot_file(path)?;
        Chain::from_file_text(path, &text)
    }

    /// The chain of the robot file `path` whose text [`read_robot_file`] read: what
    /// [`Chain::from_file`] gives, without reading the file again (a FIFO can be read once).
    ///
    /// # Errors
    /// [`LoadError`] naming `path` and, where it applies, the line, joint and field.
    pub fn from_file_text(path: &Path, text: &str) -> Result<Chain, LoadError> {
        Chain::from_file_text_with(path, text, &LoadOptions::default())
    }

    /// Builds a chain from text in `format`, named `default_name` where the text names no robot
    /// (a DH table without `name:`; a URDF always names its robot).
    ///
    /// # Errors
    /// [`LoadError`] with path `<string>`.
    pub fn from_str_named(
        text: &str,
        format: Format,
        default_name: &str,
    ) -> Result<Chain, LoadError> {
        Chain::from_str_with(text, format, default_name, &LoadOptions::default())
    }

    /// Builds a chain from DH YAML text (see the README for the format).
    ///
    /// # Errors
    /// [`LoadError`] with path `<string>`.
    pub fn from_dh_yaml_str(text: &str) -> Result<Chain, LoadError> {
        Chain::from_str_named(text, Format::DhYaml, "robot")
    }

    /// Builds a chain from URDF text.
    ///
    /// # Errors
    /// [`LoadError`] with path `<string>`.
    pub fn from_urdf_str(text: &str) -> Result<Chain, LoadError> {
        Chain::from_str_named(text, Format::Urdf, "robot")
    }
}

/// The format of the robot file `path` by its extension.
fn format_of(path: &Path) -> Result<Format, LoadError> {
    Format::from_path(path).ok_or_else(|| LoadError::new(path, LoadErrorKind::UnknownFormat))
}

/// Reads the robot file `path` once, as text: at most [`MAX_FILE_BYTES`] (a pipe or a device is
/// read no further), UTF-8. Its extension must name a format kinechain reads.
///
/// # Errors
/// [`LoadError`] naming the file: an unknown extension, a failed read, a file over the limit,
/// UTF-16 or other text that is not UTF-8.
pub fn read_robot_file(path: &Path) -> Result<String, LoadError> {
    format_of(path)?;
    read_text(path)
}

/// Reads file `path` as text: at most [`MAX_FILE_BYTES`], UTF-8.
pub(crate) fn read_text(path: &Path) -> Result<String, LoadError> {
    let fail = |kind| LoadError::new(path, kind);
    let file = std::fs::File::open(path).map_err(|e| fail(LoadErrorKind::Io(e)))?;
    let mut bytes = Vec::new();
    // Read one byte past the limit to tell "at the limit" from "over it" without trusting
    // metadata (which a pipe or a growing file does not have).
    file.take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| fail(LoadErrorKind::Io(e)))?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        // A regular file's size is known; a pipe or a device (`/dev/zero`) was read up to the
        // limit and no further.
        let size = std::fs::metadata(path)
            .ok()
            .filter(std::fs::Metadata::is_file)
            .map(|m| m.len());
        return Err(fail(LoadErrorKind::TooLarge {
            size,
            limit: MAX_FILE_BYTES,
        }));
    }
    if bytes.starts_with(&[0xff, 0xfe]) || bytes.starts_with(&[0xfe, 0xff]) {
        return Err(fail(LoadErrorKind::Utf16));
    }
    String::from_utf8(bytes).map_err(|e| {
        fail(LoadErrorKind::NotText {
            offset: e.utf8_error().valid_up_to(),
        })
    })
}

fn parse(
    text: &str,
    format: Format,
    default_name: &str,
    options: &LoadOptions,
    path: Option<&Path>,
) -> Result<Chain, LoadErrorKind> {
    if is_blank(text, format) {
        return Err(LoadErrorKind::Empty);
    }
    let with_options = |mut b: crate::model::builder::ChainBuilder| {
        if options.floating_base {
            b.floating_base();
        }
        b
    };
    match format {
        Format::Xacro => {
            let file = xacro_path(path, options, default_name);
            let expansion = xacro::expand_text(text, &file, &options.xacro, false)
                .map_err(LoadErrorKind::Xacro)?;
            load_urdf(&expansion.urdf, &expansion.warnings, with_options)
                .map_err(|e| LoadErrorKind::Expanded(Box::new(e)))
        }
        Format::Urdf if xacro::has_xacro(text) => {
            // Leftover xacro elements of a file saved as URDF.
            let file = xacro_path(path, options, default_name);
            let expansion = xacro::expand_text(text, &file, &options.xacro, true)
                .map_err(LoadErrorKind::Xacro)?;
            load_urdf(&expansion.urdf, &expansion.warnings, with_options)
                .map_err(|e| LoadErrorKind::Expanded(Box::new(e)))
        }
        Format::DhYaml => with_options(dh::parse(text, default_name)?)
            .into_chain()
            .map_err(|failed| failed.0.into()),
        Format::Mjcf if !xml_root_is(text, "robot") => {
            let files = (path, options.base_dir.as_deref());
            let builder = mjcf::parse(
                text,
                files,
                default_name,
                (MAX_FILE_BYTES, options.couplings),
            )?;
            with_options(builder)
                .into_chain()
                .map_err(|failed| LoadErrorKind::Model {
                    line: None,
                    column: None,
                    error: failed.0,
                })
        }
        Format::Urdf | Format::Mjcf => load_urdf(text, &[], with_options),
    }
}

/// The chain of URDF text `text`, with `warnings` from before it was read (a xacro expansion's).
fn load_urdf(
    text: &str,
    warnings: &[String],
    with_options: impl Fn(crate::model::builder::ChainBuilder) -> crate::model::builder::ChainBuilder,
) -> Result<Chain, LoadErrorKind> {
    let (mut builder, places) = urdf::parse(text)?;
    for w in warnings {
        builder.warn(w.clone());
    }
    with_options(builder).into_chain().map_err(|failed| {
        let (e, builder) = *failed;
        places.locate(text, &builder, e.into())
    })
}

/// The path a xacro text is expanded as: its file, or for text given as a string a file in
/// the base directory (or the current one).
fn xacro_path(
    path: Option<&Path>,
    options: &LoadOptions,
    default_name: &str,
) -> std::path::PathBuf {
    path.map_or_else(
        || {
            options
                .base_dir
                .clone()
                .unwrap_or_else(|| std::path::PathBuf::from("."))
                .join(format!("{default_name}.urdf.xacro"))
        },
        Path::to_path_buf,
    )
}

/// Nothing but whitespace (and, for YAML, comments).
fn is_blank(text: &str, format: Format) -> bool {
    match format {
        Format::DhYaml => text
            .lines()
            .map(str::trim)
            .all(|l| l.is_empty() || l.starts_with('#') || l == "---" || l == "..."),
        Format::Urdf | Format::Mjcf | Format::Xacro => text.trim().is_empty(),
    }
}

/// Whether the first element of XML text `text` is called `name` (comments, declarations and
/// processing instructions before it skipped).
fn xml_root_is(text: &str, name: &str) -> bool {
    let mut rest = text.trim_start_matches('\u{feff}');
    loop {
        rest = rest.trim_start();
        if let Some(r) = rest.strip_prefix("<!--") {
            let Some(end) = r.find("-->") else {
                return false;
            };
            rest = &r[end + 3..];
        } else if rest.starts_with("<?") || rest.starts_with("<!") {
            let Some(end) = rest.find('>') else {
                return false;
            };
            rest = &rest[end + 1..];
        } else {
            return rest.strip_prefix('<').is_some_and(|r| {
                r.starts_with(name)
                    && r[name.len()..]
                        .starts_with(|c: char| c.is_whitespace() || c == '>' || c == '/')
            });
        }
    }
}

//! Helpers shared by the integration tests: the reference data of `tests/data/reference/`
//! (see its README), turned into chains and joint vectors.
#![allow(dead_code)]

use kinechain::model::joint::{DhConvention, dh_transform};
use kinechain::nalgebra::Matrix4;
use kinechain::{
    Chain, ChainBuilder, Data, JointKind, JointSpec, LimitPolicy, Transform, forward_accelerations,
    forward_kinematics,
};
use rand::Rng;
use serde_json::Value;
use std::path::{Path, PathBuf};

pub use kinechain::measure::worse;

/// A directory of its own for the files a test writes, named by `tag`, the process and a count
/// (tests run in parallel); removed with its files when dropped, so also when the test fails.
pub struct Scratch(PathBuf);

impl Scratch {
    pub fn new(tag: &str) -> Self {
        static MADE: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = MADE.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let name = format!("kinechain-{tag}-{}-{n}", std::process::id());
        let dir = std::env::temp_dir().join(name);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }

    /// The path of the file `name` in the directory, as the text a command line takes.
    pub fn path(&self, name: &str) -> String {
        let path = self.0.join(name);
        path.to_str()
            .unwrap_or_else(|| panic!("{} is not UTF-8", path.display()))
            .to_string()
    }

    /// Writes `contents` to the file `name` in the directory; its path as [`Scratch::path`].
    pub fn write(&self, name: &str, contents: impl AsRef<[u8]>) -> String {
        let path = self.path(name);
        std::fs::write(&path, contents).unwrap();
        path
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        // Not `unwrap`: a panic while a failed test unwinds would abort the whole test binary.
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A robot without moving joints: a base and a tool 1 m above it on a fixed joint.
pub const FIXED_ONLY_URDF: &str = r#"<robot name="fixed">
  <link name="base"/><link name="tool"/>
  <joint name="mount" type="fixed">
    <parent link="base"/><child link="tool"/><origin xyz="0 0 1"/>
  </joint>
</robot>"#;

/// A two-joint arm (the first joint without limits) with a gripper whose second finger mimics
/// the first with the opposite sign: its limits and its primary's bound one entry of `q` with
/// different scales, so they are not one interval per entry and evaluations check them apart
/// from the kernels.
pub const MIMIC_GRIPPER: &str = r#"<robot name="gripper">
  <link name="base"/><link name="upper"/><link name="palm"/><link name="left"/><link name="right"/>
  <joint name="turn" type="continuous"><parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/></joint>
  <joint name="lift" type="revolute"><parent link="upper"/><child link="palm"/>
    <origin xyz="0.2 0 0.1" rpy="0.3 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="left" type="prismatic"><parent link="palm"/><child link="left"/>
    <origin xyz="0.05 0 0"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" effort="1" velocity="1"/></joint>
  <joint name="right" type="prismatic"><parent link="palm"/><child link="right"/>
    <origin xyz="0.05 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-0.04" upper="0" effort="1" velocity="1"/>
    <mimic joint="left" multiplier="-1" offset="0.01"/></joint>
</robot>"#;

/// Root of the copied reference data.
pub fn reference_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/reference")
}

/// The bundled robot files.
pub fn robots_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("robots")
}

/// The chain of a robot file given relative to the repository root; `FILE+floating` loads it
/// with a floating base.
pub fn repo_chain(file: &str) -> Chain {
    let (path, floating) = match file.strip_suffix("+floating") {
        Some(path) => (path, true),
        None => (file, false),
    };
    let options = kinechain::io::LoadOptions::default().with_floating_base(floating);
    Chain::from_file_with(Path::new(env!("CARGO_MANIFEST_DIR")).join(path), &options)
        .unwrap_or_else(|e| panic!("{file}: {e}"))
}

/// Every file of `robots/`, sorted.
pub fn robot_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(robots_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

/// Every URDF the `k` crate is compared on: the bundled Panda and the reference data's URDFs.
pub fn k_urdf_files() -> Vec<PathBuf> {
    let mut files = vec![robots_dir().join("panda.urdf")];
    for kind in ["urdf", "dh", "axis", "stress"] {
        let dir = reference_dir().join(kind);
        let mut more: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "urdf"))
            .collect();
        more.sort();
        files.extend(more);
    }
    files
}

/// Every double-precision reference file (`*.json`, not `*.hp.json`), sorted.
pub fn reference_files() -> Vec<PathBuf> {
    let mut out = Vec::new();
    for kind in ["axis", "dh", "stress", "urdf"] {
        let dir = reference_dir().join(kind);
        let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.unwrap().path())
            .filter(|p| {
                let name = p.file_name().unwrap().to_str().unwrap();
                name.ends_with(".json") && !name.ends_with(".hp.json")
            })
            .collect();
        files.sort();
        out.extend(files);
    }
    assert!(out.len() >= 15, "reference data missing: {out:?}");
    out
}

pub fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The high-precision companion of a reference file.
pub fn hp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .unwrap()
        .to_str()
        .unwrap()
        .replace(".json", ".hp.json");
    path.with_file_name(name)
}

/// A number of the reference (double files hold numbers, `.hp.json` files strings).
pub fn num(v: &Value) -> f64 {
    match v {
        Value::Number(n) => n.as_f64().unwrap(),
        Value::String(s) => s.parse().unwrap(),
        other => panic!("not a number: {other}"),
    }
}

pub fn vec3(v: &Value) -> [f64; 3] {
    let a = v.as_array().unwrap();
    [num(&a[0]), num(&a[1]), num(&a[2])]
}

pub fn matrix4(v: &Value) -> [[f64; 4]; 4] {
    let mut m = [[0.0; 4]; 4];
    for (i, row) in v.as_array().unwrap().iter().enumerate() {
        for (j, x) in row.as_array().unwrap().iter().enumerate() {
            m[i][j] = num(x);
        }
    }
    m
}

/// A reference `dh` model as the textbook evaluates it: one eq. 2.129 matrix per row
/// ([`kinechain::model::joint::dh_transform`], standard or modified), multiplied with
/// `nalgebra::Matrix4`, between the model's base and tool transforms.
pub struct DhProduct {
    convention: DhConvention,
    base: Matrix4<f64>,
    tool: Matrix4<f64>,
    /// Per row: revolute (else prismatic), a, α, d, θ, offset.
    rows: Vec<(bool, f64, f64, f64, f64, f64)>,
}

impl DhProduct {
    /// The product for a reference file's model, `None` unless it is a DH table.
    pub fn of(reference: &Value) -> Option<Self> {
        let m = &reference["model"];
        if m["kind"] != "dh" {
            return None;
        }
        let convention = if m["convention"] == "modified" {
            DhConvention::Modified
        } else {
            DhConvention::Standard
        };
        let rows = m["joints"]
            .as_array()
            .unwrap()
            .iter()
            .map(|j| {
                let [a, alpha, d, theta, offset] =
                    ["a", "alpha", "d", "theta", "offset"].map(|k| num(&j[k]));
                (j["type"] == "revolute", a, alpha, d, theta, offset)
            })
            .collect();
        Some(DhProduct {
            convention,
            base: Matrix4::from_fn(|i, j| matrix4(&m["base"])[i][j]),
            tool: Matrix4::from_fn(|i, j| matrix4(&m["tool"])[i][j]),
            rows,
        })
    }

    /// `world_from_link` of `link0` … `linkn` and then of the tool, at `q` (one entry per row).
    // Inlined into the table's timed loop, as the baseline's code was before it moved here: out
    // of line it measured 255 against 200 ns per modified DH Panda configuration.
    #[inline]
    pub fn poses(&self, q: &[f64], out: &mut Vec<Matrix4<f64>>) {
        out.clear();
        let mut t = self.base;
        out.push(t);
        for (&(revolute, a, alpha, d, theta, offset), &q) in self.rows.iter().zip(q) {
            let (theta, d) = if revolute {
                (q + offset, d)
            } else {
                (theta, q + offset)
            };
            t *= dh_transform(self.convention, a, alpha, d, theta);
            out.push(t);
        }
        out.push(t * self.tool);
    }

    /// The index in [`DhProduct::poses`] of a reference link name (`link<i>` or `tool`).
    pub fn index(&self, name: &str) -> usize {
        if name == "tool" {
            self.rows.len() + 1
        } else {
            name.trim_start_matches("link").parse().unwrap()
        }
    }
}

/// Shortest round-trip text of a float, as YAML accepts it.
fn f(x: f64) -> String {
    assert!(x.is_finite());
    format!("{x:?}")
}

fn matrix_yaml(v: &Value) -> String {
    let rows: Vec<String> = matrix4(v)
        .iter()
        .map(|r| {
            format!(
                "[{}]",
                r.iter().map(|x| f(*x)).collect::<Vec<_>>().join(", ")
            )
        })
        .collect();
    format!("[{}]", rows.join(", "))
}

/// A reference `dh` or `axis` model written in kinechain's DH YAML format (as documented in the
/// README), following the reference README's conventions.
pub fn model_yaml(reference: &Value) -> String {
    let m = &reference["model"];
    let mut out = vec![format!("name: {}", reference["robot"].as_str().unwrap())];
    match m["kind"].as_str().unwrap() {
        "dh" => {
            out.push(format!("convention: {}", m["convention"].as_str().unwrap()));
            out.push(format!(
                "base: {{name: link0, matrix: {}}}",
                matrix_yaml(&m["base"])
            ));
            out.push(format!(
                "tool: {{name: tool, matrix: {}}}",
                matrix_yaml(&m["tool"])
            ));
            out.push("joints:".into());
            for j in m["joints"].as_array().unwrap() {
                assert_eq!(
                    j["flip"],
                    Value::Bool(false),
                    "flipped joints are not modelled"
                );
                let kind = j["type"].as_str().unwrap();
                // Revolute: theta = q + offset, d constant; prismatic: d = q + offset.
                let (theta, d) = match kind {
                    "revolute" => (num(&j["offset"]), num(&j["d"])),
                    "prismatic" => (num(&j["theta"]), num(&j["offset"])),
                    other => panic!("{other}"),
                };
                let lim = j["qlim"].as_array().unwrap();
                out.push(format!(
                    "  - {{name: {}, link: {}, type: {kind}, a: {}, alpha: {}, d: {}, theta: {}, limits: [{}, {}]}}",
                    j["name"].as_str().unwrap(),
                    j["link"].as_str().unwrap(),
                    f(num(&j["a"])),
                    f(num(&j["alpha"])),
                    f(d),
                    f(theta),
                    f(num(&lim[0])),
                    f(num(&lim[1])),
                ));
            }
        }
        "axis" => {
            out.push("convention: axis".into());
            out.push(format!(
                "base: {{name: {}}}",
                m["base_link"].as_str().unwrap()
            ));
            out.push("joints:".into());
            for j in m["joints"].as_array().unwrap() {
                let axis = vec3(&j["axis"]);
                out.push(format!("  - name: {}", j["name"].as_str().unwrap()));
                out.push(format!("    link: {}", j["link"].as_str().unwrap()));
                out.push(format!("    type: {}", j["type"].as_str().unwrap()));
                out.push(format!(
                    "    origin: {{matrix: {}}}",
                    matrix_yaml(&j["origin"])
                ));
                out.push(format!(
                    "    axis: [{}, {}, {}]",
                    f(axis[0]),
                    f(axis[1]),
                    f(axis[2])
                ));
            }
        }
        other => panic!("no YAML form for model kind {other}"),
    }
    out.join("\n") + "\n"
}

/// The chain a reference file describes.
pub fn reference_chain(path: &Path, reference: &Value) -> Chain {
    let m = &reference["model"];
    let chain = if m["kind"] == "urdf" {
        Chain::from_file(path.with_file_name(m["file"].as_str().unwrap()))
    } else {
        Chain::from_dh_yaml_str(&model_yaml(reference))
    };
    chain.unwrap_or_else(|e| panic!("{}: {}", path.display(), kinechain::error::error_chain(&e)))
}

/// A `{joint: value}` map of a sample (`q`, `qd` or `qdd`) in the chain's `q` order.
pub fn joint_vector(chain: &Chain, map: &Value) -> Vec<f64> {
    kinechain::io::input::joint_vector_from_json(chain, map, "q").unwrap()
}

/// Largest absolute difference between the top three rows of two poses.
pub fn pose_error(a: &Transform, b: &[[f64; 4]; 4]) -> f64 {
    let (position, rotation) = pose_entry_errors(&a.to_rows(), b);
    worse(position, rotation)
}

/// Largest absolute differences between the positions and between the rotation entries of two
/// poses given as rows, `(position, rotation)`; NaN when either pose has a NaN there.
pub fn pose_entry_errors(got: &[[f64; 4]; 4], want: &[[f64; 4]; 4]) -> (f64, f64) {
    let (mut position, mut rotation) = (0.0_f64, 0.0_f64);
    for (g, w) in got.iter().zip(want).take(3) {
        position = worse(position, (g[3] - w[3]).abs());
        for c in 0..3 {
            rotation = worse(rotation, (g[c] - w[c]).abs());
        }
    }
    (position, rotation)
}

/// Folds one pose's [`pose_entry_errors`] into the worst so far.
pub fn worse_pose(worst: (f64, f64), got: &[[f64; 4]; 4], want: &[[f64; 4]; 4]) -> (f64, f64) {
    let (position, rotation) = pose_entry_errors(got, want);
    (worse(worst.0, position), worse(worst.1, rotation))
}

pub fn vec_error(a: &kinechain::nalgebra::Vector3<f64>, b: [f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, worse)
}

/// The largest magnitude of a link quantity over every sample and link of a reference file
/// (at least 1): errors are reported relative to it.
pub fn scale_of(reference: &Value, field: &str) -> f64 {
    let mut s: f64 = 1.0;
    for sample in reference["samples"].as_array().unwrap() {
        for link in sample["links"].as_object().unwrap().values() {
            let v = &link[field];
            if field == "pose" {
                for row in v.as_array().unwrap().iter().take(3) {
                    s = s.max(num(&row[3]).abs());
                }
            } else {
                for x in v.as_array().unwrap() {
                    s = s.max(num(x).abs());
                }
            }
        }
    }
    s
}

/// A deterministic generator for test inputs.
pub fn rng(seed: u64) -> rand_chacha::ChaCha8Rng {
    use rand::SeedableRng;
    rand_chacha::ChaCha8Rng::seed_from_u64(seed)
}

/// A random configuration within the joints' limits (±π where a joint has none); a floating
/// joint anywhere in the cube [-1, 1]³ m, turned by a uniformly random unit quaternion, and a
/// ball joint turned by one.
pub fn random_q(chain: &Chain, rng: &mut impl rand::Rng) -> Vec<f64> {
    let mut q = vec![0.0; chain.nq()];
    for joint in chain.joints() {
        let Some(first) = joint.q_index() else {
            continue;
        };
        if joint.kind() == kinechain::JointKind::Floating {
            for x in &mut q[first..first + 3] {
                *x = 2.0 * rng.random::<f64>() - 1.0;
            }
            q[first + 3..first + 7].copy_from_slice(&random_quaternion(rng));
            continue;
        }
        if joint.kind() == kinechain::JointKind::Ball {
            q[first..first + 4].copy_from_slice(&random_quaternion(rng));
            continue;
        }
        for (k, limits) in joint.limits().iter().enumerate() {
            let (lo, hi) = match limits {
                Some(l) if l.lower.is_finite() && l.upper.is_finite() => (l.lower, l.upper),
                _ => (-std::f64::consts::PI, std::f64::consts::PI),
            };
            q[first + k] = lo + (hi - lo) * rng.random::<f64>();
        }
    }
    q
}

/// A uniformly random unit quaternion (w, x, y, z), by Shoemake's method.
pub fn random_quaternion(rng: &mut impl rand::Rng) -> [f64; 4] {
    let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
    let tau = 2.0 * std::f64::consts::PI;
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    [
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
        b * (tau * u3).cos(),
    ]
}

/// A random vector with entries uniform in [-scale, scale].
pub fn random_vec(n: usize, scale: f64, rng: &mut impl rand::Rng) -> Vec<f64> {
    (0..n)
        .map(|_| scale * (2.0 * rng.random::<f64>() - 1.0))
        .collect()
}

/// Largest errors of every link pose of every sample of the reference file `path` against its
/// 50-digit twin, evaluated on the instruction set in use: position in ulps of the chain's reach
/// and rotation entries in ulps (of 1).
pub fn pose_ulps(path: &Path) -> (f64, f64) {
    const ULP: f64 = f64::EPSILON;
    let reference = read_json(path);
    let exact = read_json(&hp_path(path));
    let chain = reference_chain(path, &reference);
    let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let reach = scale_of(&exact, "pose");
    let mut worst = (0.0_f64, 0.0_f64);
    for sample in exact["samples"].as_array().unwrap() {
        let q = joint_vector(&chain, &sample["q"]);
        let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
        for (name, link) in sample["links"].as_object().unwrap() {
            let got = poses
                .world_from_link(chain.link_id(name).unwrap())
                .to_rows();
            worst = worse_pose(worst, &got, &matrix4(&link["pose"]));
        }
    }
    (worst.0 / (reach * ULP), worst.1 / ULP)
}

/// The fields of a reference file's link rates: ω, v, α and a.
pub const RATE_FIELDS: [&str; 4] = ["omega", "v", "alpha", "a"];

/// Largest absolute errors of ω, v, α and a (in the order of [`RATE_FIELDS`]) over every sample and
/// link of a reference file (`file`, for `chain`), and the largest magnitude of each in the file.
pub fn rate_errors(chain: &Chain, file: &Value) -> ([f64; 4], [f64; 4]) {
    let mut data = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
    let (mut worst, mut largest) = ([0.0_f64; 4], [0.0_f64; 4]);
    for sample in file["samples"].as_array().unwrap() {
        let q = joint_vector(chain, &sample["q"]);
        let qd = joint_vector(chain, &sample["qd"]);
        let qdd = joint_vector(chain, &sample["qdd"]);
        let acc = forward_accelerations(chain, &mut data, &q, &qd, &qdd).unwrap();
        for (name, link) in sample["links"].as_object().unwrap() {
            let id = chain.link_id(name).unwrap();
            let (v, a) = (acc.velocity(id), acc.acceleration(id));
            for (k, got) in [v.omega, v.v, a.alpha, a.a].iter().enumerate() {
                let want = vec3(&link[RATE_FIELDS[k]]);
                worst[k] = worse(worst[k], vec_error(got, want));
                largest[k] = want.iter().fold(largest[k], |m, x| m.max(x.abs()));
            }
        }
    }
    (worst, largest)
}

/// [`rate_errors`] of the reference file `path` against its 50-digit twin, in ulps (2⁻⁵²) of the
/// largest magnitude of each quantity over the file.
pub fn rate_ulps(path: &Path) -> [f64; 4] {
    let chain = reference_chain(path, &read_json(path));
    let (worst, largest) = rate_errors(&chain, &read_json(&hp_path(path)));
    std::array::from_fn(|k| worst[k] / (largest[k] * f64::EPSILON))
}

/// Every bundled robot and every reference model, each with a name for messages.
pub fn all_models() -> Vec<(String, Chain)> {
    let mut out: Vec<(String, Chain)> = robot_files()
        .into_iter()
        .map(|p| (p.display().to_string(), Chain::from_file(&p).unwrap()))
        .collect();
    for path in reference_files() {
        let chain = reference_chain(&path, &read_json(&path));
        out.push((path.display().to_string(), chain));
    }
    out
}

/// The ids of all of `chain`'s links, in the order of `chain.links()`.
pub fn link_ids(chain: &Chain) -> Vec<kinechain::LinkId> {
    chain
        .links()
        .iter()
        .map(|l| chain.link_id(l.name()).unwrap())
        .collect()
}

/// Asserts that batches (one thread and parallel, and of the end link alone) of 37 random
/// configurations of each robot file give, configuration by configuration and bit for bit, what
/// single evaluations give: four full chunks of eight and a partial one.
pub fn assert_batches_equal_single_evaluations(files: &[&str], seed: u64) {
    use kinechain::eval::batch::{
        BatchData, forward_kinematics_batch, forward_kinematics_batch_par,
        forward_kinematics_batch_to,
    };
    let mut rng = rng(seed);
    for file in files {
        let chain = repo_chain(file);
        let mut single = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let mut batch = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let mut qs: Vec<f64> = (0..37).flat_map(|_| random_q(&chain, &mut rng)).collect();
        // Angles beyond the fast reduction's range, which the lanes hand to the standard library:
        // single entries among ordinary ones, and one configuration with every entry there.
        // (With a floating base, the first entries are its position, the last joint's last.)
        let nq = chain.nq();
        for (configuration, entry, x) in [(3, 0, 1e6 + 0.3), (20, nq - 1, -2.5e7), (21, 0, 3e9)] {
            qs[configuration * nq + entry] = x;
        }
        qs[25 * nq..26 * nq].fill(-8.4e5);
        if chain.floating_joint().is_some() {
            qs[25 * nq + 3..25 * nq + 7].copy_from_slice(&[0.5, -0.5, 0.5, 0.5]);
        }
        let links = link_ids(&chain);
        let expected: Vec<Vec<Transform>> = qs
            .chunks(nq)
            .map(|q| {
                let p = forward_kinematics(&chain, &mut single, q).unwrap();
                links.iter().map(|&l| p.world_from_link(l)).collect()
            })
            .collect();
        for parallel in [false, true] {
            let poses = if parallel {
                forward_kinematics_batch_par(&chain, &mut batch, &qs).unwrap()
            } else {
                forward_kinematics_batch(&chain, &mut batch, &qs).unwrap()
            };
            assert_eq!(poses.len(), 37);
            for (i, want) in expected.iter().enumerate() {
                for (&id, pose) in links.iter().zip(want) {
                    assert_eq!(
                        poses.world_from_link(i, id),
                        *pose,
                        "{file} configuration {i} link {id:?}"
                    );
                }
            }
        }
        let end = chain.end_link();
        let end_index = links.iter().position(|&l| l == end).unwrap();
        let one = forward_kinematics_batch_to(&chain, &mut batch, &qs, end).unwrap();
        for (i, want) in expected.iter().enumerate() {
            assert_eq!(
                one.world_from_link(i),
                want[end_index],
                "{file} configuration {i}, end link alone"
            );
        }
    }
}

/// Batches check each chunk's lanes as they transpose them (with the instruction set in use): at
/// every lane and chunk position, at and one ulp past the limits, and for non-finite values, a
/// batch is accepted exactly when every configuration passes `check_q`, by all three entry points.
pub fn assert_lane_checks_decide_as_check_q_does() {
    use kinechain::eval::batch::{
        BatchData, forward_kinematics_batch, forward_kinematics_batch_par,
        forward_kinematics_batch_to,
    };
    let chain = Chain::from_file(robots_dir().join("puma560.yaml")).unwrap();
    let tool = chain.link_id("tool").unwrap();
    let limits = chain.joints()[5].limits()[0].unwrap();
    let values: Vec<f64> = [0.0].into_iter().chain(limit_probes(&limits)).collect();
    let mut batch = BatchData::new(&chain);
    let (mut accepted, mut rejected) = (0, 0);
    for policy in [LimitPolicy::Enforce, LimitPolicy::Ignore] {
        batch.set_limit_policy(policy);
        for bad in [0, 3, 7, 8, 13, 18] {
            for &x in &values {
                let mut qs = vec![0.1; 6 * 19];
                qs[6 * bad + 5] = x;
                let want = qs
                    .chunks(6)
                    .position(|q| kinechain::check_q(&chain, q, policy).is_err());
                let got = [
                    forward_kinematics_batch(&chain, &mut batch, &qs).err(),
                    forward_kinematics_batch_to(&chain, &mut batch, &qs, tool).err(),
                    forward_kinematics_batch_par(&chain, &mut batch, &qs).err(),
                ];
                for e in got {
                    assert_eq!(e.map(|e| e.index), want, "{policy:?}, {x} at {bad}");
                }
                match want {
                    None => accepted += 1,
                    Some(_) => rejected += 1,
                }
            }
        }
    }
    // Both outcomes occur under each policy's values.
    assert!(accepted >= 18 && rejected >= 18, "{accepted} / {rejected}");
}

/// Worst errors of `file`'s link poses at joint angles of up to 10⁷, 10⁹ and 10¹⁵ rad (beyond
/// the fast reduction, where the standard library takes over) against the 256-bit evaluation:
/// positions in ulps of the reach, rotation entries in ulps.
#[cfg(feature = "reference")]
pub fn large_angle_pose_ulps(file: &str) -> (f64, f64) {
    let chain = repo_chain(file);
    let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let mut rng = rng(11);
    let (mut position, mut rotation) = (0.0_f64, 0.0_f64);
    for scale in [1e7, 1e9, 1e15] {
        for _ in 0..8 {
            let q = random_vec(chain.dof(), scale, &mut rng);
            let exact = kinechain::reference::link_poses(&chain, &q);
            let reach = exact
                .iter()
                .fold(1e-300_f64, |m, t| m.max(t.translation().amax()));
            let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
            let mut worst = (0.0_f64, 0.0_f64);
            for (id, want) in link_ids(&chain).into_iter().zip(&exact) {
                worst = worse_pose(worst, &poses.world_from_link(id).to_rows(), &want.to_rows());
            }
            position = worse(position, worst.0 / (reach * f64::EPSILON));
            rotation = worse(rotation, worst.1 / f64::EPSILON);
        }
    }
    (position, rotation)
}

/// Values that probe a limit check on `limits`: both bounds, the doubles just outside them, and
/// the non-finite values.
pub fn limit_probes(limits: &kinechain::Limits) -> [f64; 7] {
    [
        limits.lower,
        limits.upper,
        limits.lower.next_down(),
        limits.upper.next_up(),
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ]
}

/// Revolute seven times in ten, else prismatic or cylindrical.
pub fn random_kind(rng: &mut impl rand::Rng) -> JointKind {
    match rng.random_range(0..10) {
        0 => JointKind::Prismatic,
        1 => JointKind::Cylindrical,
        _ => JointKind::Revolute,
    }
}

/// Joint `j{i}` of `kind` from `link{i-1}` to `link{i}`.
pub fn joint_to_link(i: usize, kind: JointKind) -> JointSpec {
    JointSpec::new(
        format!("j{i}"),
        kind,
        format!("link{}", i - 1),
        format!("link{i}"),
    )
}

/// A random chain of `n` standard DH rows (`Rz(θ) Tz(d) Tx(a) Rx(α)`, the joint at its parent's
/// origin on the parent's z axis): a and d up to 0.3 m, random α, θ and d offsets, revolute,
/// prismatic and cylindrical joints.
pub fn random_standard_dh_chain(n: usize, seed: u64) -> Chain {
    let mut rng = rng(seed);
    let mut b = ChainBuilder::new(format!("dh{n}"));
    b.link("link0");
    for i in 1..=n {
        let kind = random_kind(&mut rng);
        let (a, d) = (0.3 * rng.random::<f64>(), 0.3 * rng.random::<f64>());
        let alpha = rng.random::<f64>() * 6.0 - 3.0;
        let theta = rng.random::<f64>() * 6.0 - 3.0;
        b.link(format!("link{i}"));
        b.joint(
            joint_to_link(i, kind)
                .with_offsets(theta, d)
                .with_post(Transform::from_xyz_rpy([a, 0.0, 0.0], [alpha, 0.0, 0.0])),
        );
    }
    b.build().unwrap()
}

/// Every batch path equals single evaluations of the same configurations bit for bit (poses of
/// every link, one link, rates, Jacobians and their rates; one thread and several), and the
/// `f32` batch equals them to its precision: random configurations of `chain` (quaternions of
/// floating and ball joints included), `label` naming it in failures.
pub fn assert_batches_equal_single(chain: &Chain, label: &str) {
    use kinechain::JacobianFrame;
    use kinechain::eval::batch::{
        BatchData, forward_accelerations_batch, forward_accelerations_batch_par,
        forward_kinematics_batch, forward_kinematics_batch_par, forward_kinematics_batch_to,
        jacobian_batch, jacobian_batch_par, jacobian_dot_batch, single_precision,
    };
    let (nq, nv) = (chain.nq(), chain.nv());
    let mut r = rng(21);
    // Four full chunks of eight, a partial one; 600 for the parallel Jacobians' pieces.
    for n in [37, 600] {
        let qs: Vec<f64> = (0..n).flat_map(|_| random_q(chain, &mut r)).collect();
        let qds = random_vec(n * nv, 1.0, &mut r);
        let qdds = random_vec(n * nv, 1.0, &mut r);
        let mut single = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
        let mut batch = BatchData::new(chain).with_limit_policy(LimitPolicy::Ignore);
        let links: Vec<_> = chain
            .links()
            .iter()
            .map(|l| chain.link_id(l.name()).unwrap())
            .collect();
        let end = chain.end_link();
        let acc = forward_accelerations_batch(chain, &mut batch, &qs, &qds, &qdds)
            .unwrap()
            .velocities()
            .world_from_link(n - 1, end);
        let mut j = vec![0.0; n * 6 * nv];
        let mut j_par = vec![0.0; n * 6 * nv];
        let mut j_dot = vec![0.0; n * 6 * nv];
        jacobian_batch(chain, &mut batch, &qs, end, JacobianFrame::Link, &mut j).unwrap();
        jacobian_batch_par(chain, &mut batch, &qs, end, JacobianFrame::Link, &mut j_par).unwrap();
        assert_eq!(j, j_par, "{label}");
        jacobian_dot_batch(
            chain,
            &mut batch,
            &qs,
            &qds,
            end,
            JacobianFrame::World,
            &mut j_dot,
        )
        .unwrap();
        for i in 0..n {
            let (q, qd, qdd) = (
                &qs[i * nq..(i + 1) * nq],
                &qds[i * nv..(i + 1) * nv],
                &qdds[i * nv..(i + 1) * nv],
            );
            let s = forward_accelerations(chain, &mut single, q, qd, qdd).unwrap();
            if i == n - 1 {
                assert_eq!(acc, s.world_from_link(end));
            }
            let want_j = s.poses().jacobian_in(end, JacobianFrame::Link);
            let want_jd = s.velocities().jacobian_dot(end);
            for r in 0..6 {
                for c in 0..nv {
                    assert_eq!(
                        j[i * 6 * nv + r * nv + c].to_bits(),
                        want_j[(r, c)].to_bits(),
                        "{label} J {i} {r} {c}"
                    );
                    assert_eq!(
                        j_dot[i * 6 * nv + r * nv + c].to_bits(),
                        want_jd[(r, c)].to_bits(),
                        "{label} J̇ {i} {r} {c}"
                    );
                }
            }
        }
        let poses = forward_kinematics_batch(chain, &mut batch, &qs).unwrap();
        let expected: Vec<Vec<Transform>> = qs
            .chunks(nq)
            .map(|q| {
                let p = forward_kinematics(chain, &mut single, q).unwrap();
                links.iter().map(|&l| p.world_from_link(l)).collect()
            })
            .collect();
        for (i, want) in expected.iter().enumerate() {
            for (&id, pose) in links.iter().zip(want) {
                assert_eq!(poses.world_from_link(i, id), *pose, "{label} {i} {id:?}");
            }
        }
        let par = forward_kinematics_batch_par(chain, &mut batch, &qs).unwrap();
        for (i, want) in expected.iter().enumerate() {
            for (&id, pose) in links.iter().zip(want) {
                assert_eq!(par.world_from_link(i, id), *pose, "{label} {i} {id:?} par");
            }
        }
        let end_index = links.iter().position(|&l| l == end).unwrap();
        let one = forward_kinematics_batch_to(chain, &mut batch, &qs, end).unwrap();
        for (i, want) in expected.iter().enumerate() {
            assert_eq!(one.world_from_link(i), want[end_index], "{label} {i} end");
        }
        // Rates: every link, one thread and parallel.
        for parallel in [false, true] {
            let r = if parallel {
                forward_accelerations_batch_par(chain, &mut batch, &qs, &qds, &qdds)
            } else {
                forward_accelerations_batch(chain, &mut batch, &qs, &qds, &qdds)
            }
            .unwrap();
            for i in [0, n / 2, n - 1] {
                let (q, qd, qdd) = (
                    &qs[i * nq..(i + 1) * nq],
                    &qds[i * nv..(i + 1) * nv],
                    &qdds[i * nv..(i + 1) * nv],
                );
                let s = forward_accelerations(chain, &mut single, q, qd, qdd).unwrap();
                for &id in &links {
                    assert_eq!(r.velocity(i, id), s.velocity(id), "{label} {i} {id:?}");
                    assert_eq!(
                        r.acceleration(i, id),
                        s.acceleration(id),
                        "{label} {i} {id:?}"
                    );
                }
            }
        }
        // Single precision: the same poses to its precision.
        let mut b32 =
            single_precision::BatchData::new(chain).with_limit_policy(LimitPolicy::Ignore);
        let mut e32 =
            single_precision::BatchData::new(chain).with_limit_policy(LimitPolicy::Ignore);
        let p32 = single_precision::forward_kinematics_batch(chain, &mut b32, &qs).unwrap();
        let one32 =
            single_precision::forward_kinematics_batch_to(chain, &mut e32, &qs, end).unwrap();
        for (i, want) in expected.iter().enumerate() {
            let tol = 1e-5 * (1.0 + chain.reach());
            let close = |t: Transform, w: &Transform| {
                (t.to_homogeneous() - w.to_homogeneous()).abs().max() < tol
            };
            assert!(
                close(one32.world_from_link(i), &want[end_index]),
                "{label} {i} f32 end"
            );
            for (&id, pose) in links.iter().zip(want) {
                assert!(
                    close(p32.world_from_link(i, id), pose),
                    "{label} {i} {id:?} f32"
                );
            }
        }
    }
}

/// `(q, q̇, q̈)` in `layout` and back: the way back must give them again within 1e-14 (`label`
/// naming the chain in failures). Returns them in `layout`.
pub fn assert_layout_round_trip(
    chain: &Chain,
    layout: kinechain::eval::layouts::Layout,
    (q, qd, qdd): (&[f64], &[f64], &[f64]),
    label: &str,
) -> kinechain::eval::layouts::JointState {
    let theirs = chain.to_layout(layout, q, Some(qd), Some(qdd)).unwrap();
    let back = chain
        .from_layout(
            layout,
            &theirs.q,
            theirs.q_dot.as_deref(),
            theirs.q_ddot.as_deref(),
        )
        .unwrap();
    let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-14);
    assert!(close(&back.q, q), "{label} {layout:?} q");
    assert!(
        close(back.q_dot.as_deref().unwrap(), qd),
        "{label} {layout:?} qd"
    );
    assert!(
        close(back.q_ddot.as_deref().unwrap(), qdd),
        "{label} {layout:?} qdd"
    );
    theirs
}

/// Every link's pose, velocity and acceleration at 50 random states of `chain` (rates in
/// [-2, 2]) against the 256-bit evaluation, which must also give the same poses when asked for
/// poses alone: poses within 8 ulp (positions over 4 m, the chains staying within 2 m of the
/// origin) and every rate within 8 ulp, `label` naming the chain in failures.
#[cfg(feature = "reference")]
pub fn assert_within_8_ulp_of_the_256_bit_evaluation(chain: &Chain, label: &str) {
    let mut data = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
    let mut r = rng(55);
    let (mut pose_worst, mut rate_worst) = (0.0_f64, [0.0_f64; 4]);
    let ids: Vec<_> = (0..chain.links().len())
        .map(|l| chain.link_id(chain.links()[l].name()).unwrap())
        .collect();
    for _ in 0..50 {
        let q = random_q(chain, &mut r);
        let qd = random_vec(chain.nv(), 2.0, &mut r);
        let qdd = random_vec(chain.nv(), 2.0, &mut r);
        let exact = kinechain::reference::link_motion(chain, &q, &qd, &qdd);
        let got = forward_accelerations(chain, &mut data, &q, &qd, &qdd).unwrap();
        let poses: Vec<Transform> = ids.iter().map(|&id| got.world_from_link(id)).collect();
        let want: Vec<Transform> = exact.iter().map(|m| m.pose).collect();
        assert_eq!(kinechain::reference::link_poses(chain, &q), want, "{label}");
        let (p, rot) = kinechain::reference::max_errors(&poses, &want);
        pose_worst = pose_worst.max(p / 4.0).max(rot);
        let rates: Vec<[[f64; 3]; 4]> = ids
            .iter()
            .map(|&id| {
                let (v, a) = (got.velocity(id), got.acceleration(id));
                [v.omega.into(), v.v.into(), a.alpha.into(), a.a.into()]
            })
            .collect();
        for (w, (_, ulps)) in rate_worst
            .iter_mut()
            .zip(kinechain::reference::max_rate_errors(&rates, &exact))
        {
            *w = w.max(ulps);
        }
    }
    assert!(pose_worst < 8.0 * f64::EPSILON, "{label} {pose_worst:e}");
    assert!(
        rate_worst.iter().all(|&u| u < 8.0),
        "{label} {rate_worst:?}"
    );
}

/// The rotation of the quaternion `e` (w, x, y, z) normalised, from nalgebra.
pub fn rotation(e: &[f64]) -> kinechain::nalgebra::Matrix3<f64> {
    let q = kinechain::nalgebra::UnitQuaternion::from_quaternion(
        kinechain::nalgebra::Quaternion::new(e[0], e[1], e[2], e[3]),
    );
    *q.to_rotation_matrix().matrix()
}

/// Every link's pose at `q`, limits not checked.
pub fn link_poses(chain: &Chain, q: &[f64]) -> Vec<Transform> {
    let mut d = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
    let p = forward_kinematics(chain, &mut d, q).unwrap();
    (0..chain.links().len())
        .map(|i| p.world_from_link(chain.link_id(chain.links()[i].name()).unwrap()))
        .collect()
}

/// `q` moved along `(q̇, q̈)` for a time `t`, and the world `q̇` there: each one-coordinate entry
/// by `q + q̇ t + q̈ t²/2`; each ball or floating joint's quaternion by the turn `ω t + ε t²/2`
/// taken in the axes of the frame it turns in (fixed in its parent, where `ε` is the rate of
/// `ω`), a floating joint's position by `u t + a t²/2` in those axes (`u`, `a` its `q̇` and `q̈`
/// in them), its `q̇` at `t` that frame's world rotation then times `ω + ε t` (and `u + a t`).
/// (The turn's error is of order t³.)
pub fn advance(chain: &Chain, q: &[f64], qd: &[f64], qdd: &[f64], t: f64) -> (Vec<f64>, Vec<f64>) {
    let mut out = q.to_vec();
    let mut qd_t: Vec<f64> = qd.iter().zip(qdd).map(|(v, a)| v + a * t).collect();
    // The world rotation of each ball's or floating joint's frame before its turn (at the q in
    // `at`; `first` the quaternion's first entry).
    let frame_of = |at: &[f64], first: usize| {
        let joint = chain
            .quaternions()
            .iter()
            .find(|x| x.1 == first)
            .map(|x| chain.joint(x.0))
            .unwrap();
        let poses = link_poses(chain, at);
        let child = poses[joint.child().index()].rotation();
        child * rotation(&at[first..first + 4]).transpose()
    };
    // Linear rates first: in the frame's axes at the start.
    let mut moved_positions = Vec::new();
    for joint in chain.joints() {
        let (Some(first), Some(v)) = (joint.q_index(), joint.v_index()) else {
            continue;
        };
        match joint.kind() {
            kinechain::JointKind::Ball => {}
            kinechain::JointKind::Floating => {
                let r0 = frame_of(q, first + 3);
                let u =
                    r0.transpose() * kinechain::nalgebra::Vector3::new(qd[v], qd[v + 1], qd[v + 2]);
                let a = r0.transpose()
                    * kinechain::nalgebra::Vector3::new(qdd[v], qdd[v + 1], qdd[v + 2]);
                for k in 0..3 {
                    out[first + k] += u[k] * t + 0.5 * a[k] * t * t;
                }
                moved_positions.push((first + 3, v, u + a * t));
            }
            _ => {
                for k in 0..joint.nq() {
                    out[first + k] += qd[v + k] * t + 0.5 * qdd[v + k] * t * t;
                }
            }
        }
    }
    // Turns last: each frame's rotation at t needs the joints before it moved.
    let angular = |j: kinechain::JointId| {
        let joint = chain.joint(j);
        joint.v_index().unwrap()
            + if joint.kind() == kinechain::JointKind::Floating {
                3
            } else {
                0
            }
    };
    for &(j, first) in chain.quaternions() {
        let v = angular(j);
        let r0 = frame_of(q, first);
        let w = r0.transpose() * kinechain::nalgebra::Vector3::new(qd[v], qd[v + 1], qd[v + 2]);
        let eps =
            r0.transpose() * kinechain::nalgebra::Vector3::new(qdd[v], qdd[v + 1], qdd[v + 2]);
        let dq = kinechain::nalgebra::UnitQuaternion::from_scaled_axis(w * t + eps * (0.5 * t * t));
        let e = kinechain::nalgebra::Quaternion::new(
            q[first],
            q[first + 1],
            q[first + 2],
            q[first + 3],
        );
        // The turn is about axes of the frame before the joint: it multiplies from the left.
        let moved = dq.into_inner() * e;
        out[first..first + 4].copy_from_slice(&[moved.w, moved.i, moved.j, moved.k]);
    }
    for &(j, first) in chain.quaternions() {
        let v = angular(j);
        let r0 = frame_of(q, first);
        let rt = frame_of(&out, first);
        let local = r0.transpose()
            * kinechain::nalgebra::Vector3::new(
                qd[v] + qdd[v] * t,
                qd[v + 1] + qdd[v + 1] * t,
                qd[v + 2] + qdd[v + 2] * t,
            );
        let world = rt * local;
        qd_t[v..v + 3].copy_from_slice(world.as_slice());
    }
    for (first, v, local) in moved_positions {
        let world = frame_of(&out, first) * local;
        qd_t[v..v + 3].copy_from_slice(world.as_slice());
    }
    (out, qd_t)
}

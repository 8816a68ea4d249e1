//! Run time against error: for every robot of the reference data and every method, the time per
//! configuration and the largest error against the 50-digit references (`*.hp.json`).
//!
//! `cargo bench --bench table` prints a markdown table and writes it, with an SVG plot (log–log,
//! time against error), to `docs/bench/`.
//!
//! Timing: each method evaluates the 22 reference configurations in a loop lasting at least
//! 100 ms; the methods of a robot run in alternation for seven rounds (`measure::Interleaved`),
//! so that they share the machine's conditions. The time is the median over the rounds, divided
//! by the number of configurations; "× k" is the median of the per-round ratios to `k` (which
//! runs on the URDF models, and on the others as `kinechain convert` writes them).

#[path = "../tests/common/mod.rs"]
mod common;

use common::*;
use kinechain::eval::batch::{BatchData, forward_kinematics_batch, single_precision};
use kinechain::measure::Interleaved;
use kinechain::{Data, Isa, LimitPolicy, LinkId, Transform, force_isa, forward_kinematics, isa};
use plotters::prelude::*;
use std::fmt::Write as _;
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

struct Row {
    method: String,
    robot: String,
    ns: f64,
    /// How many times faster than `k` and than the naive product (DH models) in the same rounds.
    vs_k: Option<f64>,
    vs_naive: Option<f64>,
    position: f64,
    reach: f64,
    rotation: f64,
    /// Whether the method computes in `f32` (the single-precision batch), whose position error
    /// the table also gives in `f32` ulps.
    single_precision: bool,
}

impl Row {
    /// The position error in ulps of the reach, an ulp being `epsilon` times the reach.
    fn position_ulps(&self, epsilon: f64) -> f64 {
        self.position / (self.reach * epsilon)
    }
}

/// One method of a robot: label, poses of every reference configuration, and one timed call
/// (evaluating all configurations `repeat` times).
struct Method<'a> {
    label: &'static str,
    poses: Vec<Vec<[[f64; 4]; 4]>>,
    call: Box<dyn FnMut() + 'a>,
    repeat: usize,
    /// As [`Row::single_precision`].
    single_precision: bool,
}

/// Largest position and rotation-entry errors of per-sample link poses against the 50-digit file.
fn errors(exact: &serde_json::Value, names: &[String], poses: &[Vec<[[f64; 4]; 4]>]) -> (f64, f64) {
    let (mut position, mut rotation) = (0.0_f64, 0.0_f64);
    for (sample, got) in exact["samples"].as_array().unwrap().iter().zip(poses) {
        for (name, pose) in names.iter().zip(got) {
            let want = matrix4(&sample["links"][name.as_str()]["pose"]);
            for i in 0..3 {
                position = position.max((pose[i][3] - want[i][3]).abs());
                for j in 0..3 {
                    rotation = rotation.max((pose[i][j] - want[i][j]).abs());
                }
            }
        }
    }
    (position, rotation)
}

/// A batch method: `evaluate(flat, keep)` evaluates the batch `flat` (the reference
/// configurations repeated 16 times) and returns, when `keep`, the poses of the first copy.
fn batch_method<'a>(
    label: &'static str,
    single_precision: bool,
    flat: Vec<f64>,
    mut evaluate: impl FnMut(&[f64], bool) -> Vec<Vec<[[f64; 4]; 4]>> + 'a,
) -> Method<'a> {
    let poses = evaluate(&flat, true);
    Method {
        label,
        poses,
        call: Box::new(move || {
            black_box(evaluate(black_box(&flat), false));
        }),
        repeat: 16,
        single_precision,
    }
}

/// The poses of links `ids` in configurations `0..n` read by `pose(i, link)` (nothing, without
/// allocating, for `None`).
fn batch_poses(
    n: Option<usize>,
    ids: &[LinkId],
    pose: impl Fn(usize, LinkId) -> Transform,
) -> Vec<Vec<[[f64; 4]; 4]>> {
    (0..n.unwrap_or(0))
        .map(|i| ids.iter().map(|&l| pose(i, l).to_rows()).collect())
        .collect()
}

fn rows_for(path: &Path) -> Vec<Row> {
    let reference = read_json(path);
    let exact = read_json(&hp_path(path));
    let robot = format!(
        "{}/{}",
        path.parent()
            .unwrap()
            .file_name()
            .unwrap()
            .to_string_lossy(),
        reference["robot"].as_str().unwrap()
    );
    let chain = &reference_chain(path, &reference);
    let samples = reference["samples"].as_array().unwrap();
    let qs: Vec<Vec<f64>> = samples
        .iter()
        .map(|s| joint_vector(chain, &s["q"]))
        .collect();
    let names: Vec<String> = samples[0]["links"]
        .as_object()
        .unwrap()
        .keys()
        .cloned()
        .collect();
    let ids: Vec<_> = names.iter().map(|n| chain.link_id(n).unwrap()).collect();
    let reach = scale_of(&exact, "pose");
    let qs = &qs;
    let mut methods: Vec<Method<'_>> = Vec::new();

    // kinechain, one configuration per call, on the detected instruction set and on baseline x86-64.
    for (label, level) in [
        ("kinechain", None),
        ("kinechain, baseline x86-64", Some(Isa::Baseline)),
    ] {
        force_isa(level);
        let mut data = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
        let poses: Vec<Vec<[[f64; 4]; 4]>> = qs
            .iter()
            .map(|q| {
                let p = forward_kinematics(chain, &mut data, q).unwrap();
                ids.iter()
                    .map(|&l| p.world_from_link(l).to_rows())
                    .collect()
            })
            .collect();
        force_isa(None);
        let last = ids[ids.len() - 1];
        let call = Box::new(move || {
            force_isa(level);
            for q in qs {
                let p = forward_kinematics(chain, &mut data, black_box(q)).unwrap();
                black_box(p.world_from_link(last));
            }
            force_isa(None);
        });
        methods.push(Method {
            label,
            poses,
            call,
            repeat: 1,
            single_precision: false,
        });
    }

    // kinechain, batches of 22 × 16 configurations, in f64 and in the single-precision variant
    // (looser, chosen explicitly).
    let flat: Vec<f64> = (0..16).flat_map(|_| qs.concat()).collect();
    let ids = &ids;
    let mut batch = BatchData::new(chain).with_limit_policy(LimitPolicy::Ignore);
    methods.push(batch_method(
        "kinechain batch, 1 thread",
        false,
        flat.clone(),
        move |flat, keep| {
            let p = forward_kinematics_batch(chain, &mut batch, flat).unwrap();
            batch_poses(keep.then_some(qs.len()), ids, |i, l| {
                p.world_from_link(i, l)
            })
        },
    ));
    let mut batch32 =
        single_precision::BatchData::new(chain).with_limit_policy(LimitPolicy::Ignore);
    methods.push(batch_method(
        "kinechain batch f32, 1 thread",
        true,
        flat,
        move |flat, keep| {
            let p = single_precision::forward_kinematics_batch(chain, &mut batch32, flat).unwrap();
            batch_poses(keep.then_some(qs.len()), ids, |i, l| {
                p.world_from_link(i, l)
            })
        },
    ));

    methods.extend(k_method(path, &reference, chain, qs, &names, &robot));
    methods.extend(naive_method(&reference, qs, &names));

    let n = qs.len();
    let items: Vec<usize> = methods.iter().map(|m| m.repeat * n).collect();
    let mut calls: Vec<&mut dyn FnMut()> = methods.iter_mut().map(|m| &mut *m.call as _).collect();
    let timings = Interleaved::run(Duration::from_millis(100), 7, &mut calls).per_item(&items);
    let k = methods.iter().position(|m| m.label.starts_with("k 0.32"));
    let naive = methods
        .iter()
        .position(|m| m.label == "naive nalgebra Matrix4");
    methods
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let (position, rotation) = errors(&exact, &names, &m.poses);
            Row {
                method: m.label.to_string(),
                robot: robot.clone(),
                ns: timings.median(i),
                vs_k: k.map(|k| timings.ratio(k, i)),
                vs_naive: naive.map(|naive| timings.ratio(naive, i)),
                position,
                reach,
                rotation,
                single_precision: m.single_precision,
            }
        })
        .collect()
}

/// The k crate's method for the robot of `reference` (`path` its file, `robot` its label in the
/// table), timed on `qs` and read at the links `names`.
fn k_method<'a>(
    path: &Path,
    reference: &serde_json::Value,
    chain: &kinechain::Chain,
    qs: &'a [Vec<f64>],
    names: &[String],
    robot: &str,
) -> Option<Method<'a>> {
    // The k crate: on the URDF models, and on the others as `kinechain convert` writes them (the
    // links keep their names and the joint vector its order; a cylindrical joint becomes two
    // joints, so k's joint names are looked up in the written model). Not for a model URDF
    // cannot express (a prismatic joint without limits).
    let text = (reference["model"]["kind"] != "urdf")
        .then(|| kinechain::io::convert::to_urdf(chain).ok())
        .flatten();
    let written = text.map(|text| {
        let file = std::env::temp_dir().join(format!(
            "kinechain-table-{}-{}.urdf",
            std::process::id(),
            robot.replace('/', "-")
        ));
        std::fs::write(&file, &text).unwrap();
        (file, kinechain::Chain::from_urdf_str(&text).unwrap())
    });
    let urdf = match &written {
        Some((file, named)) => Some((file.clone(), named)),
        None => (reference["model"]["kind"] == "urdf").then(|| {
            let file = path.with_file_name(reference["model"]["file"].as_str().unwrap());
            (file, chain)
        }),
    };
    let (file, named) = urdf?;
    let robot = k::Chain::<f64>::from_urdf_file(&file).unwrap();
    if written.is_some() {
        let _ = std::fs::remove_file(&file);
    }
    let joint_names: Vec<String> = robot.iter_joints().map(|j| j.name.clone()).collect();
    let kq: Vec<Vec<f64>> = qs
        .iter()
        .map(|q| {
            named
                .positions_by_name(joint_names.iter().map(String::as_str), q)
                .unwrap()
        })
        .collect();
    let poses: Vec<Vec<[[f64; 4]; 4]>> = kq
        .iter()
        .map(|q| {
            robot.set_joint_positions_unchecked(q);
            robot.update_transforms();
            names
                .iter()
                .map(|name| {
                    let m = robot
                        .find_link(name)
                        .unwrap()
                        .world_transform()
                        .unwrap()
                        .to_homogeneous();
                    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
                })
                .collect()
        })
        .collect();
    Some(Method {
        label: if written.is_some() {
            "k 0.32, written as URDF"
        } else {
            "k 0.32"
        },
        poses,
        call: Box::new(move || {
            for q in &kq {
                robot.set_joint_positions_unchecked(black_box(q));
                black_box(robot.update_transforms());
            }
        }),
        repeat: 1,
        single_precision: false,
    })
}

/// The naive product of 4×4 matrices for a DH model (`None` for the others), timed on `qs` and
/// read at the links `names`.
fn naive_method<'a>(
    reference: &serde_json::Value,
    qs: &'a [Vec<f64>],
    names: &[String],
) -> Option<Method<'a>> {
    // The textbook method for DH models: products of 4×4 nalgebra matrices (eq. 2.129 or the
    // standard form), sin/cos from the standard library.
    let product = DhProduct::of(reference)?;
    let index: Vec<usize> = names.iter().map(|name| product.index(name)).collect();
    let mut out = Vec::new();
    let poses: Vec<Vec<[[f64; 4]; 4]>> = qs
        .iter()
        .map(|q| {
            product.poses(q, &mut out);
            index
                .iter()
                .map(|&i| std::array::from_fn(|r| std::array::from_fn(|c| out[i][(r, c)])))
                .collect()
        })
        .collect();
    Some(Method {
        label: "naive nalgebra Matrix4",
        poses,
        call: Box::new(move || {
            for q in qs {
                product.poses(black_box(q), &mut out);
                black_box(&out);
            }
        }),
        repeat: 1,
        single_precision: false,
    })
}

/// The position error in ulps of the reach (`f64` ulps, so that every row of the column is in one
/// unit), followed for a single-precision row by the same error in its own ulps.
fn reach_ulps(r: &Row) -> String {
    let ulps = r.position_ulps(f64::EPSILON);
    if r.single_precision {
        let own = r.position_ulps(f64::from(f32::EPSILON));
        format!("{ulps:.2e} ({own:.2} f32 ulp)")
    } else {
        format!("{ulps:.2}")
    }
}

/// A speed-up for the table, "–" where there is none.
fn times(x: Option<f64>) -> String {
    x.map_or("–".to_string(), |x| format!("{x:.1}"))
}

fn plot(rows: &[Row], path: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let ulps = |r: &Row| {
        r.position_ulps(f64::EPSILON)
            .max(r.rotation / f64::EPSILON)
            .max(0.1)
    };
    let (x_min, x_max, y_max) = rows
        .iter()
        .fold((f64::INFINITY, 1.0_f64, 1.0_f64), |(lo, x, y), r| {
            (lo.min(r.ns), x.max(r.ns), y.max(ulps(r)))
        });
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Time per configuration against error (all link poses)",
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(
            (x_min.min(5.0) / 1.5..x_max * 2.0).log_scale(),
            (0.1..y_max * 4.0).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc("ns per configuration (log)")
        .y_desc("max error, ulp of reach or of 1 (log)")
        .draw()?;
    let mut methods: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
    methods.dedup();
    methods.sort();
    methods.dedup();
    for (i, method) in methods.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let points: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.method == *method)
            .map(|r| (r.ns, ulps(r)))
            .collect();
        chart
            .draw_series(points.iter().map(|&p| Circle::new(p, 5, color.filled())))?
            .label(*method)
            .legend(move |(x, y)| Circle::new((x, y), 5, color.filled()));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

fn main() {
    // `cargo bench` passes `--bench`; nothing to parse.
    let mut rows = Vec::new();
    for path in reference_files() {
        rows.extend(rows_for(&path));
    }
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |name: &str| {
        cpuinfo
            .lines()
            .find(|l| l.split(':').next().map(str::trim) == Some(name))
            .and_then(|l| l.split(':').nth(1))
            .map(|v| v.trim().to_string())
    };
    let cpu = match (field("model name"), field("cpu family"), field("model")) {
        (Some(name), Some(family), Some(model)) => {
            format!("{name} (CPU family {family}, model {model})")
        }
        (Some(name), ..) => name,
        _ => "unknown CPU".into(),
    };
    let mut table = format!(
        "Machine: {cpu}, {} threads, kernels: {}.\n\n| method | robot | ns/config | × k | × naive | max position error (m) | (ulp of reach) | max rotation error |\n|---|---|---:|---:|---:|---:|---:|---:|\n",
        std::thread::available_parallelism().map_or(1, |n| n.get()),
        isa().name()
    );
    for r in &rows {
        writeln!(
            table,
            "| {} | {} | {:.1} | {} | {} | {:.1e} | {} | {:.1e} |",
            r.method,
            r.robot,
            r.ns,
            times(r.vs_k),
            times(r.vs_naive),
            r.position,
            reach_ulps(r),
            r.rotation
        )
        .unwrap();
    }
    print!("{table}");
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/bench");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("table.md"), &table).unwrap();
    plot(&rows, &dir.join("time_vs_error.svg")).unwrap();
    println!(
        "\nwrote {} and {}",
        dir.join("table.md").display(),
        dir.join("time_vs_error.svg").display()
    );
}

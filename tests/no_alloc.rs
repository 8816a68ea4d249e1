//! Evaluations on a reused `Data` allocate nothing, loading an alias or merge bomb allocates in
//! proportion to the file's size, and a loaded chain holds memory in proportion to its joints
//! (counted by a per-thread counting allocator, so tests running in parallel do not disturb each
//! other).

use kinechain::{
    Chain, Data, LoadError, forward_accelerations, forward_kinematics,
    forward_kinematics_incremental, forward_kinematics_to, forward_velocities,
};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
    /// Bytes allocated minus bytes freed on this thread (wrapping, since a block may be freed
    /// by another thread than the one that allocated it).
    static LIVE: Cell<usize> = const { Cell::new(0) };
    /// The most `LIVE` has been since [`footprint`] last reset it.
    static PEAK: Cell<usize> = const { Cell::new(0) };
}

/// Records a change of `grown` bytes allocated and `shrunk` bytes freed.
fn account(grown: usize, shrunk: usize) {
    let _ = LIVE.try_with(|live| {
        let now = live.get().wrapping_add(grown).wrapping_sub(shrunk);
        live.set(now);
        let _ = PEAK.try_with(|peak| peak.set(peak.get().max(now)));
    });
}

// SAFETY: forwards to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        account(layout.size(), 0);
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        account(0, layout.size());
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        account(new_size, layout.size());
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations() -> usize {
    ALLOCATIONS.with(|c| c.get())
}

/// What `f` returns, the bytes it still holds when it returns, and the most it held meanwhile.
fn footprint<T>(f: impl FnOnce() -> T) -> (T, usize, usize) {
    let before = LIVE.with(Cell::get);
    PEAK.with(|peak| peak.set(before));
    let value = f();
    let held = LIVE.with(Cell::get).wrapping_sub(before);
    let peak = PEAK.with(Cell::get) - before;
    (value, held, peak)
}

#[test]
fn evaluations_allocate_nothing() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    for file in [
        "robots/panda.urdf",
        "robots/cylindrical.yaml",
        "tests/data/reference/urdf/tiago_no_hand.urdf",
    ] {
        let chain = Chain::from_file(root.join(file)).unwrap();
        let mut data = Data::new(&chain);
        // Mid-range values, so that the limit checks run (and pass).
        let mut q = vec![0.0; chain.dof()];
        for j in chain.joints() {
            if let Some(first) = j.q_index() {
                for (k, l) in j.limits().iter().enumerate() {
                    q[first + k] = l.map_or(0.0, |l| 0.5 * (l.lower + l.upper));
                }
            }
        }
        let qd = vec![0.1; chain.dof()];
        let tip = chain.end_link();
        // A Jacobian (and its rate) written into a matrix of the right shape, as a control loop
        // reuses one.
        let mut jacobian = kinechain::nalgebra::Matrix6xX::zeros(chain.dof());
        let before = allocations();
        for k in 0..100 {
            let mut q = q.clone();
            let after_clone = allocations();
            q[0] += 1e-3 * k as f64;
            let p = forward_kinematics(&chain, &mut data, &q).unwrap();
            std::hint::black_box(p.world_from_link(tip));
            p.jacobian_into(tip, &mut jacobian);
            std::hint::black_box(&jacobian);
            let p = forward_kinematics_incremental(&chain, &mut data, &q).unwrap();
            std::hint::black_box(p.world_from_link(tip));
            std::hint::black_box(forward_kinematics_to(&chain, &mut data, &q, tip).unwrap());
            let v = forward_velocities(&chain, &mut data, &q, &qd).unwrap();
            std::hint::black_box(v.velocity(tip));
            v.jacobian_dot_into(tip, &mut jacobian);
            std::hint::black_box(&jacobian);
            let a = forward_accelerations(&chain, &mut data, &q, &qd, &qd).unwrap();
            std::hint::black_box(a.acceleration(tip));
            assert_eq!(
                allocations(),
                after_clone,
                "{file}: an evaluation allocated"
            );
        }
        assert_eq!(
            allocations() - before,
            100,
            "{file}: only the 100 clones of q allocate"
        );
    }
}

/// Batches of rates and Jacobians into reused buffers and a reused caller's array allocate
/// nothing after the first call (which sizes the buffers), on the calling thread.
#[test]
fn batches_of_rates_and_jacobians_allocate_nothing_on_reuse() {
    use kinechain::JacobianFrame;
    use kinechain::eval::batch::{
        BatchData, forward_accelerations_batch, forward_velocities_batch, jacobian_batch,
        jacobian_dot_batch,
    };
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    for file in ["robots/panda.urdf", "robots/cylindrical.yaml"] {
        let chain = Chain::from_file(root.join(file)).unwrap();
        let n = 100;
        let dof = chain.dof();
        let qs: Vec<f64> = chain
            .neutral()
            .iter()
            .cycle()
            .take(n * dof)
            .copied()
            .collect();
        let qds = vec![0.1; n * dof];
        let mut data = BatchData::new(&chain);
        let mut out = vec![0.0; n * 6 * dof];
        let tip = chain.end_link();
        let run = |data: &mut BatchData, out: &mut [f64]| {
            let v = forward_velocities_batch(&chain, data, &qs, &qds).unwrap();
            std::hint::black_box(v.velocity(n - 1, tip));
            let a = forward_accelerations_batch(&chain, data, &qs, &qds, &qds).unwrap();
            std::hint::black_box(a.acceleration(n - 1, tip));
            for frame in [
                JacobianFrame::World,
                JacobianFrame::Link,
                JacobianFrame::Point([0.1; 3]),
            ] {
                jacobian_batch(&chain, data, &qs, tip, frame, out).unwrap();
                jacobian_dot_batch(&chain, data, &qs, &qds, tip, frame, out).unwrap();
            }
            std::hint::black_box(&out);
        };
        run(&mut data, &mut out);
        let before = allocations();
        for _ in 0..10 {
            run(&mut data, &mut out);
        }
        assert_eq!(allocations(), before, "{file}: a reused batch allocated");
    }
}

/// Files whose aliases replay exponentially more than they hold are refused after a number of
/// allocations in proportion to their size: an alias bomb (ten anchors, each a list of nine
/// aliases to the one before: 9¹⁰ leaves in 555 bytes) and a merge bomb (each joint merging the
/// two before it). At most 64 per byte (measured: 11.5 and 34); under the parser's own limit of
/// a million replayed events they allocated 1 400 and 1 500 times per byte.
#[test]
fn bombs_allocate_in_proportion_to_their_size() {
    for file in ["alias_bomb.yaml", "merge_bomb.yaml"] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/bad/yaml")
            .join(file);
        let bytes = std::fs::metadata(&path).unwrap().len() as usize;
        let before = allocations();
        let loaded = Chain::from_file(&path);
        let allocated = allocations() - before;
        assert!(loaded.is_err(), "{file}");
        println!("{file}: {bytes} bytes, {allocated} allocations");
        assert!(
            allocated <= 64 * bytes,
            "{file} of {bytes} bytes took {allocated} allocations"
        );
    }
}

/// A serial chain of `n` revolute joints, as URDF and as a standard DH table.
fn long_chain(n: usize) -> (String, String) {
    let mut urdf = String::from("<robot name=\"long\">\n  <link name=\"l0\"/>\n");
    let mut dh = String::from("name: long\nconvention: standard\nbase: {name: l0}\njoints:\n");
    for i in 1..=n {
        urdf += &format!(
            "  <link name=\"l{i}\"/>\n  <joint name=\"j{i}\" type=\"revolute\"><parent \
             link=\"l{}\"/><child link=\"l{i}\"/><origin xyz=\"0 0 0.1\" rpy=\"0 0.1 0\"/>\
             <axis xyz=\"0 0 1\"/><limit lower=\"-3\" upper=\"3\" effort=\"1\" \
             velocity=\"1\"/></joint>\n",
            i - 1
        );
        dh += &format!(
            "  - {{name: j{i}, link: l{i}, type: revolute, a: 0.1, alpha: 1.5707963267948966, \
             d: 0.05, theta: 0, limits: [-3, 3]}}\n"
        );
    }
    urdf += "</robot>\n";
    (urdf, dh)
}

/// A loaded chain of 2 000 joints holds at most 4 kB per joint (measured 1.9 kB: the evaluation
/// layout, the description it was built from, names and their indices). Loading it from URDF
/// peaks at most at 64 times the text's size (measured 35; nearly all of it inside urdf-rs, which
/// builds an XML tree of the text and writes it out again before reading it). From DH YAML, the
/// peak is at most 512 bytes per joint above what the chain keeps (measured 360, while the chain
/// is built from its description; 810 when the chain kept a copy of the description, 1 590 when
/// each parsed row also held room for an `origin` frame of 2 kB). Bytes are counted as
/// requested, a reallocation as its new size.
#[test]
fn loading_holds_memory_in_proportion_to_the_joints() {
    let n = 2000;
    let (urdf, dh) = long_chain(n);
    type Loader = fn(&str) -> Result<Chain, LoadError>;
    let loaders: [(&str, &str, Loader); 2] = [
        ("URDF", &urdf, Chain::from_urdf_str),
        ("DH YAML", &dh, Chain::from_dh_yaml_str),
    ];
    for (format, text, load) in loaders {
        let (chain, held, peak) = footprint(|| load(text));
        let chain = chain.unwrap();
        assert_eq!(chain.dof(), n, "{format}");
        let bytes = text.len();
        println!(
            "{format}: {bytes} bytes, {n} joints: holds {:.0} B per joint, peak {:.0} B per \
             joint ({:.1} times the text)",
            held as f64 / n as f64,
            peak as f64 / n as f64,
            peak as f64 / bytes as f64
        );
        assert!(held <= 4096 * n, "{format}: {held} bytes held");
        if format == "URDF" {
            assert!(peak <= 20 * bytes, "{format}: {peak} bytes at the peak");
        } else {
            assert!(
                peak - held <= 512 * n,
                "{format}: {peak} bytes at the peak, {held} held"
            );
        }
        drop(chain);
    }
}

/// URDF files of the shapes that make an XML tree largest for their size (empty elements with
/// white space between them, elements with many empty attributes, deep nesting) are read, or
/// refused for holding more nodes than a robot file of their size could, within 20 times their
/// size at the peak.
#[test]
fn urdf_loading_peaks_within_twenty_times_the_file() {
    let size = 4 << 20;
    let fill = |unit: &str| {
        let head = "<robot name=\"r\"><link name=\"a\"/>";
        let tail = "</robot>";
        let n = (size - head.len() - tail.len()) / unit.len();
        format!("{head}{}{tail}", unit.repeat(n))
    };
    let deep = {
        let n = 50_000;
        format!(
            "<robot name=\"r\"><link name=\"a\"/>{}{}</robot>",
            "<g>".repeat(n),
            "</g>".repeat(n)
        )
    };
    for (shape, text) in [
        ("empty elements and line breaks", fill("<a/>\n")),
        ("empty elements", fill("<a/>")),
        (
            "empty attributes",
            fill("<a b=\"\" c=\"\" d=\"\" e=\"\" f=\"\"/>"),
        ),
        ("comments", fill("<!---->")),
        ("empty elements twelve bytes apart", fill("<a/>        ")),
        (
            "links",
            (0..(size / 24))
                .map(|i| format!("<link name=\"l{i}\"/>"))
                .collect::<String>()
                .replacen("", "<robot name=\"r\">", 1)
                + "</robot>",
        ),
        ("deep nesting", deep),
    ] {
        let (loaded, _, peak) = footprint(|| Chain::from_urdf_str(&text));
        let outcome = match &loaded {
            Ok(chain) => format!("loaded with {} warnings", chain.warnings().len()),
            Err(e) => kinechain::error::error_chain(e),
        };
        println!(
            "{shape}: {} bytes, peak {:.1} times the text: {outcome}",
            text.len(),
            peak as f64 / text.len() as f64
        );
        assert!(
            peak <= 20 * text.len(),
            "{shape}: {peak} bytes at the peak for {} bytes",
            text.len()
        );
    }
}

//! Evaluations on a reused `Data` allocate nothing, and loading an alias or merge bomb allocates
//! in proportion to the file's size (counted by a per-thread counting allocator, so tests running in
//! parallel do not disturb each other).

use kinechain::{
    Chain, Data, forward_accelerations, forward_kinematics, forward_kinematics_incremental,
    forward_kinematics_to, forward_velocities,
};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

// SAFETY: forwards to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations() -> usize {
    ALLOCATIONS.with(|c| c.get())
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

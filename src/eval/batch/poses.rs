//! Many configurations at once: link poses of `n` configurations of one chain, eight per pass
//! through the kernels (one configuration per SIMD lane), on one thread or several.
//!
//! Configurations are given row-major (`qs[i * dof + j]` is joint entry `j` of configuration
//! `i`). Results are the same as [`forward_kinematics`](crate::forward_kinematics) gives for each
//! configuration, to the last bit on the same instruction set.

use crate::eval::batch::blocks::{block_path, chunk_poses};
use crate::eval::batch::data::BLOCK;
use crate::eval::batch::data::{
    BatchData, BatchError, LaneCheck, first_error_on_path, kept_len, streams,
};
use crate::eval::batch::threads::{par_chunks_checked, worth_parallel};
use crate::eval::kernel::frame::Frame;
use crate::eval::layout::body::Placement;
use crate::eval::layout::chain::Chain;
use crate::eval::simd::isa::fma_dispatch;
use crate::eval::simd::lanes::{LANES, Lanes};
use crate::eval::simd::traits::{Arith, Num};
use crate::model::chain::LinkId;
use crate::model::transform::Transform;

batch_len!(BatchPoses, BatchLinkPoses);

/// Link poses of every configuration of a batch.
#[derive(Clone, Copy, Debug)]
pub struct BatchPoses<'a> {
    pub(crate) chain: &'a Chain,
    pub(crate) data: &'a BatchData,
}

impl BatchPoses<'_> {
    /// Pose of `link` in configuration `index`, world frame.
    ///
    /// # Panics
    /// If `index >= self.len()` or `link` comes from another chain.
    #[must_use]
    #[inline]
    pub fn world_from_link(&self, index: usize, link: LinkId) -> Transform {
        lane_pose(self.chain, self.data.len, link, index, |b, offset| {
            let f = &self.data.frames[(index / LANES) * self.data.bodies + b];
            lane_link_pose(f, index % LANES, offset)
        })
    }
}

/// Poses of every link for each configuration of `qs` (row-major, `dof` entries per
/// configuration), on the calling thread.
///
/// When the frames (96 bytes per body and configuration) exceed the processor's last-level
/// cache, they are written around the caches with streaming stores: about a quarter faster for
/// such a batch, which could not have stayed in the cache for the caller to read anyway.
///
/// # Errors
/// [`BatchError`] naming the first configuration that has a non-finite entry or (under
/// [`LimitPolicy::Enforce`](crate::LimitPolicy::Enforce)) a value outside a joint's limits, a `qs` whose length is not a
/// multiple of the chain's dof, or a chain without moving joints
/// ([`StateError::NoDegreesOfFreedom`](crate::StateError::NoDegreesOfFreedom)). No result is returned then (the kernels check the
/// entries as they transpose them, so the batch may have been evaluated, without effect).
///
/// # Panics
/// If `data` was created for another chain.
///
/// # Examples
/// ```
/// use kinechain::{Chain, eval::batch::{BatchData, forward_kinematics_batch}};
/// let chain = Chain::from_file("robots/planar3.yaml")?;
/// let mut data = BatchData::new(&chain);
/// let qs = [0.0, 0.0, 0.0, 1.5707963267948966, 0.0, 0.0]; // two configurations
/// let poses = forward_kinematics_batch(&chain, &mut data, &qs)?;
/// let tip = chain.link_id("link3")?;
/// approx::assert_relative_eq!(poses.world_from_link(1, tip).translation().y, 9.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn forward_kinematics_batch<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
) -> Result<BatchPoses<'a>, BatchError> {
    let check = LaneCheck::of(chain, data.limit_policy);
    let chunks = data.prepare(chain, qs, check.is_none())?;
    let stream = streams(data.size_frames(chunks));
    let bodies = chain.bodies.len().max(1);
    if stream {
        data.kept
            .resize(kept_len(chain), Frame::splat(&Transform::IDENTITY));
    }
    let mut all_ok = true;
    for (c, frames) in data
        .frames
        .chunks_exact_mut(bodies)
        .take(chunks)
        .enumerate()
    {
        all_ok &= chunk_poses(
            chain,
            check,
            frames,
            &mut data.q_lanes[..chain.nq()],
            qs,
            c,
            stream,
            &mut data.kept,
        );
    }
    if stream {
        crate::eval::simd::lanes::fence_streams();
    }
    if !all_ok {
        data.first_error(chain, qs)?;
    }
    Ok(BatchPoses { chain, data })
}

/// As [`forward_kinematics_batch`], with the chunks of eight configurations shared between the
/// calling thread and `n - 1` threads of rayon's pool, `n` being its size
/// (`rayon::current_num_threads()`: the global pool's, set with `RAYON_NUM_THREADS` or
/// `rayon::ThreadPoolBuilder`, or the pool the call is made from). Each thread evaluates an
/// equal, contiguous share of the batch in runs of chunks, then takes the last runs left in
/// the others' shares, so a thread that starts late or is paused does less, and a batch
/// evaluated again into the same `data` is mostly written by the same cores. Results are
/// identical to the single-threaded call. A batch of fewer than [`PARALLEL_WORK`](crate::eval::batch::PARALLEL_WORK) joint
/// evaluations (configurations × moving joints) runs on the calling thread.
///
/// # Errors
/// As [`forward_kinematics_batch`] (the same configuration is named); no result is returned.
///
/// # Panics
/// If `data` was created for another chain.
pub fn forward_kinematics_batch_par<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
) -> Result<BatchPoses<'a>, BatchError> {
    if !worth_parallel(qs, chain.nq(), chain.bodies.len()) {
        return forward_kinematics_batch(chain, data, qs);
    }
    // The first bad configuration is looked for only on failure.
    let chunks = data.prepare(chain, qs, false)?;
    data.size_frames(chunks);
    let bodies = chain.bodies.len().max(1);
    // Ordinary stores, even where one thread streams (see `streams`).
    let all_ok = par_chunks_checked(
        chain,
        (data.limit_policy, LaneCheck::of(chain, data.limit_policy)),
        qs,
        1,
        bodies,
        &mut data.frames[..chunks * chain.bodies.len()],
        bodies,
        || vec![Lanes::splat(0.0); chain.nq()],
        |check, q_lanes, c, frames| {
            chunk_poses(chain, check, frames, q_lanes, qs, c, false, &mut [])
        },
    );
    if !all_ok {
        data.first_error(chain, qs)?;
    }
    Ok(BatchPoses { chain, data })
}

/// The pose of `link` in configuration `index` of `len`: `pose(b, offset)`, the frame of the
/// link's body `b` in that configuration followed by the link's offset.
#[inline]
pub(crate) fn lane_pose(
    chain: &Chain,
    len: usize,
    link: LinkId,
    index: usize,
    pose: impl FnOnce(usize, &Placement) -> Transform,
) -> Transform {
    assert!(index < len, "configuration {index} of {len}");
    let l = chain.carrier(link);
    let Some(b) = l.body else {
        return l.offset.to_transform();
    };
    pose(b, &l.offset)
}

/// `f`'s frame in lane `lane` followed by `offset`, as [`crate::eval::kernel::pose_columns::link_pose`] composes it.
#[inline(always)]
fn lane_link_pose_generic<A: Arith>(
    f: &Frame<Lanes>,
    lane: usize,
    offset: &Placement,
) -> Transform {
    let lane = lane % LANES;
    let column = |c: usize| if c < 3 { &f.r[c] } else { &f.p };
    crate::eval::kernel::pose_columns::link_pose_from_entries::<A>(
        |c, i| column(c)[i].0[lane],
        offset,
    )
}

fma_dispatch!(avx2 fn lane_link_pose(f: &Frame<Lanes>, lane: usize, offset: &Placement) -> Transform => lane_link_pose_generic);

/// One link's pose in every configuration of a batch.
#[derive(Clone, Copy, Debug)]
pub struct BatchLinkPoses<'a> {
    pub(crate) chain: &'a Chain,
    pub(crate) data: &'a BatchData,
    pub(crate) link: LinkId,
}

impl BatchLinkPoses<'_> {
    /// The link's pose in configuration `index`, world frame.
    ///
    /// # Panics
    /// If `index >= self.len()`.
    #[must_use]
    #[inline]
    pub fn world_from_link(&self, index: usize) -> Transform {
        lane_pose(self.chain, self.data.len, self.link, index, |_, offset| {
            lane_link_pose(&self.data.link_frames[index / LANES], index % LANES, offset)
        })
    }
}

/// The pose of one link for each configuration of `qs` (row-major): only the joints between
/// the base and that link are evaluated, and only that link's pose is kept (one frame per
/// configuration written to memory instead of one per joint, which is what bounds a large
/// batch of all poses), on the calling thread ([`forward_kinematics_batch_to_par`] shares the
/// batch with rayon's pool). The poses are the same, bit for bit, as [`forward_kinematics_batch`]
/// gives for the link.
///
/// # Errors
/// As [`forward_kinematics_batch`].
///
/// # Panics
/// If `data` was created for another chain, or `link` comes from another chain with more links.
///
/// # Examples
/// ```
/// use kinechain::{Chain, eval::batch::{BatchData, forward_kinematics_batch_to}};
/// let chain = Chain::from_file("robots/planar3.yaml")?;
/// let mut data = BatchData::new(&chain);
/// let tip = chain.link_id("link3")?;
/// let qs = [0.0, 0.0, 0.0, 1.5707963267948966, 0.0, 0.0];
/// let poses = forward_kinematics_batch_to(&chain, &mut data, &qs, tip)?;
/// approx::assert_relative_eq!(poses.world_from_link(1).translation().y, 9.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn forward_kinematics_batch_to<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
    link: LinkId,
) -> Result<BatchLinkPoses<'a>, BatchError> {
    batch_to(chain, data, qs, link, false)
}

/// As [`forward_kinematics_batch_to`], the batch shared between the calling thread and rayon's
/// pool as [`forward_kinematics_batch_par`] shares one (batches of fewer than
/// [`PARALLEL_WORK`](crate::eval::batch::PARALLEL_WORK) joint evaluations run on the calling thread). The poses are the same, bit
/// for bit.
///
/// # Errors
/// As [`forward_kinematics_batch`].
///
/// # Panics
/// As [`forward_kinematics_batch_to`].
pub fn forward_kinematics_batch_to_par<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
    link: LinkId,
) -> Result<BatchLinkPoses<'a>, BatchError> {
    batch_to(chain, data, qs, link, true)
}

fn batch_to<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
    link: LinkId,
    parallel: bool,
) -> Result<BatchLinkPoses<'a>, BatchError> {
    let body = chain.carrier(link).body;
    chain.body_path(body, &mut data.path);
    // Only what the path reads of `q` is transposed and checked (a robot's link in a scene of
    // many costs what it costs alone).
    chain.path_reads(body, &mut data.reads);
    // Out of `data` while the kernels borrow it (put back below, its room kept).
    let reads = std::mem::take(&mut data.reads);
    let result = path_kernels(chain, data, qs, &reads, parallel);
    data.reads = reads;
    result?;
    Ok(BatchLinkPoses { chain, data, link })
}

/// The kernels of [`batch_to`] on the path in `data.path`, which reads `reads`.
fn path_kernels(
    chain: &Chain,
    data: &mut BatchData,
    qs: &[f64],
    reads: &crate::eval::layout::chain::PathReads,
    parallel: bool,
) -> Result<(), BatchError> {
    let parallel = parallel && worth_parallel(qs, chain.nq(), data.path.len());
    let policy = data.limit_policy;
    let check = LaneCheck::for_path(chain, policy, reads);
    let chunks = data.prepare(chain, qs, !parallel && check.is_none())?;
    let zero = Frame::splat(&Transform::IDENTITY);
    data.link_frames.resize(chunks, zero);
    let path = &data.path;
    let all_ok = if parallel {
        // Groups of fewer chunks than a block when blocks would give a thread fewer than two
        // (a long chain's batch of a few dozen configurations).
        let per_item = (chunks / (2 * rayon::current_num_threads())).clamp(1, BLOCK);
        par_chunks_checked(
            chain,
            (policy, check),
            qs,
            per_item,
            path.len(),
            &mut data.link_frames[..chunks],
            per_item,
            || vec![Lanes::splat(0.0); per_item * chain.nq()],
            |check, q_lanes, c0, out| block_path(chain, check, path, q_lanes, qs, c0, out),
        )
    } else {
        let mut all_ok = true;
        for (b, out) in data.link_frames[..chunks].chunks_mut(BLOCK).enumerate() {
            all_ok &= block_path(chain, check, path, &mut data.q_lanes, qs, b * BLOCK, out);
        }
        all_ok
    };
    if !all_ok {
        match check.and_then(|c| c.entries) {
            Some(_) => first_error_on_path(chain, qs, policy, reads)?,
            None => data.first_error(chain, qs)?,
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::batch::blocks::chunk_poses_generic;
    use crate::eval::checks::LimitPolicy;
    use crate::eval::single::data::Data;
    use crate::eval::single::kinematics::forward_kinematics;

    /// A serial arm, and two chains whose branches read a frame again (the Panda's second finger
    /// hangs from the hand; TIAGo's tree branches too), each with its file and `q` in `n`
    /// configurations (`None`: just past the last-level cache, and not a whole number of chunks)
    /// spread over a few radians (deterministic, every entry different).
    fn chains_and_qs(n: Option<usize>) -> Vec<(&'static str, Chain, Vec<f64>)> {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let files = [
            "robots/ur5.yaml",
            "robots/panda.urdf",
            "tests/data/reference/urdf/tiago_no_hand.urdf",
        ];
        files
            .into_iter()
            .map(|file| {
                let chain = Chain::from_file(root.join(file)).unwrap();
                let frame_bytes = size_of::<Frame<Lanes>>() / LANES;
                let past_cache = || {
                    crate::eval::simd::isa::last_level_cache_bytes()
                        / (frame_bytes * chain.bodies.len())
                        + 13
                };
                let n = n.unwrap_or_else(past_cache);
                let qs = (0..n * chain.nq())
                    .map(|i| ((i as f64) * 0.754_877_666_246_692_7).fract() * 5.0 - 2.5)
                    .collect();
                (file, chain, qs)
            })
            .collect()
    }

    /// The all-links kernel writes the same frames streamed as cached: on baseline x86-64
    /// (four 16-byte streaming stores per line), with the ISA this machine selects (AVX-512
    /// streams whole lines, AVX2 does not stream), and with bodies whose frames are read again by
    /// a branch from the copies kept aside.
    #[test]
    fn streamed_chunks_equal_cached_chunks() {
        for (file, chain, qs) in chains_and_qs(Some(37)) {
            let (bodies, dof) = (chain.bodies.len(), chain.nq());
            let zero = Frame::splat(&Transform::IDENTITY);
            let evaluate = |stream: bool, baseline: bool| {
                let mut frames = vec![zero; 5 * bodies];
                let mut kept = vec![zero; kept_len(&chain)];
                let mut q = vec![Lanes::splat(0.0); dof];
                for (c, out) in frames.chunks_exact_mut(bodies).enumerate() {
                    let ok = if baseline {
                        chunk_poses_generic::<crate::eval::simd::portable::Separate>(
                            &chain, None, out, &mut q, &qs, c, stream, &mut kept,
                        )
                    } else {
                        chunk_poses(&chain, None, out, &mut q, &qs, c, stream, &mut kept)
                    };
                    assert!(ok);
                }
                crate::eval::simd::lanes::fence_streams();
                frames
            };
            for baseline in [true, false] {
                let cached = evaluate(false, baseline);
                assert!(cached.iter().all(|f| *f != zero));
                assert_eq!(
                    evaluate(true, baseline),
                    cached,
                    "{file} baseline {baseline}"
                );
            }
        }
    }

    /// Batches whose frames exceed the last-level cache are written around it on one thread
    /// ([`streams`]); they give, on one thread and on the pool, what single evaluations give, bit
    /// for bit, on the chains of [`chains_and_qs`].
    #[test]
    fn streamed_batches_equal_single_evaluations() {
        for (file, chain, qs) in chains_and_qs(None) {
            let (bodies, dof) = (chain.bodies.len(), chain.nq());
            let n = qs.len() / dof;
            assert!(streams(n.div_ceil(LANES) * bodies), "{file}");
            // Frames that fill the cache exactly are written through it.
            let fill = crate::eval::simd::isa::last_level_cache_bytes() / size_of::<Frame<Lanes>>();
            assert!(!streams(fill) && streams(fill + 1));
            assert!(chain.bodies.iter().any(|b| b.branches) == (file != "robots/ur5.yaml"));
            let mut single = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
            let mut data = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
            let links: Vec<LinkId> = (0..chain.links().len()).map(LinkId).collect();
            for parallel in [false, true] {
                let poses = if parallel {
                    forward_kinematics_batch_par(&chain, &mut data, &qs)
                } else {
                    forward_kinematics_batch(&chain, &mut data, &qs)
                }
                .unwrap();
                assert_eq!(poses.len(), n);
                for (i, q) in qs.chunks_exact(dof).enumerate() {
                    let want = forward_kinematics(&chain, &mut single, q).unwrap();
                    for &l in &links {
                        assert_eq!(
                            poses.world_from_link(i, l),
                            want.world_from_link(l),
                            "{file} configuration {i} link {l:?} parallel {parallel}"
                        );
                    }
                }
            }
        }
    }
}

//! Batches of link poses written out as 4 × 4 homogeneous matrices, row-major, configuration
//! after configuration: the layout of a C-ordered numpy array `(N, L, 4, 4)` or of a file of
//! matrices. Each chunk's link frame is composed on its lanes (the body frame followed by the
//! link's constant offset, for eight configurations at once) and its lanes are then written to
//! their configurations' places, instead of one [`BatchPoses::world_from_link`] per
//! configuration and link. The values are the same bits as `world_from_link(i, link).to_rows()`.

use crate::eval::batch::poses::{BatchLinkPoses, BatchPoses};
use crate::eval::error::StateError;
use crate::eval::kernel::frame::Frame;
use crate::eval::layout::body::Placement;
use crate::eval::layout::chain::Chain;
use crate::eval::simd::isa::fma_dispatch;
use crate::eval::simd::lanes::{LANES, Lanes};
use crate::eval::simd::traits::{Arith, LaneNum};
use crate::model::chain::LinkId;

/// The first `count` lanes of `f` followed by `offset`, each written as the 16 entries of a
/// row-major homogeneous matrix at `out[l * stride..]` for lane `l`.
#[inline(always)]
fn write_lanes<A: Arith>(
    f: &Frame<Lanes>,
    offset: &Placement,
    count: usize,
    out: &mut [f64],
    stride: usize,
) {
    type N<A> = <A as Arith>::Lanes;
    let mut placed = *f;
    for part in 0..N::<A>::PARTS {
        let mut g = Frame::<N<A>>::get(f, part);
        crate::eval::kernel::frame::place::<N<A>, A>(&mut g, offset);
        g.put(&mut placed, part);
    }
    let (r, p) = (&placed.r, &placed.p);
    for l in 0..count {
        let m = &mut out[l * stride..l * stride + 16];
        for i in 0..3 {
            m[4 * i..4 * i + 4].copy_from_slice(&[
                r[0][i].0[l],
                r[1][i].0[l],
                r[2][i].0[l],
                p[i].0[l],
            ]);
        }
        m[12..].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
    }
}

/// The constant pose `rows` (a link fixed to the world) at `out[i * stride..]` for `n`
/// configurations.
fn write_constant(rows: [[f64; 4]; 4], n: usize, out: &mut [f64], stride: usize) {
    for i in 0..n {
        for (r, row) in rows.iter().enumerate() {
            out[i * stride + 4 * r..i * stride + 4 * r + 4].copy_from_slice(row);
        }
    }
}

/// `links`' matrices of `n` configurations into `out` (`n × links.len() × 16`), from the frames
/// `frame(c, body)` of chunk `c`.
#[inline(always)]
fn write_all<'f, A: Arith>(
    chain: &Chain,
    n: usize,
    links: &[LinkId],
    frame: impl Fn(usize, usize) -> &'f Frame<Lanes>,
    out: &mut [f64],
) {
    let stride = 16 * links.len();
    for c in 0..n.div_ceil(LANES) {
        let count = (n - c * LANES).min(LANES);
        let out = &mut out[c * LANES * stride..];
        for (k, &link) in links.iter().enumerate() {
            let carrier = chain.carrier(link);
            let out = &mut out[16 * k..];
            match carrier.body {
                Some(b) => write_lanes::<A>(frame(c, b), &carrier.offset, count, out, stride),
                None => write_constant(carrier.offset.to_transform().to_rows(), count, out, stride),
            }
        }
    }
}

#[inline(always)]
fn write_poses_generic<A: Arith>(poses: &BatchPoses<'_>, links: &[LinkId], out: &mut [f64]) {
    let data = poses.data;
    let frame = |c: usize, b: usize| &data.frames[c * data.bodies + b];
    write_all::<A>(poses.chain, data.len, links, frame, out);
}

#[inline(always)]
fn write_link_generic<A: Arith>(poses: &BatchLinkPoses<'_>, out: &mut [f64]) {
    let data = poses.data;
    let frame = |c: usize, _: usize| &data.link_frames[c];
    write_all::<A>(poses.chain, data.len, &[poses.link], frame, out);
}

fma_dispatch!(fn write_poses(poses: &BatchPoses<'_>, links: &[LinkId], out: &mut [f64]) => write_poses_generic);

fma_dispatch!(fn write_link(poses: &BatchLinkPoses<'_>, out: &mut [f64]) => write_link_generic);

/// [`StateError::OutputLength`] unless `out` has `expected` entries.
fn check_length(out: &[f64], expected: usize) -> Result<(), StateError> {
    if out.len() == expected {
        Ok(())
    } else {
        Err(StateError::OutputLength {
            expected,
            got: out.len(),
        })
    }
}

impl BatchPoses<'_> {
    /// Writes the pose of each of `links` in every configuration as a 4 × 4 homogeneous matrix
    /// (world frame, row-major, last row `0 0 0 1`): configuration `i`'s matrices start at
    /// `16 · links.len() · i`, link `k`'s 16 entries after `16 k` more (a C-ordered
    /// `(N, links.len(), 4, 4)` array). The entries are those of
    /// [`world_from_link(i, link)`](BatchPoses::world_from_link) bit for bit, composed eight
    /// configurations at a time.
    ///
    /// # Errors
    /// [`StateError::OutputLength`] when `out` does not have `16 · links.len() · self.len()`
    /// entries (nothing is written then).
    ///
    /// # Panics
    /// If a link comes from another chain with more links.
    ///
    /// # Examples
    /// ```
    /// use kinechain::{Chain, eval::batch::{BatchData, forward_kinematics_batch}};
    /// let chain = Chain::from_file("robots/planar3.yaml")?;
    /// let mut data = BatchData::new(&chain);
    /// let qs = [0.0, 0.0, 0.0, 1.5707963267948966, 0.0, 0.0]; // two configurations
    /// let poses = forward_kinematics_batch(&chain, &mut data, &qs)?;
    /// let tip = chain.link_id("link3")?;
    /// let mut m = [0.0; 2 * 16];
    /// poses.write_matrices(&[tip], &mut m)?;
    /// approx::assert_relative_eq!(m[16 + 7], 9.0); // configuration 1: row 1, column 3 (y)
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn write_matrices(&self, links: &[LinkId], out: &mut [f64]) -> Result<(), StateError> {
        check_length(out, 16 * links.len() * self.data.len)?;
        write_poses(self, links, out);
        Ok(())
    }
}

impl BatchLinkPoses<'_> {
    /// Writes the link's pose in every configuration as a 4 × 4 homogeneous matrix (world frame,
    /// row-major, last row `0 0 0 1`), configuration `i`'s at `16 i`: a C-ordered `(N, 4, 4)`
    /// array. The entries are those of [`world_from_link(i)`](BatchLinkPoses::world_from_link)
    /// bit for bit.
    ///
    /// # Errors
    /// [`StateError::OutputLength`] when `out` does not have `16 · self.len()` entries.
    pub fn write_matrices(&self, out: &mut [f64]) -> Result<(), StateError> {
        check_length(out, 16 * self.data.len)?;
        write_link(self, out);
        Ok(())
    }
}

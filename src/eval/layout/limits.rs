//! Joint limits as the evaluation checks them: one check per limited entry of `q`
//! ([`LimitCheck`]), and the same checks as dense columns when there is one per entry
//! ([`DenseLimits`]).

use crate::eval::simd::traits::within;
use crate::model::joint::Limits;

/// One entry of `q` and what it drives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LimitCheck {
    pub(crate) joint: usize,
    pub(crate) index: usize,
    pub(crate) component: Option<&'static str>,
    /// Whether the coordinate is an angle (rad) rather than a length (m).
    pub(crate) angular: bool,
    pub(crate) scale: f64,
    pub(crate) offset: f64,
    pub(crate) limits: Limits,
}

impl LimitCheck {
    /// The joint coordinate this check limits when `q[self.index]` is `x`.
    pub(crate) fn value(&self, x: f64) -> f64 {
        self.scale * x + self.offset
    }

    /// Whether `q` (a whole configuration) passes this check (finiteness is checked apart).
    pub(crate) fn admits(&self, q: &[f64]) -> bool {
        self.limits.contains(self.value(q[self.index]))
    }
}

/// The limit checks by entry of `q`, as columns: entry `i` passes when it is finite and
/// `lower[i] ≤ scale[i] · x + offset[i] ≤ upper[i]` (the arithmetic of [`LimitCheck`]), with
/// `(1, 0, −∞, ∞)` for an entry without limits (also the padding to whole blocks of four). A
/// whole configuration is then checked in one branch-free pass, four entries per vector compare
/// (`checks::admitted`).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct DenseLimits {
    /// Block `b` holds the columns `[scale, offset, lower, upper]` of entries `4b..4b + 4`, so
    /// that a vector check reads one contiguous block.
    blocks: Vec<[[f64; 4]; 4]>,
}

impl DenseLimits {
    /// The columns of four entries without limits: any finite value passes.
    pub(crate) const FREE: [[f64; 4]; 4] = [
        [1.0; 4],
        [0.0; 4],
        [f64::NEG_INFINITY; 4],
        [f64::INFINITY; 4],
    ];

    /// The columns for `checks` over `dof` entries. Two checks of one entry with the same scale
    /// and offset (a mimic joint copying its leader) become their intersection; with different
    /// ones the result is `None`.
    pub(crate) fn new(checks: &[LimitCheck], dof: usize) -> Option<DenseLimits> {
        // Padded to whole blocks of four with entries that admit any finite value.
        let mut blocks = vec![Self::FREE; dof.div_ceil(4)];
        let mut seen = vec![false; dof];
        for c in checks {
            let i = c.index;
            let seen_before = *seen.get(i)?;
            let [scale, offset, lower, upper] = &mut blocks[i / 4];
            let k = i % 4;
            if seen_before && (scale[k] != c.scale || offset[k] != c.offset) {
                return None;
            }
            seen[i] = true;
            scale[k] = c.scale;
            offset[k] = c.offset;
            lower[k] = lower[k].max(c.limits.lower);
            upper[k] = upper[k].min(c.limits.upper);
        }
        Some(DenseLimits { blocks })
    }

    /// Whether entry `i` may take the value `x`.
    #[inline(always)]
    pub(crate) fn admits(&self, i: usize, x: f64) -> bool {
        within(x, self.entry(i))
    }

    /// `(scale, offset, lower, upper)` of entry `i`.
    #[inline(always)]
    pub(crate) fn entry(&self, i: usize) -> (f64, f64, f64, f64) {
        let [scale, offset, lower, upper] = &self.blocks[i / 4];
        let k = i % 4;
        (scale[k], offset[k], lower[k], upper[k])
    }

    /// The columns `[scale, offset, lower, upper]` of entries `4b..4b + 4` for each block `b`,
    /// as the rows of a vector check: one block per four entries of `q`, the last one padded.
    #[inline(always)]
    pub(crate) fn blocks(&self) -> &[[[f64; 4]; 4]] {
        &self.blocks
    }
}

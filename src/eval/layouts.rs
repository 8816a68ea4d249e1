//! Joint vectors in the layouts of other libraries, both ways: Pinocchio's (as
//! `buildModelFromUrdf` lays out a model, with `JointModelFreeFlyer` for a floating base) and
//! MuJoCo's (`qpos`, `qvel`, `qacc`).
//!
//! Joint by joint, depth first from the root: a link's children in file order for MuJoCo (as
//! kinechain orders them), by joint name for Pinocchio (whose URDF reader keeps them so):
//!
//! | joint | kinechain `q` / `q̇` | Pinocchio `q` / `v` | MuJoCo `qpos` / `qvel` |
//! |---|---|---|---|
//! | revolute, prismatic | θ or d / rate | the same | the same |
//! | continuous (a rotation without limits) | θ / θ̇ | `cos θ, sin θ` / θ̇ | θ / θ̇ |
//! | mimic | none | its own value `m q + o` / `m q̇` | the same as Pinocchio |
//! | fixed | none | none | none |
//! | floating | `x y z qw qx qy qz` / `v ω` (world) | `x y z qx qy qz qw` / `R̄ᵀ v, R̄ᵀ ω` | `x y z qw qx qy qz` / `v, R̄ᵀ ω` |
//! | ball | `qw qx qy qz` / `ω` (world) | `qx qy qz qw` / `R̄ᵀ ω` | `qw qx qy qz` / `R̄ᵀ ω` |
//!
//! `R̄` is the rotation in the world of the joint's frame after its motion. A floating or ball
//! joint below another joint has its rates relative to its parent link, in world axes (the
//! parent's own motion excluded), so that `R̄ᵀ` gives Pinocchio's free-flyer and spherical
//! joint velocities, which are relative to the parent in the joint's frame; MuJoCo puts free
//! joints only on bodies whose parent is the world. Pinocchio's joint velocity and acceleration
//! of a free-flyer are the body-frame twist and its time derivative: with `u = R̄ᵀ w` for a world
//! vector `w`, `u̇ = R̄ᵀ (ẇ − ω × w)` (eq. 2.29, `R̄ᵀ dR̄/dt = [ω̄]×`), so its acceleration is
//! `R̄ᵀ (q̈_v − ω × q̇_v)` and `R̄ᵀ q̈_ω`; MuJoCo's free joint keeps the world linear velocity and
//! acceleration and gives the angular ones in the body frame (`R̄ᵀ α` as `ω × ω = 0`). A mimic
//! joint's entry read from another layout is not used: its value follows its primary's.

use crate::eval::checks::check_values;
use crate::eval::error::StateError;
use crate::eval::layout::chain::Chain;
use crate::model::chain::Joint;
use crate::model::joint::JointKind;
use crate::model::transform::{Transform, cross3, sub3};

/// The joint-space layout of another library.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Layout {
    /// Pinocchio's, for a model built by `buildModelFromUrdf` (a floating base as
    /// `JointModelFreeFlyer`, continuous joints as `cos, sin`, mimic joints as joints of their own).
    Pinocchio,
    /// MuJoCo's `qpos`, `qvel`, `qacc` (a floating base as a free joint).
    Mujoco,
}

impl Layout {
    /// `pinocchio` or `mujoco`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Layout::Pinocchio => "pinocchio",
            Layout::Mujoco => "mujoco",
        }
    }
}

/// A configuration and, where given, its rates.
#[derive(Clone, Debug, PartialEq)]
pub struct JointState {
    /// Joint positions.
    pub q: Vec<f64>,
    /// Joint velocities.
    pub q_dot: Option<Vec<f64>>,
    /// Joint accelerations.
    pub q_ddot: Option<Vec<f64>>,
}

/// How one joint's coordinates appear in another layout.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Entry {
    /// One coordinate, the same in both (`index` into kinechain's `q` and `q̇`, scaled and offset
    /// for a mimic joint, which the other layout lists and kinechain does not).
    Same {
        q: usize,
        v: usize,
        scale: f64,
        offset: f64,
        mimic: bool,
    },
    /// A rotation without limits as Pinocchio writes it: `cos θ, sin θ`, one rate.
    CosSin {
        q: usize,
        v: usize,
        scale: f64,
        offset: f64,
        mimic: bool,
    },
    /// A floating joint: its position and quaternion from `q`, its rates from `v`, `body` its
    /// body.
    Free { q: usize, v: usize, body: usize },
    /// A ball joint: its quaternion from `q`, its rates from `v`, `body` its body.
    Ball { q: usize, v: usize, body: usize },
}

impl Entry {
    /// Its entries of `q` and of `q̇`.
    fn sizes(self) -> (usize, usize) {
        match self {
            Entry::Same { .. } => (1, 1),
            Entry::CosSin { .. } => (2, 1),
            Entry::Free { .. } => (7, 6),
            Entry::Ball { .. } => (4, 3),
        }
    }
}

/// The chain's joints in `layout`'s order: depth first from the root, a link's children in file
/// order (MuJoCo, as kinechain orders them) or by joint name (Pinocchio, whose URDF reader
/// keeps a link's child joints in a map by name).
fn joint_order(chain: &Chain, layout: Layout) -> Vec<&Joint> {
    let joints = chain.joints();
    if layout == Layout::Mujoco {
        return joints.iter().collect();
    }
    let mut children: Vec<Vec<&Joint>> = vec![Vec::new(); chain.links().len()];
    for j in joints {
        children[j.parent().index()].push(j);
    }
    for c in &mut children {
        c.sort_by(|a, b| a.name().cmp(b.name()));
    }
    let mut order = Vec::with_capacity(joints.len());
    // Depth first (iteratively: chains may be long); the root is link 0.
    let mut stack: Vec<&Joint> = children[0].iter().rev().copied().collect();
    while let Some(j) = stack.pop() {
        order.push(j);
        stack.extend(children[j.child().index()].iter().rev().copied());
    }
    order
}

/// Each moving joint's entries in `layout`, in order.
fn entries(chain: &Chain, layout: Layout) -> Vec<Entry> {
    let mut out = Vec::new();
    for joint in joint_order(chain, layout) {
        let source = chain
            .joint_id(joint.name())
            .ok()
            .and_then(|id| chain.coordinate_source(id));
        let Some((q, scale, offset)) = source else {
            continue;
        };
        let mimic = joint.q_index().is_none();
        // The entry of `q̇`: the joint's own, or its primary's.
        let Some(v) = joint.v_index().or_else(|| {
            let primary = joint.mimic()?.primary;
            chain.joints()[primary.index()].v_index()
        }) else {
            continue;
        };
        match joint.kind() {
            JointKind::Floating | JointKind::Ball => {
                let body = chain
                    .bodies
                    .iter()
                    .position(|b| b.ball.is_some_and(|b| b.q == q) || (b.floating && q == 0));
                match (body, joint.kind()) {
                    (Some(body), JointKind::Floating) => out.push(Entry::Free { q, v, body }),
                    (Some(body), _) => out.push(Entry::Ball { q, v, body }),
                    (None, _) => {}
                }
            }
            JointKind::Fixed => {}
            JointKind::Cylindrical => {
                out.push(rotation(layout, joint, 0, q, v, scale, offset, mimic));
                out.push(Entry::Same {
                    q: q + 1,
                    v: v + 1,
                    scale,
                    offset,
                    mimic,
                });
            }
            JointKind::Revolute | JointKind::Continuous => {
                out.push(rotation(layout, joint, 0, q, v, scale, offset, mimic));
            }
            JointKind::Prismatic => out.push(Entry::Same {
                q,
                v,
                scale,
                offset,
                mimic,
            }),
        }
    }
    out
}

/// A rotation coordinate (`component` of `joint`): continuous in Pinocchio when it has no limits.
#[allow(clippy::too_many_arguments)]
fn rotation(
    layout: Layout,
    joint: &Joint,
    component: usize,
    q: usize,
    v: usize,
    scale: f64,
    offset: f64,
    mimic: bool,
) -> Entry {
    let unlimited = joint.limits().get(component).is_none_or(Option::is_none);
    match (layout, unlimited) {
        (Layout::Pinocchio, true) => Entry::CosSin {
            q,
            v,
            scale,
            offset,
            mimic,
        },
        _ => Entry::Same {
            q,
            v,
            scale,
            offset,
            mimic,
        },
    }
}

/// The rotation in the world of each ball or floating joint's frame at kinechain's `q`, after
/// its motion and before the body's `post` placement (`A_k A_postᵀ`, `A_k` the body's rotation;
/// the floating base's whole rotation, as its rates are those of its body): the axes of the
/// body-frame rates of Pinocchio's spherical joint and free-flyer and MuJoCo's ball and free
/// joints. By body index; the identity for other bodies.
fn ball_rotations(chain: &Chain, q: &[f64]) -> Vec<Transform> {
    use crate::eval::kernel::frame::Frame;
    use crate::eval::kernel::pose_lanes::pose_step;
    use crate::eval::simd::portable::Separate;
    let mut frames: Vec<Frame<f64>> = Vec::with_capacity(chain.bodies.len());
    for body in &chain.bodies {
        let sin_cos = crate::eval::kernel::joint::body_sin_cos::<f64, Separate>(body, q);
        let f = match body.parent {
            Some(p) => pose_step::<f64, Separate>(Some(&frames[p]), body, q, sin_cos),
            None if body.floating => Frame::splat(&crate::eval::kernel::floating::frame(body, q)),
            None => pose_step::<f64, Separate>(None, body, q, sin_cos),
        };
        frames.push(f);
    }
    chain
        .bodies
        .iter()
        .zip(frames)
        .map(|(body, f)| match (body.floating, body.ball) {
            (true, _) => Transform {
                p: [0.0; 3],
                ..Transform::from(f)
            },
            (false, Some(_)) => {
                let frame = Transform::from(f) * body.post.to_transform().inverse();
                Transform {
                    p: [0.0; 3],
                    ..frame
                }
            }
            (false, None) => Transform::IDENTITY,
        })
        .collect()
}

/// `R̄ᵀ w`.
fn to_body(r: &Transform, w: [f64; 3]) -> [f64; 3] {
    let c = &r.r;
    [0, 1, 2].map(|i| c[i][0] * w[0] + c[i][1] * w[1] + c[i][2] * w[2])
}

fn three(x: &[f64]) -> [f64; 3] {
    [x[0], x[1], x[2]]
}

impl Chain {
    /// The number of entries of `q` and of `q̇` in `layout` (`(nq, nv)`).
    #[must_use]
    pub fn layout_sizes(&self, layout: Layout) -> (usize, usize) {
        entries(self, layout)
            .into_iter()
            .map(Entry::sizes)
            .fold((0, 0), |(a, b), (c, d)| (a + c, b + d))
    }

    /// `state` (kinechain's `q` and, where given, `q̇` and `q̈`) in `layout`.
    ///
    /// # Errors
    /// [`StateError`] for a vector of the wrong length or with a non-finite entry, or a floating
    /// joint's quaternion off unit length.
    ///
    /// # Examples
    /// ```
    /// use kinechain::{Chain, eval::layouts::Layout, io::LoadOptions};
    /// let chain = Chain::from_file_with("robots/ur5.yaml", &LoadOptions::default().with_floating_base(true))?;
    /// let mut q = chain.neutral();
    /// q[3..7].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]); // half a turn about z: w x y z
    /// let pin = chain.to_layout(kinechain::eval::layouts::Layout::Pinocchio, &q, None, None)?;
    /// assert_eq!(pin.q[3..7], [0.0, 0.0, 1.0, 0.0]); // x y z w
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn to_layout(
        &self,
        layout: Layout,
        q: &[f64],
        q_dot: Option<&[f64]>,
        q_ddot: Option<&[f64]>,
    ) -> Result<JointState, StateError> {
        check_values(self, q, "q")?;
        for (what, x) in [("q_dot", q_dot), ("q_ddot", q_ddot)] {
            if let Some(x) = x {
                check_values(self, x, what)?;
            }
        }
        let (nq, nv) = self.layout_sizes(layout);
        let mut out = JointState {
            q: Vec::with_capacity(nq),
            q_dot: q_dot.map(|_| Vec::with_capacity(nv)),
            q_ddot: q_ddot.map(|_| Vec::with_capacity(nv)),
        };
        let entries = entries(self, layout);
        let balls = match entries
            .iter()
            .any(|e| matches!(e, Entry::Ball { .. } | Entry::Free { .. }))
        {
            true => ball_rotations(self, q),
            false => Vec::new(),
        };
        for e in entries {
            match e {
                Entry::Ball { q: i, v, body } => {
                    let e = &q[i..i + 4];
                    match layout {
                        Layout::Pinocchio => out.q.extend([e[1], e[2], e[3], e[0]]),
                        Layout::Mujoco => out.q.extend_from_slice(e),
                    }
                    for (o, x) in [(&mut out.q_dot, q_dot), (&mut out.q_ddot, q_ddot)] {
                        if let (Some(o), Some(x)) = (o.as_mut(), x) {
                            o.extend(to_body(&balls[body], three(&x[v..])));
                        }
                    }
                }
                Entry::Same {
                    q: i,
                    v,
                    scale,
                    offset,
                    ..
                } => {
                    out.q.push(scale * q[i] + offset);
                    push_rate(&mut out.q_dot, q_dot, v, scale);
                    push_rate(&mut out.q_ddot, q_ddot, v, scale);
                }
                Entry::CosSin {
                    q: i,
                    v,
                    scale,
                    offset,
                    ..
                } => {
                    let (s, c) = (scale * q[i] + offset).sin_cos();
                    out.q.extend([c, s]);
                    push_rate(&mut out.q_dot, q_dot, v, scale);
                    push_rate(&mut out.q_ddot, q_ddot, v, scale);
                }
                Entry::Free {
                    q: i,
                    v: at_v,
                    body,
                } => {
                    let r = &balls[body];
                    out.q.extend_from_slice(&q[i..i + 3]);
                    let e = &q[i + 3..i + 7];
                    match layout {
                        Layout::Pinocchio => out.q.extend([e[1], e[2], e[3], e[0]]),
                        Layout::Mujoco => out.q.extend_from_slice(e),
                    }
                    let (Some(qd), Some(out_qd)) = (q_dot, out.q_dot.as_mut()) else {
                        continue;
                    };
                    let (v, w) = (three(&qd[at_v..]), three(&qd[at_v + 3..]));
                    let linear = match layout {
                        Layout::Pinocchio => to_body(r, v),
                        Layout::Mujoco => v,
                    };
                    out_qd.extend(linear);
                    out_qd.extend(to_body(r, w));
                    if let (Some(qdd), Some(out_qdd)) = (q_ddot, out.q_ddot.as_mut()) {
                        let at = &qdd[at_v..];
                        let (a, alpha) = (three(at), three(&at[3..]));
                        let linear = match layout {
                            Layout::Pinocchio => to_body(r, sub3(a, cross3(w, v))),
                            Layout::Mujoco => a,
                        };
                        out_qdd.extend(linear);
                        out_qdd.extend(to_body(r, alpha));
                    }
                }
            }
        }
        Ok(out)
    }

    /// The kinechain state of `state` given in `layout` (the inverse of [`Chain::to_layout`]).
    ///
    /// # Errors
    /// [`StateError::LayoutLength`] for a vector of the wrong length, and what
    /// [`Chain::to_layout`] refuses of the result.
    pub fn from_layout(
        &self,
        layout: Layout,
        q: &[f64],
        q_dot: Option<&[f64]>,
        q_ddot: Option<&[f64]>,
    ) -> Result<JointState, StateError> {
        let (nq, nv) = self.layout_sizes(layout);
        for (what, x, n) in [
            ("q", Some(q), nq),
            ("q_dot", q_dot, nv),
            ("q_ddot", q_ddot, nv),
        ] {
            if let Some(x) = x
                && x.len() != n
            {
                return Err(StateError::LayoutLength {
                    layout: layout.name(),
                    what,
                    expected: n,
                    got: x.len(),
                });
            }
        }
        let mut out = JointState {
            q: vec![0.0; self.nq()],
            q_dot: q_dot.map(|_| vec![0.0; self.nv()]),
            q_ddot: q_ddot.map(|_| vec![0.0; self.nv()]),
        };
        let (mut at_q, mut at_v) = (0, 0);
        // (entry of the layout's rates, kinechain's, body) of each ball joint and of each
        // floating one.
        let (mut balls, mut frees) = (Vec::new(), Vec::new());
        let quaternion = |e: &[f64]| match layout {
            Layout::Pinocchio => [e[3], e[0], e[1], e[2]],
            Layout::Mujoco => [e[0], e[1], e[2], e[3]],
        };
        for e in entries(self, layout) {
            let (dq, dv) = e.sizes();
            match e {
                Entry::Same { q: i, v, mimic, .. } | Entry::CosSin { q: i, v, mimic, .. }
                    if !mimic =>
                {
                    out.q[i] = match e {
                        Entry::CosSin { .. } => q[at_q + 1].atan2(q[at_q]),
                        _ => q[at_q],
                    };
                    for (o, x) in [(&mut out.q_dot, q_dot), (&mut out.q_ddot, q_ddot)] {
                        if let (Some(o), Some(x)) = (o.as_mut(), x) {
                            o[v] = x[at_v];
                        }
                    }
                }
                Entry::Ball { q: i, v, body } => {
                    out.q[i..i + 4].copy_from_slice(&quaternion(&q[at_q..at_q + 4]));
                    balls.push((at_v, v, body));
                }
                Entry::Free { q: i, v, body } => {
                    out.q[i..i + 3].copy_from_slice(&q[at_q..at_q + 3]);
                    out.q[i + 3..i + 7].copy_from_slice(&quaternion(&q[at_q + 3..at_q + 7]));
                    frees.push((at_v, v, body));
                }
                _ => {}
            }
            at_q += dq;
            at_v += dv;
        }
        check_values(self, &out.q, "q")?;
        if (balls.is_empty() && frees.is_empty()) || q_dot.is_none() && q_ddot.is_none() {
            return Ok(out);
        }
        let rotations = ball_rotations(self, &out.q);
        for (at, v, body) in balls {
            for (o, x) in [(&mut out.q_dot, q_dot), (&mut out.q_ddot, q_ddot)] {
                if let (Some(o), Some(x)) = (o.as_mut(), x) {
                    o[v..v + 3].copy_from_slice(&rotations[body].apply(three(&x[at..])));
                }
            }
        }
        for (at, i, body) in frees {
            let Some(qd) = q_dot else { break };
            let to_world = |u: [f64; 3]| rotations[body].apply(u);
            let (v, w) = (three(&qd[at..]), to_world(three(&qd[at + 3..])));
            let v = match layout {
                Layout::Pinocchio => to_world(v),
                Layout::Mujoco => v,
            };
            if let Some(o) = out.q_dot.as_mut() {
                o[i..i + 3].copy_from_slice(&v);
                o[i + 3..i + 6].copy_from_slice(&w);
            }
            if let (Some(qdd), Some(o)) = (q_ddot, out.q_ddot.as_mut()) {
                let (a, alpha) = (three(&qdd[at..]), to_world(three(&qdd[at + 3..])));
                let a = match layout {
                    Layout::Pinocchio => crate::model::transform::add3(to_world(a), cross3(w, v)),
                    Layout::Mujoco => a,
                };
                o[i..i + 3].copy_from_slice(&a);
                o[i + 3..i + 6].copy_from_slice(&alpha);
            }
        }
        Ok(out)
    }
}

fn push_rate(out: &mut Option<Vec<f64>>, rates: Option<&[f64]>, v: usize, scale: f64) {
    if let (Some(out), Some(rates)) = (out.as_mut(), rates) {
        out.push(scale * rates[v]);
    }
}

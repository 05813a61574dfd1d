//! The ray-tracing acceleration structure: a BVH with uncompressed single-precision boxes and
//! triangles tested a pack at a time, traversed one ray at a time with every node and leaf test
//! in SIMD: eight-wide nodes and packs in AVX2 where the CPU has it, else four-wide in glam's
//! `Vec4` (SSE on x86-64, NEON on AArch64), chosen at run time ([`Bvh::build`]). This is the
//! layout of Embree's BVH4/BVH8 with `Triangle4`/`Triangle8`-style leaves (Wald et al. 2014,
//! "Embree: A Kernel Framework for Efficient CPU Ray Tracing", §4), built by collapsing obvhs'
//! binary PLOC BVH (Meister & Bittner 2018, with reinsertion optimisation) instead of its
//! compressed eight-wide CWBVH: the CWBVH's quantised child boxes (Ylitie et al. 2017) are made
//! for GPUs, and decoding them costs more on the CPU than their smaller footprint saves.
//! Measured against the CWBVH (whole processes, 256², 8 spp, medians of paired runs), the
//! four-wide tree took 0.76× the CPU time on Lost Empire, 0.85× on the holodeck, 0.88× on the
//! Mori knob, 1.00× on the Cornell box; on a 1M-triangle heightfield, load and build in 0.92×
//! the time and 470 MiB peak instead of 570. The eight-wide AVX2 tree with leaves of up to 16
//! triangles against that four-wide one with leaves of 4 (one thread, medians of paired whole
//! processes, 256²): 0.93–0.95× the CPU time on the Cornell box (0.91× the instructions),
//! 0.99× on Lost Empire, 0.93× on the Mori knob, 1.02× on the holodeck (within this machine's
//! noise of ±5 %); the Cornell box renders bit-identically.
//!
//! Each inner node holds the boxes of up to N children as structure-of-arrays rows
//! (`lo[axis]`, `hi[axis]`, one lane per child). A leaf is up to [`LEAF_PACKS_MAX`] packs of N
//! triangles, each pack the rows of Baldwin & Weber's precomputed transformations
//! ([`IsectTri`]) as lanes; empty lanes are all-zero rows, which never report a hit.
//! Slab tests follow Williams et al. 2005 with the far distance scaled by 1 + 2γ₃ (Ize 2013,
//! "Robust BVH Ray Traversal", JCGT 2(2)), so a ray grazing a flat box (an axis-aligned wall)
//! is never lost to rounding.

mod lanes;

use glam::{Vec3, Vec3A, Vec4};
#[cfg(target_arch = "x86_64")]
use lanes::F8;
use lanes::Lanes;
use obvhs::aabb::Aabb;
use std::mem::MaybeUninit;
use std::time::Duration;

/// Triangle packs per leaf asked of the builder (leaves of up to `LEAF_PACKS_ASKED · N`
/// triangles).
const LEAF_PACKS_ASKED: u32 = 2;
/// The cost of testing one node, in units of one triangle test, given to the builder's leaf
/// collapse (obvhs' SAH: a leaf of k triangles costs k, an inner node this plus its children):
/// [`Lanes::N`], as one N-wide node test costs about what one N-triangle pack test does. With
/// obvhs' default of 3 the collapse priced a leaf by its triangles, as a scalar tracer tests
/// them, and stopped at 4.0–4.4 triangles per eight-lane pack (Lost Empire, the Mori knob, a
/// 1M-triangle heightfield). At N it fills 5.9–6.5 of 8 lanes, with 0.61–0.73× the packs,
/// 0.37–0.48× the nodes and 0.61× the memory (72 MB for the heightfield instead of 118), at the
/// same render speed (one thread, paired whole processes at 192², 32 spp: 0.995× on the Mori
/// knob, 1.00× on the holodeck, 0.95× on Lost Empire, medians of 7) and a slightly faster
/// build. Costs above N change little (10 and 16 give the same packs within 1 %).
fn collapse_node_cost<L: Lanes>() -> f32 {
    L::N as f32
}
/// Largest number of packs in a leaf (the slot's 3-bit count).
const LEAF_PACKS_MAX: usize = 8;
/// Child slot marker: the child is a leaf (`LEAF | packs − 1 << 28 | first pack`).
const LEAF: u32 = 1 << 31;
/// An unused child slot.
const EMPTY: u32 = u32::MAX;
/// Entries of the traversal stack kept on the machine stack; deeper trees use the heap.
const INLINE_STACK: usize = 64;
/// 1 + 2γ₃ with γₙ = nε / (1 − nε), ε = 2⁻²⁴ (pbrt-v3 §3.9.2; Ize 2013).
const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Intersection data of one triangle: the affine map that takes it to the unit triangle in the
/// xy-plane (Baldwin & Weber 2016, "Fast Ray-Triangle Intersections by Coordinate
/// Transformation", JCGT 5(3), the precomputed-transformation variant): three rows of
/// (x, y, z, constant). Row 2 gives the signed distance to the plane, rows 0 and 1 the
/// barycentrics of v1 and v2. Degenerate triangles get rows of zeros and are never hit.
#[derive(Clone, Copy, Debug)]
pub(crate) struct IsectTri {
    r: [Vec4; 3],
}

impl IsectTri {
    /// The transformation of triangle (v0, v1, v2), normalised by its largest normal component.
    pub(crate) fn new(v0: Vec3, v1: Vec3, v2: Vec3) -> IsectTri {
        let (e1, e2) = (v1 - v0, v2 - v0);
        let n = e1.cross(e2);
        let (c20, c10) = (v2.cross(v0), v1.cross(v0));
        let d = -v0.dot(n);
        let a = n.abs();
        let r = if a.x > a.y && a.x > a.z {
            let k = 1.0 / n.x;
            [
                Vec4::new(0.0, e2.z * k, -e2.y * k, c20.x * k),
                Vec4::new(0.0, -e1.z * k, e1.y * k, -c10.x * k),
                Vec4::new(1.0, n.y * k, n.z * k, d * k),
            ]
        } else if a.y > a.z {
            let k = 1.0 / n.y;
            [
                Vec4::new(-e2.z * k, 0.0, e2.x * k, c20.y * k),
                Vec4::new(e1.z * k, 0.0, -e1.x * k, -c10.y * k),
                Vec4::new(n.x * k, 1.0, n.z * k, d * k),
            ]
        } else if a.z > 0.0 {
            let k = 1.0 / n.z;
            [
                Vec4::new(e2.y * k, -e2.x * k, 0.0, c20.z * k),
                Vec4::new(-e1.y * k, e1.x * k, 0.0, -c10.z * k),
                Vec4::new(n.x * k, n.y * k, 1.0, d * k),
            ]
        } else {
            [Vec4::ZERO; 3]
        };
        if r.iter().all(|r| r.is_finite()) {
            IsectTri { r }
        } else {
            IsectTri { r: [Vec4::ZERO; 3] }
        }
    }

    /// (t, b1, b2) for a hit at t in (0, `t_max`) (scalar; the reference for the packs).
    #[cfg(test)]
    pub(crate) fn intersect(&self, o: Vec3A, d: Vec3A, t_max: f32) -> Option<(f32, f32, f32)> {
        let row = |r: Vec4| Vec3A::from(r.truncate());
        let t = -(row(self.r[2]).dot(o) + self.r[2].w) / row(self.r[2]).dot(d);
        if !(t > 0.0 && t < t_max) {
            return None;
        }
        let h = o + d * t;
        let b1 = row(self.r[0]).dot(h) + self.r[0].w;
        let b2 = row(self.r[1]).dot(h) + self.r[1].w;
        (b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0).then_some((t, b1, b2))
    }
}

/// [`Lanes::N`] triangles' transformations as lanes: `m[row][column]` holds column (x, y, z,
/// constant) of row 0, 1 or 2 for each triangle; `ids` are the triangle ids (`EMPTY` for an
/// unused lane, whose rows are zero).
#[derive(Clone, Copy)]
struct TriPack<L: Lanes> {
    m: [[L; 4]; 3],
    ids: L::Ids,
}

impl<L: Lanes> TriPack<L> {
    fn new(tris: &[(u32, IsectTri)]) -> TriPack<L> {
        let mut m = [[[0f32; 8]; 4]; 3];
        let mut ids = L::ids(EMPTY);
        for (lane, (id, t)) in tris.iter().enumerate() {
            ids.as_mut()[lane] = *id;
            for (rows, r) in m.iter_mut().zip(&t.r) {
                for (col, v) in rows.iter_mut().zip(r.to_array()) {
                    col[lane] = v;
                }
            }
        }
        TriPack {
            m: m.map(|row| row.map(|col| L::from_slice(&col))),
            ids,
        }
    }

    /// Per lane: hit mask (bit i for lane i) of hits at t in (0, `t_max`), and t, b1, b2.
    #[inline(always)]
    fn intersect(&self, r: &Prepared<L>, t_max: f32) -> (u32, L, L, L) {
        let [m0, m1, m2] = &self.m;
        let dot = |m: &[L; 4], v: &[L; 3]| m[0].mul(v[0]).add(m[1].mul(v[1])).add(m[2].mul(v[2]));
        let dn = dot(m2, &r.d);
        let t = dot(m2, &r.o).add(m2[3]).neg().div(dn);
        let h = [
            r.o[0].add(r.d[0].mul(t)),
            r.o[1].add(r.d[1].mul(t)),
            r.o[2].add(r.d[2].mul(t)),
        ];
        let b1 = dot(m0, &h).add(m0[3]);
        let b2 = dot(m1, &h).add(m1[3]);
        let zero = L::splat(0.0);
        let ok = t.gt(zero)
            & t.lt(L::splat(t_max))
            & b1.ge(zero)
            & b2.ge(zero)
            & b1.add(b2).le(L::splat(1.0));
        (L::bitmask(ok), t, b1, b2)
    }
}

/// Up to [`Lanes::N`] children: their boxes as lanes (`b[2a]` the lower and `b[2a + 1]` the
/// upper bound on axis a, so a ray picks its near plane by index rather than by branch) and
/// their slots (an inner node's index, a leaf, or `EMPTY`, whose box is inverted and never hit).
#[derive(Clone, Copy)]
struct Node<L: Lanes> {
    b: [L; 6],
    child: L::Ids,
}

impl<L: Lanes> Node<L> {
    /// A node whose lane i has box [lo[a][i], hi[a][i]] on axis a and slot `child[i]`.
    fn new(lo: &[[f32; 8]; 3], hi: &[[f32; 8]; 3], child: L::Ids) -> Node<L> {
        let l = |v: &[f32; 8]| L::from_slice(v);
        Node {
            b: [
                l(&lo[0]),
                l(&hi[0]),
                l(&lo[1]),
                l(&hi[1]),
                l(&lo[2]),
                l(&hi[2]),
            ],
            child,
        }
    }
}

/// A ray prepared for the SIMD tests: origin, direction and reciprocal direction splatted per
/// axis, and which slab plane is near on each axis.
struct Prepared<L: Lanes> {
    o: [L; 3],
    d: [L; 3],
    inv: [L; 3],
    /// Index into `Node::b` of the near plane on each axis (the far one is `^ 1`).
    near: [usize; 3],
}

impl<L: Lanes> Prepared<L> {
    #[inline(always)]
    fn new(o: Vec3A, d: Vec3A) -> Prepared<L> {
        // A zero component would give 0 × ∞ = NaN in the slab test; a tiny one gives the
        // same answer without it.
        let safe = |c: f32| {
            if c.abs() < 1e-30 {
                1e-30f32.copysign(c)
            } else {
                c
            }
        };
        // One vector division for the three reciprocals (the same correctly rounded values).
        let inv = (Vec3A::ONE / Vec3A::new(safe(d.x), safe(d.y), safe(d.z))).to_array();
        Prepared {
            o: [L::splat(o.x), L::splat(o.y), L::splat(o.z)],
            d: [L::splat(d.x), L::splat(d.y), L::splat(d.z)],
            inv: inv.map(L::splat),
            near: [0, 2, 4].map(|k| k + (inv[k / 2] < 0.0) as usize),
        }
    }

    /// Slab test of the node's boxes over (0, `t_max`): hit mask and entry distances.
    #[inline(always)]
    fn boxes(&self, n: &Node<L>, t_max: f32) -> (u32, L) {
        let axis = |a: usize| {
            let (near, far) = (n.b[self.near[a]], n.b[self.near[a] ^ 1]);
            (
                near.sub(self.o[a]).mul(self.inv[a]),
                far.sub(self.o[a]).mul(self.inv[a]),
            )
        };
        let (nx, fx) = axis(0);
        let (ny, fy) = axis(1);
        let (nz, fz) = axis(2);
        let t_near = nx.max(ny).max(nz.max(L::splat(0.0)));
        let t_far = fx
            .min(fy)
            .min(fz.min(L::splat(t_max)))
            .mul(L::splat(FAR_SCALE));
        (L::bitmask(t_near.le(t_far)), t_near)
    }
}

/// The traversal stack: (slot, entry distance) pairs, on the machine stack up to
/// [`INLINE_STACK`] entries and on the heap for deeper trees. The inline entries start
/// uninitialised: zeroing them cost a 512-byte fill per ray, several per cent of a render.
struct Stack {
    inline: [MaybeUninit<(u32, f32)>; INLINE_STACK],
    len: usize,
    spill: Vec<(u32, f32)>,
}

impl Stack {
    #[inline(always)]
    fn new() -> Stack {
        Stack {
            inline: [const { MaybeUninit::uninit() }; INLINE_STACK],
            len: 0,
            spill: Vec::new(),
        }
    }

    #[inline(always)]
    fn push(&mut self, e: (u32, f32)) {
        if self.len < INLINE_STACK {
            self.inline[self.len].write(e);
            self.len += 1;
        } else {
            self.spill.push(e);
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if let Some(e) = self.spill.pop() {
            return Some(e);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: entries below `len` were written by `push` and are never moved out (the
        // pair is `Copy`); `len` only grows past an entry after writing it.
        Some(unsafe { self.inline[self.len].assume_init() })
    }
}

/// A BVH over a set of triangles with [`Lanes::N`]-wide nodes and triangle packs.
pub(crate) struct Tree<L: Lanes> {
    nodes: Vec<Node<L>>,
    packs: Vec<TriPack<L>>,
}

impl<L: Lanes> Tree<L> {
    /// Builds over the triangles `ids` (at least one), whose vertices are `verts(id)`.
    fn build(ids: &[u32], verts: impl Fn(u32) -> [Vec3; 3]) -> Tree<L> {
        // The builder needs only each triangle's box (32 bytes, against 48 for its vertices):
        // the same tree as from the triangles themselves, as the build reads nothing else.
        let boxes: Vec<Aabb> = ids
            .iter()
            .map(|&i| {
                let [v0, v1, v2] = verts(i);
                Aabb::new(v0.min(v1).min(v2).into(), v0.max(v1).max(v2).into())
            })
            .collect();
        let params = obvhs::BvhBuildParams {
            max_prims_per_leaf: LEAF_PACKS_ASKED * L::N as u32,
            collapse_traversal_cost: collapse_node_cost::<L>(),
            ..obvhs::BvhBuildParams::medium_build()
        };
        assert!(
            !params.pre_split,
            "spatial splits need the triangles, not their boxes"
        );
        let mut core = Duration::default();
        let bvh2 = obvhs::bvh2::builder::build_bvh2(&boxes, params, &mut core);
        drop(boxes);
        let mut out = Tree {
            nodes: Vec::with_capacity(bvh2.nodes.len() / (L::N / 2) + 1),
            packs: Vec::with_capacity(ids.len() / (L::N / 2) + 1),
        };
        let pack = |out: &mut Tree<L>, n: &obvhs::bvh2::node::Bvh2Node| {
            let range = n.first_index as usize..(n.first_index + n.prim_count) as usize;
            let tris: Vec<(u32, IsectTri)> = bvh2.primitive_indices[range]
                .iter()
                .map(|&k| {
                    let id = ids[k as usize];
                    let [v0, v1, v2] = verts(id);
                    (id, IsectTri::new(v0, v1, v2))
                })
                .collect();
            out.push_leaf(&tris)
        };
        let root = &bvh2.nodes[0];
        if root.is_leaf() {
            let slot = pack(&mut out, root);
            let (mut lo, mut hi) = ([[f32::INFINITY; 8]; 3], [[f32::NEG_INFINITY; 8]; 3]);
            let mut child = L::ids(EMPTY);
            for a in 0..3 {
                lo[a][0] = f32::NEG_INFINITY;
                hi[a][0] = f32::INFINITY;
            }
            child.as_mut()[0] = slot;
            out.nodes.push(Node::new(&lo, &hi, child));
        } else {
            out.inner(&bvh2.nodes, 0, &pack);
        }
        out
    }

    /// Packs a leaf's triangles and returns its slot.
    fn push_leaf(&mut self, tris: &[(u32, IsectTri)]) -> u32 {
        let first = self.packs.len() as u32;
        let chunks: Vec<&[(u32, IsectTri)]> = tris.chunks(L::N).collect();
        assert!(
            !chunks.is_empty() && chunks.len() <= LEAF_PACKS_MAX,
            "a BVH leaf of {} triangles",
            tris.len()
        );
        assert!(first < 1 << 28, "more than 2^28 triangle packs");
        for c in &chunks {
            self.packs.push(TriPack::new(c));
        }
        LEAF | (chunks.len() as u32 - 1) << 28 | first
    }

    /// Converts the subtree of inner BVH2 node `i` (depth first) and returns its index: the
    /// node's children are opened, largest surface area first, until it has [`Lanes::N`].
    fn inner(
        &mut self,
        b2: &[obvhs::bvh2::node::Bvh2Node],
        i: usize,
        pack: &impl Fn(&mut Tree<L>, &obvhs::bvh2::node::Bvh2Node) -> u32,
    ) -> u32 {
        let kids = |k: usize| [b2[k].first_index as usize, b2[k].first_index as usize + 1];
        let mut children: Vec<usize> = kids(i).to_vec();
        while children.len() < L::N {
            let best = children
                .iter()
                .enumerate()
                .filter(|(_, c)| !b2[**c].is_leaf())
                .max_by(|a, b| {
                    b2[*a.1]
                        .aabb
                        .half_area()
                        .total_cmp(&b2[*b.1].aabb.half_area())
                });
            let Some((at, &c)) = best else { break };
            children.swap_remove(at);
            children.extend(kids(c));
        }
        let me = self.nodes.len();
        let (mut lo, mut hi) = ([[f32::INFINITY; 8]; 3], [[f32::NEG_INFINITY; 8]; 3]);
        self.nodes.push(Node::new(&lo, &hi, L::ids(EMPTY)));
        let mut child = L::ids(EMPTY);
        for (lane, &c) in children.iter().enumerate() {
            let n = &b2[c];
            child.as_mut()[lane] = if n.is_leaf() {
                pack(self, n)
            } else {
                self.inner(b2, c, pack)
            };
            for a in 0..3 {
                lo[a][lane] = n.aabb.min[a];
                hi[a][lane] = n.aabb.max[a];
            }
        }
        self.nodes[me] = Node::new(&lo, &hi, child);
        me as u32
    }

    /// The triangle packs of leaf slot `slot`.
    #[inline(always)]
    fn leaf(&self, slot: u32) -> &[TriPack<L>] {
        let first = (slot & 0x0fff_ffff) as usize;
        let count = ((slot >> 28) & 7) as usize + 1;
        &self.packs[first..first + count]
    }

    /// Closest hit at t in (0, `t_max`) that `keep(triangle id, b1, b2)` accepts: (triangle id,
    /// t, b1, b2).
    #[inline(always)]
    fn closest(
        &self,
        o: Vec3A,
        d: Vec3A,
        mut t_max: f32,
        keep: impl Fn(u32, f32, f32) -> bool,
    ) -> Option<(u32, f32, f32, f32)> {
        let r = Prepared::<L>::new(o, d);
        let mut best = None;
        let mut stack = Stack::new();
        let mut slot = 0u32;
        loop {
            if slot & LEAF == 0 {
                let node = &self.nodes[slot as usize];
                let (mask, t_near) = r.boxes(node, t_max);
                // No, one or several children hit (bit tests: a population count compiles to
                // a dozen instructions where the CPU's POPCNT is not enabled).
                if mask != 0 {
                    slot = if mask & (mask - 1) == 0 {
                        node.child.as_ref()[mask.trailing_zeros() as usize]
                    } else {
                        push_ordered(&mut stack, node, mask, t_near)
                    };
                    continue;
                }
            } else {
                for pack in self.leaf(slot) {
                    let (mask, t, b1, b2) = pack.intersect(&r, t_max);
                    for lane in lanes(mask) {
                        let id = pack.ids.as_ref()[lane];
                        let (t, b1, b2) = (t.lane(lane), b1.lane(lane), b2.lane(lane));
                        if t < t_max && keep(id, b1, b2) {
                            t_max = t;
                            best = Some((id, t, b1, b2));
                        }
                    }
                }
            }
            loop {
                let Some((s, t_near)) = stack.pop() else {
                    return best;
                };
                if t_near <= t_max {
                    slot = s;
                    break;
                }
            }
        }
    }

    /// True when nothing that `keep` accepts is hit at t in (0, `t_max`).
    #[inline(always)]
    fn unoccluded(
        &self,
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
        keep: impl Fn(u32, f32, f32) -> bool,
    ) -> bool {
        let r = Prepared::<L>::new(o, d);
        let mut stack = Stack::new();
        let mut slot = 0u32;
        loop {
            if slot & LEAF == 0 {
                let node = &self.nodes[slot as usize];
                let (mask, _) = r.boxes(node, t_max);
                for lane in lanes(mask) {
                    stack.push((node.child.as_ref()[lane], 0.0));
                }
            } else {
                for pack in self.leaf(slot) {
                    let (mask, _, b1, b2) = pack.intersect(&r, t_max);
                    for lane in lanes(mask) {
                        if keep(pack.ids.as_ref()[lane], b1.lane(lane), b2.lane(lane)) {
                            return false;
                        }
                    }
                }
            }
            match stack.pop() {
                Some((s, _)) => slot = s,
                None => return true,
            }
        }
    }
}

/// A BVH over a set of triangles, as wide as the CPU's SIMD allows: eight-wide nodes and
/// packs where the CPU has AVX2 ([`Tree<F8>`]), four-wide otherwise ([`Tree<Vec4>`]). Both give
/// the same hits (the same arithmetic per triangle; only the order in which equal-distance
/// hits are found can differ).
pub(crate) enum Bvh {
    /// Four-wide (SSE or NEON).
    W4(Tree<Vec4>),
    /// Eight-wide (AVX2).
    #[cfg(target_arch = "x86_64")]
    W8(Tree<F8>),
}

impl Bvh {
    /// Builds over the triangles `ids` (at least one), whose vertices are `verts(id)`, at the
    /// widest width this CPU runs.
    pub(crate) fn build(ids: &[u32], verts: impl Fn(u32) -> [Vec3; 3]) -> Bvh {
        #[cfg(target_arch = "x86_64")]
        if lanes::has_avx2() {
            return Bvh::W8(Tree::build(ids, verts));
        }
        Bvh::W4(Tree::build(ids, verts))
    }

    /// Builds four-wide whatever the CPU (tests of the fallback).
    #[cfg(test)]
    pub(crate) fn build4(ids: &[u32], verts: impl Fn(u32) -> [Vec3; 3]) -> Bvh {
        Bvh::W4(Tree::build(ids, verts))
    }

    /// (lanes per pack, triangle packs, inner nodes).
    #[cfg(test)]
    fn shape(&self) -> (usize, usize, usize) {
        match self {
            Bvh::W4(t) => (4, t.packs.len(), t.nodes.len()),
            #[cfg(target_arch = "x86_64")]
            Bvh::W8(t) => (8, t.packs.len(), t.nodes.len()),
        }
    }

    /// Closest hit at t in (0, `t_max`) that `keep(triangle id, b1, b2)` accepts: (triangle id,
    /// t, b1, b2).
    #[inline]
    pub(crate) fn closest(
        &self,
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
        keep: impl Fn(u32, f32, f32) -> bool,
    ) -> Option<(u32, f32, f32, f32)> {
        match self {
            Bvh::W4(t) => t.closest(o, d, t_max, keep),
            // SAFETY: eight-wide trees are built only on CPUs with AVX2.
            #[cfg(target_arch = "x86_64")]
            Bvh::W8(t) => unsafe { closest_avx2(t, o, d, t_max, keep) },
        }
    }

    /// True when nothing that `keep` accepts is hit at t in (0, `t_max`).
    #[inline]
    pub(crate) fn unoccluded(
        &self,
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
        keep: impl Fn(u32, f32, f32) -> bool,
    ) -> bool {
        match self {
            Bvh::W4(t) => t.unoccluded(o, d, t_max, keep),
            // SAFETY: eight-wide trees are built only on CPUs with AVX2.
            #[cfg(target_arch = "x86_64")]
            Bvh::W8(t) => unsafe { unoccluded_avx2(t, o, d, t_max, keep) },
        }
    }
}

/// [`Tree::closest`] compiled for AVX2, where the eight-lane operations inline.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn closest_avx2(
    t: &Tree<F8>,
    o: Vec3A,
    d: Vec3A,
    t_max: f32,
    keep: impl Fn(u32, f32, f32) -> bool,
) -> Option<(u32, f32, f32, f32)> {
    t.closest(o, d, t_max, keep)
}

/// [`Tree::unoccluded`] compiled for AVX2.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn unoccluded_avx2(
    t: &Tree<F8>,
    o: Vec3A,
    d: Vec3A,
    t_max: f32,
    keep: impl Fn(u32, f32, f32) -> bool,
) -> bool {
    t.unoccluded(o, d, t_max, keep)
}

/// The set bits of a lane mask, lowest first.
#[inline(always)]
fn lanes(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let lane = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            lane
        })
    })
}

/// Pushes the hit children of `node` (two or more bits of `mask`) farthest first and returns
/// the nearest, which is visited next.
#[inline(always)]
fn push_ordered<L: Lanes>(stack: &mut Stack, node: &Node<L>, mask: u32, t_near: L) -> u32 {
    let mut hits = [(0u32, 0.0f32); 8];
    let mut n = 0;
    for lane in lanes(mask) {
        // Insertion sort by distance, nearest last.
        let e = (node.child.as_ref()[lane], t_near.lane(lane));
        let mut k = n;
        while k > 0 && hits[k - 1].1 < e.1 {
            hits[k] = hits[k - 1];
            k -= 1;
        }
        hits[k] = e;
        n += 1;
    }
    for &h in &hits[..n - 1] {
        stack.push(h);
    }
    hits[n - 1].0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// Möller–Trumbore in f64, the independent reference: (t, b1, b2) for t > 0.
    fn reference(v: [Vec3; 3], o: Vec3, d: Vec3) -> Option<(f64, f64, f64)> {
        let f = |v: Vec3| glam::DVec3::new(v.x as f64, v.y as f64, v.z as f64);
        let (v0, e1, e2, o, d) = (f(v[0]), f(v[1] - v[0]), f(v[2] - v[0]), f(o), f(d));
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-14 {
            return None;
        }
        let s = o - v0;
        let b1 = s.dot(p) / det;
        let q = s.cross(e1);
        let b2 = d.dot(q) / det;
        let t = e2.dot(q) / det;
        (b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 && t > 0.0).then_some((t, b1, b2))
    }

    #[test]
    fn baldwin_weber_agrees_with_f64_moller_trumbore() {
        let mut rng = Rng::new(11, 2);
        let mut r3 = || Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0 - 2.0;
        let (mut hits, mut checked) = (0, 0);
        for _ in 0..20_000 {
            let v = [r3(), r3(), r3()];
            let o = r3() * 3.0;
            let target = (v[0] + v[1] + v[2]) / 3.0 + r3() * 0.5;
            let d = (target - o).normalize();
            let tri = IsectTri::new(v[0], v[1], v[2]);
            let got = tri.intersect(o.into(), d.into(), f32::INFINITY);
            let want = reference(v, o, d);
            match (got, want) {
                (Some((t, b1, b2)), Some((tw, b1w, b2w))) => {
                    hits += 1;
                    assert!((t as f64 - tw).abs() < 1e-3 * tw.max(1.0), "t {t} vs {tw}");
                    assert!((b1 as f64 - b1w).abs() < 1e-3 && (b2 as f64 - b2w).abs() < 1e-3);
                }
                (None, None) => {}
                // Disagreement only within rounding of an edge.
                (Some((_, b1, b2)), None) => {
                    assert!(b1.min(b2).min(1.0 - b1 - b2) < 1e-4, "{b1} {b2}")
                }
                (None, Some((_, b1, b2))) => assert!(b1.min(b2).min(1.0 - b1 - b2) < 1e-4),
            }
            checked += 1;
        }
        assert!(hits > checked / 5, "{hits} of {checked}");
    }

    /// Random triangle soups of several sizes: the BVH's closest hit and occlusion agree with
    /// testing every triangle (the scalar transformation test), ray by ray.
    #[test]
    fn bvh_agrees_with_brute_force() {
        let mut rng = Rng::new(5, 9);
        let r3 = |rng: &mut Rng| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0 - 1.0;
        for n in [1usize, 3, 7, 50, 2000] {
            let tris: Vec<[Vec3; 3]> = (0..n)
                .map(|_| {
                    let c = r3(&mut rng) * 4.0;
                    [0, 1, 2].map(|_| c + r3(&mut rng) * 0.5)
                })
                .collect();
            let ids: Vec<u32> = (0..n as u32).collect();
            let bvhs = [
                Bvh::build(&ids, |i| tris[i as usize]),
                Bvh::build4(&ids, |i| tris[i as usize]),
            ];
            let isect: Vec<IsectTri> = tris
                .iter()
                .map(|v| IsectTri::new(v[0], v[1], v[2]))
                .collect();
            let mut hits = 0;
            for _ in 0..2000 {
                // Aimed near a random triangle, so that about half the rays hit something.
                let o = r3(&mut rng) * 6.0;
                let v = tris[(rng.uniform() * n as f32) as usize % n];
                let aim = (v[0] + v[1] + v[2]) / 3.0 + r3(&mut rng) * 0.15;
                let d = (aim - o).normalize();
                let t_max = if o.x < 0.0 { f32::INFINITY } else { 8.0 };
                let brute = isect
                    .iter()
                    .enumerate()
                    .filter_map(|(i, t)| {
                        t.intersect(o.into(), d.into(), t_max)
                            .map(|h| (i as u32, h.0))
                    })
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                for bvh in &bvhs {
                    let got = bvh.closest(o.into(), d.into(), t_max, |_, _, _| true);
                    assert_eq!(got.map(|g| (g.0, g.1)), brute, "n {n}");
                    assert_eq!(
                        bvh.unoccluded(o.into(), d.into(), t_max, |_, _, _| true),
                        brute.is_none()
                    );
                }
                hits += brute.is_some() as u32;
            }
            assert!(hits > 400, "n {n}: {hits} hits");
        }
    }

    /// On a 200 × 200 heightfield (79,202 triangles) the leaves fill most of a pack's lanes:
    /// with the builder's default node cost (3 triangle tests) they held 4.2 triangles per
    /// eight-lane pack (53 % of the lanes); with the node cost at the pack width, 6.2 (77 %),
    /// and 3.3 of 4 in the four-wide tree.
    #[test]
    fn leaves_fill_most_lanes() {
        let n = 200;
        let at = |i: usize, j: usize| {
            let (x, z) = (i as f32 / n as f32 * 10.0, j as f32 / n as f32 * 10.0);
            Vec3::new(x, 0.2 * (3.0 * x).sin() * (2.0 * z).cos(), z)
        };
        let tris: Vec<[Vec3; 3]> = (0..n * n)
            .flat_map(|k| {
                let (i, j) = (k / n, k % n);
                [
                    [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                    [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
                ]
            })
            .collect();
        let ids: Vec<u32> = (0..tris.len() as u32).collect();
        for bvh in [
            Bvh::build(&ids, |i| tris[i as usize]),
            Bvh::build4(&ids, |i| tris[i as usize]),
        ] {
            let (lanes, packs, nodes) = bvh.shape();
            let fill = tris.len() as f64 / (packs * lanes) as f64;
            eprintln!("{lanes} lanes: {packs} packs, {nodes} nodes, fill {fill:.3}");
            assert!(fill > 0.7, "{lanes}-wide packs {:.0} % full", 100.0 * fill);
        }
    }

    /// The traversal stack spills to the heap past its inline entries and pops in LIFO order.
    #[test]
    fn stack_spills_and_pops_in_order() {
        let mut s = Stack::new();
        for i in 0..(3 * INLINE_STACK as u32) {
            s.push((i, i as f32));
        }
        for i in (0..(3 * INLINE_STACK as u32)).rev() {
            assert_eq!(s.pop(), Some((i, i as f32)));
        }
        assert_eq!(s.pop(), None);
    }

    /// Rays along a flat, axis-aligned quad (a zero-thickness box) and along the axes still hit.
    #[test]
    fn flat_boxes_and_axis_rays_hit() {
        let q = [
            [
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 1.0),
            ],
            [
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 1.0),
                Vec3::new(0.0, 0.0, 1.0),
            ],
        ];
        for bvh in [
            Bvh::build(&[0, 1], |i| q[i as usize]),
            Bvh::build4(&[0, 1], |i| q[i as usize]),
        ] {
            flat_quad_is_hit(&bvh);
        }
    }

    fn flat_quad_is_hit(bvh: &Bvh) {
        for k in 1..20 {
            let x = k as f32 / 20.0;
            let down = bvh.closest(
                Vec3A::new(x, 1.0, 0.3),
                Vec3A::NEG_Y,
                f32::INFINITY,
                |_, _, _| true,
            );
            assert!(down.is_some_and(|h| (h.1 - 1.0).abs() < 1e-6), "x {x}");
            let up = bvh.closest(
                Vec3A::new(0.3, -2.0, x),
                Vec3A::Y,
                f32::INFINITY,
                |_, _, _| true,
            );
            assert!(up.is_some_and(|h| (h.1 - 2.0).abs() < 1e-6), "z {x}");
        }
    }
}

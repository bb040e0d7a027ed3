//! The global step under geometric constraints (alg. 7 step 6, C_g ũ = b of eq. 4.7), by
//! elimination: a vertex on one line gets the unknowns (along the line's normal, along the
//! line) with the first fixed; a vertex on two lines (a corner of the curves) is fixed. One
//! fixed component is not a complex-linear condition, so the system is assembled in its real
//! 2×2-block form (twice the unknowns of the complex one; factored once per solve).
//!
//! A component whose energy is invariant under translations has one vertex pinned at 0 in the
//! unconstrained step; with lines on it, the lines fix the translation across them, and the
//! pin keeps only the directions they leave free (otherwise it would pull every line through
//! the pinned vertex's lattice point).

use std::collections::BTreeMap;

use glam::DVec3;

use super::ParamError;
use super::constraints::VertexFix;
use super::cut::{CutGraph, NONE};
use super::global::{GlobalSystem, stiffness};
use super::rot::{M2, Rots, apply, mul, transpose};
use super::untangle::MapSpace;
use crate::mesh::TriMesh;
use crate::sparse::{Analysis, SparseBuilder, SpdSolver};

/// Per corner ψ (disk frames) minimising the global energy with the gaps `w` fixed and the
/// vertex constraints `fixes` holding exactly.
pub(crate) fn solve(
    mesh: &TriMesh,
    cut: &CutGraph,
    global: &GlobalSystem,
    rots: &Rots,
    disk: &[[DVec3; 2]],
    w: &[[f64; 2]],
    fixes: &BTreeMap<usize, VertexFix>,
) -> Result<(Vec<[f64; 2]>, MapSpace), ParamError> {
    ConstrainedStep::new(mesh, cut, global, rots, disk, fixes)?.solve(w, fixes)
}

/// The global step under vertex constraints, factored once. The matrix depends only on which
/// components the constraints fix and along which normals, not on the gaps or the fixed values,
/// so one factorization serves every rounding of the integer unknowns (the re-rounding under
/// curves solves a dozen candidates per round).
pub(crate) struct ConstrainedStep<'a> {
    mesh: &'a TriMesh,
    cut: &'a CutGraph,
    global: &'a GlobalSystem,
    rots: &'a Rots,
    disk: &'a [[DVec3; 2]],
    /// Per vertex the basis Q (columns) of its unknowns.
    q: Vec<M2>,
    /// Per component (2v + i): fixed.
    fixed: Vec<bool>,
    solver: SpdSolver,
    /// The right-hand side's parts that do not depend on the gaps or the fixed values,
    /// computed once: a solve per candidate rounding assembles only what they change (the
    /// bunny with its boundary aligned: 14 → 3 ms of each 30 ms solve).
    rhs: RhsParts,
}

/// The constrained step's right-hand side as an affine function of the corners' constants
/// c (from the gaps) and the fixed components' values y:
/// rhs_free = t − Σ_corners Q_aᵀ R^{−rot_a} Σ_b k_ab c_b − K_free,fixed y, rhs_fixed = y.
struct RhsParts {
    /// Σ over a vertex's corners of Q_aᵀ R^{−rot_a} b_a (the targets), on the free rows.
    targets: Vec<f64>,
    /// Per face its stiffness k.
    stiffness: Vec<[[f64; 3]; 3]>,
    /// Per corner with unknowns Q_aᵀ R^{−rot_a}.
    to_row: Vec<M2>,
    /// The entries coupling free rows to fixed columns: (row, column, value).
    coupling: Vec<(u32, u32, f64)>,
}

/// Per vertex the basis Q of its unknowns, and per component its fixed value (singular
/// vertices: 0; the unconstrained step's pins replaced by what the lines leave free).
fn layout(
    mesh: &TriMesh,
    cut: &CutGraph,
    global: &GlobalSystem,
    rots: &Rots,
    fixes: &BTreeMap<usize, VertexFix>,
) -> (Vec<M2>, Vec<Option<f64>>) {
    let nv = mesh.n_vertices();
    let mut fixes = fixes.clone();
    pin_translations(mesh, cut, global, rots, &mut fixes);
    let mut q: Vec<M2> = vec![[1.0, 0.0, 0.0, 1.0]; nv];
    let mut fixed: Vec<Option<f64>> = vec![None; 2 * nv];
    for (&v, fix) in &fixes {
        match *fix {
            VertexFix::One { m, value } => {
                q[v] = [m[0], -m[1], m[1], m[0]];
                fixed[2 * v] = Some(value);
            }
            VertexFix::Both { x } => {
                fixed[2 * v] = Some(x[0]);
                fixed[2 * v + 1] = Some(x[1]);
            }
        }
    }
    for v in 0..nv {
        if cut.singular[v] {
            fixed[2 * v] = Some(0.0);
            fixed[2 * v + 1] = Some(0.0);
        }
    }
    (q, fixed)
}

/// The global step's entries k_ab Q_aᵀ R^{rot_b − rot_a} Q_b of corner `ca`'s face on the free
/// rows of its vertex, as (row, column, value) with columns free or fixed (singular vertices
/// have no unknowns).
#[allow(clippy::too_many_arguments)]
fn corner_entries(
    mesh: &TriMesh,
    cut: &CutGraph,
    global: &GlobalSystem,
    rots: &Rots,
    q: &[M2],
    fixed: &[Option<f64>],
    k: &[[f64; 3]; 3],
    ca: usize,
    mut visit: impl FnMut(usize, usize, f64),
) {
    let var_of = |c: usize| -> Option<usize> {
        let v = mesh.from(c);
        (!cut.singular[v]).then_some(v)
    };
    let Some(va) = var_of(ca) else { return };
    let (f, a) = (ca / 3, ca % 3);
    let ra = global.corner_rot[ca] as i64;
    let qa_t = transpose(&q[va]);
    for bb in 0..3 {
        let cb = 3 * f + bb;
        let Some(vb) = var_of(cb) else { continue };
        let rb = global.corner_rot[cb] as i64;
        let blk = mul(&qa_t, &mul(rots.get(rb - ra), &q[vb]));
        for i in 0..2 {
            let row = 2 * va + i;
            if fixed[row].is_some() {
                continue;
            }
            for j in 0..2 {
                visit(row, 2 * vb + j, k[a][bb] * blk[2 * i + j]);
            }
        }
    }
}

impl<'a> ConstrainedStep<'a> {
    pub(crate) fn new(
        mesh: &'a TriMesh,
        cut: &'a CutGraph,
        global: &'a GlobalSystem,
        rots: &'a Rots,
        disk: &'a [[DVec3; 2]],
        fixes: &BTreeMap<usize, VertexFix>,
    ) -> Result<Self, ParamError> {
        let nv = mesh.n_vertices();
        let (q, fixed) = layout(mesh, cut, global, rots, fixes);
        let mut b = SparseBuilder::<f64>::with_capacity(2 * nv, 2 * nv + 18 * mesh.n_faces());
        for (i, f) in fixed.iter().enumerate() {
            // Explicit zero keeps every diagonal in the pattern.
            b.add(i, i, if f.is_some() { 1.0 } else { 0.0 });
        }
        for f in 0..mesh.n_faces() {
            let k = stiffness(mesh, f);
            for a in 0..3 {
                corner_entries(
                    mesh,
                    cut,
                    global,
                    rots,
                    &q,
                    &fixed,
                    &k,
                    3 * f + a,
                    |r, c, v| {
                        // The lower triangle only: the factorization reads no other (half
                        // the entries to sort: 125 → 60 ms on the bunny).
                        if fixed[c].is_none() && r >= c {
                            b.add(r, c, v);
                        }
                    },
                );
            }
        }
        let matrix = b.build()?;
        // The unconstrained system's ordering, a 2 × 2 block per vertex: no ordering is
        // computed again (the pattern is the same vertex adjacency, each vertex doubled).
        let analysis = match global.analysis().order() {
            Some(order) => {
                let blocks: Vec<usize> = order.iter().flat_map(|&v| [2 * v, 2 * v + 1]).collect();
                Analysis::with_order(&matrix, &blocks)?
            }
            None => Analysis::new(&matrix)?,
        };
        let solver = SpdSolver::with_analysis(analysis, &matrix)?;
        let rhs = RhsParts::new(mesh, cut, global, rots, disk, &q, &fixed);
        Ok(ConstrainedStep {
            mesh,
            cut,
            global,
            rots,
            disk,
            q,
            fixed: fixed.iter().map(Option::is_some).collect(),
            solver,
            rhs,
        })
    }

    /// The map for gaps `w` and constraints `fixes`; `fixes` must fix what the ones this step
    /// was factored for fix (values may differ), otherwise the step is factored afresh.
    pub(crate) fn solve(
        &self,
        w: &[[f64; 2]],
        fixes: &BTreeMap<usize, VertexFix>,
    ) -> Result<(Vec<[f64; 2]>, MapSpace), ParamError> {
        let (mesh, cut, global, rots) = (self.mesh, self.cut, self.global, self.rots);
        let (q, fixed) = layout(mesh, cut, global, rots, fixes);
        if q != self.q
            || fixed
                .iter()
                .map(Option::is_some)
                .ne(self.fixed.iter().copied())
        {
            return ConstrainedStep::new(mesh, cut, global, rots, self.disk, fixes)?
                .solve(w, fixes);
        }
        let nv = mesh.n_vertices();
        let var_of = |c: usize| -> Option<usize> {
            let v = mesh.from(c);
            (!cut.singular[v]).then_some(v)
        };
        let consts: Vec<[f64; 2]> = global.corner_lin.iter().map(|l| l.eval(w)).collect();
        let rhs = self.rhs.assemble(mesh, cut, &consts, &fixed);
        let y = self.solver.solve(&rhs)?;
        let uv = (0..3 * mesh.n_faces())
            .map(|c| {
                let mut p = consts[c];
                if let Some(v) = var_of(c) {
                    let x = apply(&q[v], [y[2 * v], y[2 * v + 1]]);
                    let x = apply(rots.get(global.corner_rot[c] as i64), x);
                    p[0] += x[0];
                    p[1] += x[1];
                }
                p
            })
            .collect();
        // The maps the repair may move within: the same unknowns, the fixed components held.
        let space = MapSpace {
            var: (0..3 * mesh.n_faces())
                .map(|c| var_of(c).map_or(NONE, |v| v as u32))
                .collect(),
            consts,
            rot: global.corner_rot.clone(),
            basis: q,
            free: (0..nv)
                .map(|v| [fixed[2 * v].is_none(), fixed[2 * v + 1].is_none()])
                .collect(),
        };
        Ok((uv, space))
    }
}

impl RhsParts {
    fn new(
        mesh: &TriMesh,
        cut: &CutGraph,
        global: &GlobalSystem,
        rots: &Rots,
        disk: &[[DVec3; 2]],
        q: &[M2],
        fixed: &[Option<f64>],
    ) -> Self {
        let targets = GlobalSystem::targets(mesh, disk);
        let stiffness: Vec<[[f64; 3]; 3]> =
            (0..mesh.n_faces()).map(|f| stiffness(mesh, f)).collect();
        let mut rhs = vec![0.0; fixed.len()];
        let mut to_row = vec![[0.0; 4]; 3 * mesh.n_faces()];
        let mut coupling = Vec::new();
        for (f, k) in stiffness.iter().enumerate() {
            for a in 0..3 {
                let ca = 3 * f + a;
                let va = mesh.from(ca);
                if cut.singular[va] {
                    continue;
                }
                let ra = global.corner_rot[ca] as i64;
                to_row[ca] = mul(&transpose(&q[va]), rots.get(-ra));
                let r = apply(&to_row[ca], targets[ca]);
                for i in 0..2 {
                    if fixed[2 * va + i].is_none() {
                        rhs[2 * va + i] += r[i];
                    }
                }
                corner_entries(mesh, cut, global, rots, q, fixed, k, ca, |r, c, v| {
                    if fixed[c].is_some() {
                        coupling.push((r as u32, c as u32, v));
                    }
                });
            }
        }
        RhsParts {
            targets: rhs,
            stiffness,
            to_row,
            coupling,
        }
    }

    /// The right-hand side for the corners' constants `consts` and the fixed values `fixed`
    /// (whose pattern is the one these parts were made for).
    fn assemble(
        &self,
        mesh: &TriMesh,
        cut: &CutGraph,
        consts: &[[f64; 2]],
        fixed: &[Option<f64>],
    ) -> Vec<f64> {
        let mut rhs: Vec<f64> = fixed
            .iter()
            .zip(&self.targets)
            .map(|(f, t)| f.unwrap_or(*t))
            .collect();
        for (f, k) in self.stiffness.iter().enumerate() {
            for a in 0..3 {
                let ca = 3 * f + a;
                let va = mesh.from(ca);
                if cut.singular[va] {
                    continue;
                }
                // − Q_aᵀ R^{−rot_a} Σ_b k_ab c_b
                let mut r = [0.0; 2];
                for bb in 0..3 {
                    let c = consts[3 * f + bb];
                    r[0] += k[a][bb] * c[0];
                    r[1] += k[a][bb] * c[1];
                }
                let r = apply(&self.to_row[ca], r);
                for i in 0..2 {
                    if fixed[2 * va + i].is_none() {
                        rhs[2 * va + i] -= r[i];
                    }
                }
            }
        }
        // Fixed columns move to the right-hand side.
        for &(r, c, v) in &self.coupling {
            if let Some(y) = fixed[c as usize] {
                rhs[r as usize] -= v * y;
            }
        }
        rhs
    }
}

/// Replaces the unconstrained step's pins (one vertex per translation-invariant component)
/// by what the lines leave free: nothing when they fix both directions, the direction along
/// them when all are parallel, both when there are none.
fn pin_translations(
    mesh: &TriMesh,
    cut: &CutGraph,
    global: &GlobalSystem,
    rots: &Rots,
    fixes: &mut BTreeMap<usize, VertexFix>,
) {
    let comp = |v: usize| cut.comp_of_face[mesh.face_of(mesh.vertex_halfedge(v))] as usize;
    // On such a component every transition is a translation, so the corners of a vertex share
    // one rotation: 0, or the turn of its frame to the gauge of the system this one updates.
    // R^{rot} turns a vertex-frame normal into the common frame where normals compare.
    let rot_of = |v: usize| global.corner_rot[mesh.vertex_halfedge(v)] as i64;
    for p in 0..mesh.n_vertices() {
        if cut.singular[p] || global.corner_var[mesh.vertex_halfedge(p)] != NONE {
            continue;
        }
        // p is the pinned vertex of its component.
        let c = comp(p);
        let mut first: Option<[f64; 2]> = None;
        let mut spans_two = false;
        for (&v, fix) in fixes.iter() {
            if comp(v) != c {
                continue;
            }
            match *fix {
                VertexFix::Both { .. } => spans_two = true,
                VertexFix::One { m, .. } => {
                    let m = apply(rots.get(rot_of(v)), m);
                    match first {
                        None => first = Some(m),
                        Some(m0) if (m0[0] * m[0] + m0[1] * m[1]).abs() < 1.0 - 1e-6 => {
                            spans_two = true
                        }
                        _ => {}
                    }
                }
            }
        }
        if spans_two {
            continue;
        }
        let pin = match (first, fixes.get(&p).copied()) {
            (None, _) => VertexFix::Both { x: [0.0, 0.0] },
            // x = value m (+ 0 along the line), in p's own frame.
            (Some(_), Some(VertexFix::One { m, value })) => VertexFix::Both {
                x: [value * m[0], value * m[1]],
            },
            (Some(m0), _) => {
                let m = apply(rots.get(-rot_of(p)), m0);
                VertexFix::One {
                    m: [-m[1], m[0]],
                    value: 0.0,
                }
            }
        };
        fixes.insert(p, pin);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn far(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1]))
            .fold(0.0, f64::max)
    }

    /// Without constraints the real 2 × 2-block step is the complex global step (the same
    /// energy, the same pin); with them, the fixed components hold at every corner, and the map
    /// is affine in the gaps and the fixed values, on the one factorization (what the windings'
    /// ranking relies on when it solves a step and its mirror image once).
    #[test]
    fn the_constrained_step_is_the_global_step_under_its_fixes() {
        let (mesh, qc, local) = crate::param::sphere_with_gaps();
        let (cut, global, rots) = (&qc.cut, &qc.global, &qc.rots);
        let free = BTreeMap::new();
        let (uv, _) = solve(&mesh, cut, global, rots, &local.disk, &local.gaps, &free).unwrap();
        let plain = qc.global_uv(&mesh, &local, &local.gaps).unwrap();
        let gap = far(&uv, &plain);
        assert!(gap < 1e-9, "unconstrained: {gap}");

        // One component fixed at a few regular vertices, both at one.
        let regular: Vec<usize> = (0..mesh.n_vertices())
            .filter(|&v| !cut.singular[v])
            .collect();
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let mut fixes = BTreeMap::new();
        for (i, &v) in regular.iter().step_by(37).take(6).enumerate() {
            let m = if i % 2 == 0 { [1.0, 0.0] } else { [s, s] };
            fixes.insert(
                v,
                VertexFix::One {
                    m,
                    value: i as f64 * 0.5 - 1.0,
                },
            );
        }
        let both = regular[regular.len() / 2];
        fixes.insert(both, VertexFix::Both { x: [0.25, -0.5] });
        let step = ConstrainedStep::new(&mesh, cut, global, rots, &local.disk, &fixes).unwrap();
        let (uv, _) = step.solve(&local.gaps, &fixes).unwrap();
        // In a corner's vertex frame: R^{−rot}(uv − c).
        let consts: Vec<[f64; 2]> = global
            .corner_lin
            .iter()
            .map(|l| l.eval(&local.gaps))
            .collect();
        let frame_x = |c: usize| -> [f64; 2] {
            let d = [uv[c][0] - consts[c][0], uv[c][1] - consts[c][1]];
            apply(rots.get(-(global.corner_rot[c] as i64)), d)
        };
        for (&v, fix) in &fixes {
            for c in mesh.outgoing(v) {
                let x = frame_x(c);
                match *fix {
                    VertexFix::One { m, value } => {
                        let got = m[0] * x[0] + m[1] * x[1];
                        assert!((got - value).abs() < 1e-9, "vertex {v}: {got} ≠ {value}");
                    }
                    VertexFix::Both { x: want } => {
                        let d = (x[0] - want[0]).hypot(x[1] - want[1]);
                        assert!(d < 1e-9, "vertex {v}: {x:?} ≠ {want:?}");
                    }
                }
            }
        }
        // The constraints move the map.
        assert!(far(&uv, &plain) > 0.1, "{}", far(&uv, &plain));

        // Affine: a step and its mirror image move the map by opposite amounts.
        let mut up = local.gaps.clone();
        let mut down = local.gaps.clone();
        up[1][0] += 1.0;
        down[1][0] -= 1.0;
        let moved = |fixes: &BTreeMap<usize, VertexFix>, by: f64| {
            let mut f = fixes.clone();
            if let Some(VertexFix::One { value, .. }) = f.values_mut().next() {
                *value += by;
            }
            f
        };
        let (a, _) = step.solve(&up, &moved(&fixes, 1.0)).unwrap();
        let (b, _) = step.solve(&down, &moved(&fixes, -1.0)).unwrap();
        let mid: Vec<[f64; 2]> = a
            .iter()
            .zip(&b)
            .map(|(p, q)| [(p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0])
            .collect();
        assert!(far(&a, &uv) > 0.1, "the step moves nothing");
        let gap = far(&mid, &uv);
        assert!(gap < 1e-9, "not affine: {gap}");
    }
}

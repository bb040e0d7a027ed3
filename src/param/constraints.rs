//! QuadCover with constraints (thesis sec. 4.4.1, alg. 7).
//!
//! Each curve δ_κ is traced over the faces on its left side (the reversed curve's when the
//! left side is not complete, e.g. along a boundary), composing the transitions of every edge
//! crossed, so the chart of the first face maps to the chart of every later one. In the first
//! face, one line family λ (normal n_λ of a lattice line) and the value c_κ (an integer, in
//! units of the line spacing s) give the line n_λᵀφ = s c_κ (eq. 4.5); in a later face it reads
//! (R^ρ n_λ)ᵀφ = s c_κ + (R^ρ n_λ)ᵀ t(W) (eq. 4.6). λ is the family along which the field
//! runs along the curve; c_κ is the average of the local step's values on the curve.
//!
//! At a regular vertex the line is a linear equation in the vertex's unknown (eq. 4.7, C_g); at
//! a branch point, whose value eq. 2.40 fixes by the gaps, and wherever a vertex is met twice
//! by lines of one family (curves meeting each other or themselves, a closed curve closing),
//! it is an integer equation in the gaps and the c_κ (eq. 4.8, 4.9, C_c). The integer unknowns
//! are the gaps' lattice coordinates and the c_κ; they are rounded to the nearest solution of
//! C_c w = 0 ([`super::integer`]); the global step then runs with the geometric equations
//! eliminated ([`super::constrained`]).
//!
//! A geometric curve is split into runs where the field's line family along it changes (the
//! curve turns a grid corner there, at a regular vertex or a branch point; runs shorter than
//! half a cell join their neighbours). Contradictions are reported with the curves involved: a
//! closed curve whose line family turns on the way round (the singularities it encloses rotate
//! the lattice: it cannot close as one line), a curve along the boundary with the surface on
//! either side in turn.

use std::collections::BTreeMap;

use glam::DVec3;

use super::ParamError;
use super::cut::{CutGraph, NONE, step};
use super::global::GlobalSystem;
use super::rot::{Aff, Lattice, Lin, Rots, apply, transpose};
use crate::mesh::TriMesh;

mod off_lines;
pub(crate) use off_lines::Breaks;

/// A constraint curve as QuadCover takes it: mesh vertices (consecutive ones sharing an edge,
/// the first not repeated when `closed`).
#[derive(Clone, Copy, Debug)]
pub struct ConstraintCurve<'a> {
    pub id: u32,
    pub vertices: &'a [usize],
    pub closed: bool,
    /// A parameter line runs exactly along it (otherwise only the layout is prescribed).
    pub geometric: bool,
}

/// How a solved curve sits in the map.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CurveFit {
    pub id: u32,
    pub geometric: bool,
    /// Line family λ in the first face's chart (0..N/2 for N = 4, 6; 0, 1 for N = 2).
    pub family: u8,
    /// The line's value s·c_κ in the first face's chart.
    pub value: f64,
    /// Largest |n·φ − value| over the curve's vertices in the final map (0 up to rounding for
    /// geometric curves; how far the map is from the curve for combinatorial ones).
    pub max_offset: f64,
    /// Branch points on the curve.
    pub singular_vertices: Vec<usize>,
    /// Vertices the line does not hold: tips of ears (a vertex whose two neighbours on the
    /// curve share a face with it), which one line through all three would fold.
    pub ear_tips: Vec<usize>,
}

/// Largest factor the equations' rational coefficients need to become integers (branch points
/// sit on (1/2)Z², (1/3)-points of G6, ...).
const DENOMINATOR: f64 = 12.0;

/// Line normals n_λ, the line spacing s and the lattice basis L (columns) of a symmetry.
pub(crate) struct Lines {
    pub normals: Vec<[f64; 2]>,
    pub spacing: f64,
    pub basis: [[f64; 2]; 2],
}

impl Lines {
    pub fn new(lattice: Lattice) -> Lines {
        match lattice {
            Lattice::G6 => {
                let s3 = 3f64.sqrt();
                let normals = (0..3)
                    .map(|l| {
                        let a = std::f64::consts::FRAC_PI_2 + std::f64::consts::PI * l as f64 / 3.0;
                        [a.cos(), a.sin()]
                    })
                    .collect();
                Lines {
                    normals,
                    spacing: s3 / 2.0,
                    basis: [[1.0, 0.0], [0.5, s3 / 2.0]],
                }
            }
            Lattice::D2 => Lines {
                normals: vec![[1.0, 0.0], [0.0, 1.0]],
                spacing: 1.0,
                basis: [[1.0, 1.0], [1.0, -1.0]],
            },
            _ => {
                let scale = if lattice == Lattice::TwoZ2 { 2.0 } else { 1.0 };
                Lines {
                    normals: vec![[1.0, 0.0], [0.0, 1.0]],
                    spacing: 1.0,
                    basis: [[scale, 0.0], [0.0, scale]],
                }
            }
        }
    }
    /// Lattice coordinates of a gap vector.
    pub fn coords(&self, w: [f64; 2]) -> [f64; 2] {
        let [[a, c], [b, d]] = self.basis; // columns (a, c), (b, d)
        let det = a * d - b * c;
        [(d * w[0] - b * w[1]) / det, (-c * w[0] + a * w[1]) / det]
    }
    pub fn vector(&self, a: [f64; 2]) -> [f64; 2] {
        let [g1, g2] = self.basis;
        [a[0] * g1[0] + a[1] * g2[0], a[0] * g1[1] + a[1] * g2[1]]
    }
}

/// A linear form in the integer unknowns (gap coordinates 2k, 2k + 1; curve values 2K + κ),
/// in units of the line spacing.
type Form = BTreeMap<usize, f64>;

fn form_add(a: &mut Form, b: &Form, f: f64) {
    for (&k, &v) in b {
        *a.entry(k).or_insert(0.0) += f * v;
    }
}

fn eval(form: &Form, w: &[f64]) -> f64 {
    form.iter().map(|(&k, &v)| v * w[k]).sum()
}

/// nᵀ lin(W) / s as a form in the gaps' lattice coordinates.
fn lin_form(lin: &Lin, n: [f64; 2], lines: &Lines) -> Form {
    let mut f = Form::new();
    for (k, m) in &lin.0 {
        // nᵀ M L e_j
        let mt_n = apply(&transpose(m), n);
        for (j, g) in lines.basis.iter().enumerate() {
            let v = (mt_n[0] * g[0] + mt_n[1] * g[1]) / lines.spacing;
            if v.abs() > 1e-12 {
                *f.entry(2 * *k as usize + j).or_insert(0.0) += v;
            }
        }
    }
    f
}

/// One point of a curve where its line constrains the map: corner `h` (a halfedge leaving
/// `vertex`, in the face whose chart `chart` reaches from the first face).
struct Emit {
    vertex: usize,
    corner: usize,
    chart: Aff,
    /// The closing visit of a closed curve's first vertex.
    closing: bool,
}

/// One curve edge as the field maps it: the face's chart and the edge's image there.
struct EdgeImage {
    chart_rot: u8,
    d: [f64; 2],
}

struct Walk {
    emits: Vec<Emit>,
    edges: Vec<EdgeImage>,
}

/// The frames a curve's line family is read from (in the disk frames).
#[derive(Clone, Copy)]
pub(crate) enum FamilyFrames<'a> {
    /// The field's, which the design runs along every curve in one of its directions (N = 4,
    /// 6). Not the local step's curl*-free frames: those leave the field next to singularities,
    /// turned by up to 120° along a short crease between two of them, and a curve read through
    /// them was split where the field runs straight along it.
    Field(&'a [[DVec3; 2]]),
    /// The curl*-free ones, for N = 2: its design holds U along every curve (modulo π), also
    /// along two creases meeting at a right angle, so the field turns by 90° in the corner and
    /// every curve comes out on the one family; the curl*-free frames, closer to the map the
    /// global step makes, put such curves on the two families (fandisk with features at 40°:
    /// 368 folded faces after the repair with them, 5404 with the field's). Their runs are
    /// joined to their neighbours only when short ([`SHORT_RUN`]), not for a slight turn
    /// ([`SLIGHT_TURN`]; 1414 folds with it).
    CurlFree(&'a [[DVec3; 2]]),
}

impl<'a> FamilyFrames<'a> {
    fn frames(self) -> &'a [[DVec3; 2]] {
        match self {
            FamilyFrames::Field(f) | FamilyFrames::CurlFree(f) => f,
        }
    }

    fn is_field(self) -> bool {
        matches!(self, FamilyFrames::Field(_))
    }
}

/// Traces a curve over the faces on its left; `None` if some are missing (boundary).
fn walk_left(
    mesh: &TriMesh,
    cut: &CutGraph,
    rots: &Rots,
    frames: &[[DVec3; 2]],
    verts: &[usize],
    closed: bool,
) -> Option<Walk> {
    let mut seq: Vec<usize> = verts.to_vec();
    if closed {
        seq.push(verts[0]);
    }
    let hs: Vec<usize> = seq
        .windows(2)
        .map(|w| mesh.halfedge_to(w[0], w[1]))
        .collect::<Option<_>>()?;
    let mut chart = Aff::default();
    let mut emits = vec![Emit {
        vertex: seq[0],
        corner: hs[0],
        chart: chart.clone(),
        closing: false,
    }];
    let mut edges = Vec::with_capacity(hs.len());
    // The edge's image under the frames the family is read from ([`FamilyFrames`]): which
    // family the field runs along here.
    let image = |h: usize, chart: &Aff| {
        let (x, e) = (&frames[mesh.face_of(h)], mesh.vector(h));
        EdgeImage {
            chart_rot: chart.rot,
            d: [x[0].dot(e), x[1].dot(e)],
        }
    };
    edges.push(image(hs[0], &chart));
    for i in 0..hs.len() {
        let g0 = mesh.next(hs[i]);
        let b = seq[i + 1];
        let last = i + 1 == hs.len();
        emits.push(Emit {
            vertex: b,
            corner: g0,
            chart: chart.clone(),
            closing: last && closed,
        });
        if last {
            break;
        }
        // Clockwise around b from the face left of a -> b to the face left of b -> c.
        let mut g = g0;
        let mut guard = 0;
        while g != hs[i + 1] {
            let t = mesh.twin(g)?;
            let c = mesh.edge(g);
            chart = step(mesh, &cut.transitions[c], c, mesh.face_of(g), rots).after(&chart, rots);
            g = mesh.next(t);
            guard += 1;
            if guard > 10_000 {
                return None;
            }
        }
        edges.push(image(hs[i + 1], &chart));
    }
    Some(Walk { emits, edges })
}

/// A vertex-frame line through a regular vertex: mᵀx_v = s·form.
struct VertexLine {
    curve: usize,
    geometric: bool,
    m: [f64; 2],
    form: Form,
}

/// The traced constraints of a set of curves, ready for rounding and the global step.
pub(crate) struct Traced {
    lines: Lines,
    n_gaps: usize,
    /// Integer equations (scaled by [`DENOMINATOR`]) with the curves (indices) behind each.
    rows: Vec<(IntRow, Vec<usize>)>,
    /// Per regular vertex its lines (geometric ones constrain the global step).
    at_vertex: BTreeMap<usize, Vec<VertexLine>>,
    /// Per curve the measured value c_κ and its family.
    measured_c: Vec<f64>,
    family: Vec<u8>,
    ids: Vec<u32>,
    geometric: Vec<bool>,
    singular_on: Vec<Vec<usize>>,
    /// Per curve: (vertex, corner, chart) of every emission, to report the fit.
    emits: Vec<Vec<(usize, usize, Aff)>>,
    /// Per curve its ear tips ([`is_ear_tip`]), which its line does not hold.
    ears: Vec<Vec<usize>>,
    /// The reduced lattice basis of C_c w = 0 over [`Traced::involved`] (computed once: the
    /// re-rounding rounds many targets under the same equations).
    kernel: std::sync::OnceLock<Result<Vec<Vec<i128>>, String>>,
    /// Branch points beside geometric lines they are not on ([`off_lines`]).
    guards: Vec<off_lines::Guard>,
    /// Corners beside the lines of geometric curves less than two cells away, never mended
    /// ([`Traced::collapsed_strips`]); only on 2Z².
    corner_guards: Vec<off_lines::Guard>,
    /// Whether [`Traced::round`] mends the guards (quads, [`Breaks::Across`]); with N = 6 only
    /// [`Traced::off_lines_try`] does, on request.
    mend_in_round: bool,
}

/// Whether the vertex at position `i` of a piece is the tip of an ear: it and its two
/// neighbours on the piece are the corners of one face (a scanned boundary's notch, a drawn
/// curve around a single triangle). One line through all three corners would give that face
/// zero area, a fold no motion of the other vertices undoes; the tip is left off the line
/// instead, and the line runs along the face's third edge.
fn is_ear_tip(mesh: &TriMesh, verts: &[usize], closed: bool, i: usize) -> bool {
    let nv = verts.len();
    let (prev, next) = if closed {
        (verts[(i + nv - 1) % nv], verts[(i + 1) % nv])
    } else if i > 0 && i + 1 < nv {
        (verts[i - 1], verts[i + 1])
    } else {
        return false;
    };
    let m = verts[i];
    nv >= 3
        && prev != next
        && mesh.outgoing(m).any(|h| {
            let f = mesh.face(mesh.face_of(h));
            f.contains(&prev) && f.contains(&next)
        })
}

/// The sign nᵀ(φ − φ_q) takes in `corner`'s face off the line through its vertex q (normal
/// `n`), on the local step's map: the face's vertex farthest from the line decides (the other
/// is q's neighbour on the curve).
fn left_sign(mesh: &TriMesh, uv: &[[f64; 2]], corner: usize, n: [f64; 2]) -> f64 {
    let q = uv[corner];
    let off = |c: usize| n[0] * (uv[c][0] - q[0]) + n[1] * (uv[c][1] - q[1]);
    let (a, b) = (off(mesh.next(corner)), off(mesh.prev(corner)));
    if a.abs() > b.abs() {
        a.signum()
    } else {
        b.signum()
    }
}

/// An integer equation Σ a_k w_k = 0, sparse.
type IntRow = Vec<(usize, i128)>;

/// A constraint of the global step on a regular vertex's unknown x_v (vertex frame).
#[derive(Clone, Copy, Debug)]
pub(crate) enum VertexFix {
    /// mᵀx = value.
    One { m: [f64; 2], value: f64 },
    /// x = value.
    Both { x: [f64; 2] },
}

fn contradiction(ids: &[u32], curves: &[usize], message: String) -> ParamError {
    let mut c: Vec<u32> = curves.iter().map(|&i| ids[i]).collect();
    c.sort_unstable();
    c.dedup();
    ParamError::Contradiction { curves: c, message }
}

fn names(ids: &[u32], curves: &[usize]) -> String {
    let mut c: Vec<u32> = curves.iter().map(|&i| ids[i]).collect();
    c.sort_unstable();
    c.dedup();
    let list: Vec<String> = c.iter().map(|i| i.to_string()).collect();
    if c.len() == 1 {
        format!("curve {}", list[0])
    } else {
        format!("curves {}", list.join(", "))
    }
}

impl Traced {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        mesh: &TriMesh,
        cut: &CutGraph,
        rots: &Rots,
        lattice: Lattice,
        global: &GlobalSystem,
        families: FamilyFrames,
        local_uv: &[[f64; 2]],
        measured_gaps: &[[f64; 2]],
        curves: &[ConstraintCurve],
    ) -> Result<Traced, ParamError> {
        let lines = Lines::new(lattice);
        let n_gaps = measured_gaps.len();
        let curve_ids: Vec<u32> = curves.iter().map(|c| c.id).collect();
        let pieces = split_by_family(mesh, cut, rots, &lines, families, curves, &curve_ids)?;
        let frames = families.frames();
        let ids: Vec<u32> = pieces.iter().map(|p| curves[p.curve].id).collect();
        let w_measured: Vec<f64> = measured_gaps
            .iter()
            .flat_map(|&g| lines.coords(g))
            .collect();
        let mut out = Traced {
            lines,
            n_gaps,
            rows: Vec::new(),
            at_vertex: BTreeMap::new(),
            measured_c: Vec::new(),
            family: Vec::new(),
            ids: ids.clone(),
            geometric: pieces.iter().map(|p| curves[p.curve].geometric).collect(),
            singular_on: Vec::new(),
            emits: Vec::new(),
            ears: Vec::new(),
            kernel: std::sync::OnceLock::new(),
            guards: Vec::new(),
            corner_guards: Vec::new(),
            mend_in_round: lattice != Lattice::G6,
        };
        // The guards keeping branch points off the lines beside them ([`off_lines`]): for
        // quads mended in every rounding; with N = 6 (three line families) only in the tries
        // a map that keeps folds is given (`QuadCover::solve_curves`): mended in every
        // rounding they took folds away on some CAD parts and added them on others (the cross
        // plate 117 → 132, a T-shaped prism at 20 000 vertices 0 → 13, docs/untangling.md).
        // Stripes (N = 2) keep their folds for other reasons.
        let guarded = families.is_field();
        let mut lines_at: Vec<off_lines::LineAt> = Vec::new();
        // Per curve: forms at its emissions.
        let mut fixed_rows: Vec<(Form, usize)> = Vec::new();
        for (ci, piece) in pieces.iter().enumerate() {
            let c = ConstraintCurve {
                vertices: &piece.vertices,
                closed: piece.closed,
                ..curves[piece.curve]
            };
            let walk = walk_left(mesh, cut, rots, frames, c.vertices, c.closed)
                .expect("split_by_family oriented the piece");
            let lines = &out.lines;
            // The family along which the field runs along the curve.
            let family_cost = |l: usize| -> f64 {
                walk.edges
                    .iter()
                    .map(|e| {
                        let n = apply(rots.get(e.chart_rot as i64), lines.normals[l]);
                        (n[0] * e.d[0] + n[1] * e.d[1]).abs()
                    })
                    .sum()
            };
            let lambda = (0..lines.normals.len())
                .min_by(|&a, &b| family_cost(a).total_cmp(&family_cost(b)))
                .expect("a family");
            let n0 = lines.normals[lambda];
            let cvar = 2 * n_gaps + ci;
            let mut c_sum = 0.0;
            let mut start_m: Option<[f64; 2]> = None;
            let mut singular_on = Vec::new();
            let mut emits = Vec::new();
            let mut ears = Vec::new();
            let nv = c.vertices.len();
            for (i, e) in walk.emits.iter().enumerate() {
                let n = apply(rots.get(e.chart.rot as i64), n0);
                // Value of the line in this chart: s c + nᵀ t(W).
                let mut form = lin_form(&e.chart.lin, n, lines);
                *form.entry(cvar).or_insert(0.0) += 1.0;
                if guarded && c.geometric && !e.closing {
                    lines_at.push(off_lines::LineAt {
                        face: mesh.face_of(e.corner),
                        piece: ci,
                        n,
                        line: form.clone(),
                        left: left_sign(mesh, local_uv, e.corner, n),
                    });
                }
                // c estimate from the local map: nᵀψ/s − nᵀt(W*)/s.
                let psi = local_uv[e.corner];
                let mut tf = form.clone();
                tf.remove(&cvar);
                c_sum += (n[0] * psi[0] + n[1] * psi[1]) / lines.spacing
                    - eval_partial(&tf, &w_measured);
                emits.push((e.vertex, e.corner, e.chart.clone()));
                let v = e.vertex;
                if global.corner_var[e.corner] == NONE && cut.singular[v] {
                    // ψ = corner_lin(W) is fixed: nᵀψ/s = form (eq. 4.9 at a singularity).
                    let mut row = lin_form(&global.corner_lin[e.corner], n, lines);
                    form_add(&mut row, &form, -1.0);
                    fixed_rows.push((row, ci));
                    if !e.closing {
                        singular_on.push(v);
                    }
                    continue;
                }
                // Regular vertex: (R^{-rot} n)ᵀ x = s (form − nᵀ lin_h(W)/s).
                let m = apply(rots.get(-(global.corner_rot[e.corner] as i64)), n);
                form_add(
                    &mut form,
                    &lin_form(&global.corner_lin[e.corner], n, lines),
                    -1.0,
                );
                if e.closing
                    && let Some(m0) = start_m
                    && (m0[0] * m[0] + m0[1] * m[1]).abs() < 1.0 - 1e-6
                {
                    let turn = (m0[0] * m[1] - m0[1] * m[0])
                        .atan2(m0[0] * m[0] + m0[1] * m[1])
                        .to_degrees()
                        .round();
                    return Err(contradiction(
                        &ids,
                        &[ci],
                        format!(
                            "closed curve {} cannot close as one parameter line: its line family turns by {turn} degrees on the way round (the singularities it encloses)",
                            c.id
                        ),
                    ));
                }
                if start_m.is_none() {
                    start_m = Some(m);
                }
                if c.geometric && is_ear_tip(mesh, c.vertices, c.closed, i % nv) {
                    if !e.closing {
                        ears.push(v);
                    }
                    continue;
                }
                out.at_vertex.entry(v).or_default().push(VertexLine {
                    curve: ci,
                    geometric: c.geometric,
                    m,
                    form,
                });
            }
            out.measured_c.push(c_sum / walk.emits.len() as f64);
            out.family.push(lambda as u8);
            out.singular_on.push(singular_on);
            out.emits.push(emits);
            out.ears.push(ears);
        }
        (out.guards, out.corner_guards) = if !guarded {
            (Vec::new(), Vec::new())
        } else {
            let mut on_piece = vec![false; mesh.n_vertices()];
            let mut edge_piece = vec![NONE; mesh.n_edges()];
            for (ci, piece) in pieces.iter().enumerate() {
                if !curves[piece.curve].geometric {
                    continue;
                }
                let vs = &piece.vertices;
                for &v in vs {
                    on_piece[v] = true;
                }
                let closing = piece.closed.then(|| (vs[vs.len() - 1], vs[0]));
                for (a, b) in vs.windows(2).map(|w| (w[0], w[1])).chain(closing) {
                    if let Some(h) = mesh.halfedge_to(a, b) {
                        edge_piece[mesh.edge(h)] = ci as u32;
                    }
                }
            }
            let measured = out.target(measured_gaps);
            let ends: Vec<Vec<usize>> = pieces
                .iter()
                .map(
                    |p| match (p.closed, p.vertices.first(), p.vertices.last()) {
                        (false, Some(&a), Some(&b)) => vec![a, b],
                        _ => Vec::new(),
                    },
                )
                .collect();
            let guards = |corners: bool| {
                off_lines::guards(
                    mesh,
                    cut,
                    global,
                    &out.lines,
                    frames,
                    &on_piece,
                    &edge_piece,
                    &lines_at,
                    &ends,
                    &measured,
                    corners,
                )
            };
            // Only the 2Z² rounding puts corners on even lattice points ([`off_lines`]).
            let corner_guards = if lattice == Lattice::TwoZ2 {
                guards(true)
            } else {
                Vec::new()
            };
            (guards(false), corner_guards)
        };
        // Integer equations: fixed values on lines, and lines of one family meeting.
        let mut rows: Vec<(Form, Vec<usize>)> =
            fixed_rows.into_iter().map(|(f, c)| (f, vec![c])).collect();
        for lines_v in out.at_vertex.values() {
            let mut basis: Vec<usize> = Vec::new();
            for (i, l) in lines_v.iter().enumerate() {
                let parallel = basis.iter().copied().find(|&b| {
                    let mb = lines_v[b].m;
                    (mb[0] * l.m[0] + mb[1] * l.m[1]).abs() > 1.0 - 1e-6
                });
                if let Some(b) = parallel {
                    let mb = lines_v[b].m;
                    let sign = (mb[0] * l.m[0] + mb[1] * l.m[1]).signum();
                    let mut row = l.form.clone();
                    form_add(&mut row, &lines_v[b].form, -sign);
                    rows.push((row, vec![l.curve, lines_v[b].curve]));
                } else if basis.len() < 2 {
                    basis.push(i);
                } else {
                    // A third family (N = 6): m = α m1 + β m2, so form = α form1 + β form2.
                    let (m1, m2) = (lines_v[basis[0]].m, lines_v[basis[1]].m);
                    let det = m1[0] * m2[1] - m1[1] * m2[0];
                    let alpha = (l.m[0] * m2[1] - l.m[1] * m2[0]) / det;
                    let beta = (m1[0] * l.m[1] - m1[1] * l.m[0]) / det;
                    let mut row = l.form.clone();
                    form_add(&mut row, &lines_v[basis[0]].form, -alpha);
                    form_add(&mut row, &lines_v[basis[1]].form, -beta);
                    rows.push((
                        row,
                        vec![l.curve, lines_v[basis[0]].curve, lines_v[basis[1]].curve],
                    ));
                }
            }
        }
        for (row, curves_of) in rows {
            let mut int_row = Vec::new();
            for (k, v) in row {
                let scaled = v * DENOMINATOR;
                let r = scaled.round();
                if (scaled - r).abs() > 1e-6 {
                    return Err(ParamError::InvalidInput(format!(
                        "{}: a constraint coefficient {v} is not a multiple of 1/{DENOMINATOR}",
                        names(&ids, &curves_of)
                    )));
                }
                if r != 0.0 {
                    int_row.push((k, r as i128));
                }
            }
            if !int_row.is_empty() {
                out.rows.push((int_row, curves_of));
            }
        }
        Ok(out)
    }

    /// The integer unknowns after rounding: gaps (lattice vectors) and line values s·c_κ.
    /// `rounded` are the gaps as the plain rounding left them; unknowns in no equation keep
    /// those (and c_κ its nearest integer), the rest take the nearest solution of C_c w = 0.
    /// `hessian` is the energy's dependence on the gaps ([`GlobalSystem::gap_hessian`] on
    /// [`Traced::metric_gap_components`]): the rounding is nearest in its metric (the gaps that cost least energy give way), the c_κ,
    /// which the energy does not see, follow.
    pub fn round(
        &self,
        measured: &[[f64; 2]],
        rounded: &[[f64; 2]],
        hessian: &[f64],
    ) -> Result<(Vec<[f64; 2]>, Vec<f64>), ParamError> {
        let ng = self.n_gaps;
        let mut w: Vec<f64> = rounded
            .iter()
            .flat_map(|&g| self.lines.coords(g).map(f64::round))
            .chain(self.measured_c.iter().map(|c| c.round()))
            .collect();
        let target = self.target(measured);
        let (involved, rows) = self.involved();
        if !involved.is_empty() {
            let t: Vec<f64> = involved.iter().map(|&k| target[k]).collect();
            let metric =
                super::integer::sparse_rows(&self.metric(hessian, &involved), involved.len());
            let sol = self
                .kernel(&rows, involved.len())
                .and_then(|basis| {
                    super::integer::nearest_in_lattice(basis, involved.len(), &t, Some(&metric))
                })
                .map_err(|why| {
                    let all: Vec<usize> = (0..self.ids.len()).collect();
                    contradiction(
                        &self.ids,
                        &all,
                        format!("{}: {why}", names(&self.ids, &all)),
                    )
                })?;
            for (i, &k) in involved.iter().enumerate() {
                w[k] = sol[i] as f64;
            }
        }
        if self.mend_in_round {
            self.keep_off_lines(&mut w, &target, Breaks::Across);
        }
        let gaps = (0..ng)
            .map(|k| self.lines.vector([w[2 * k], w[2 * k + 1]]))
            .collect();
        Ok((gaps, w))
    }

    /// The measured values of the integer unknowns: `measured` gaps in lattice coordinates,
    /// then the line values.
    fn target(&self, measured: &[[f64; 2]]) -> Vec<f64> {
        measured
            .iter()
            .flat_map(|&g| self.lines.coords(g))
            .chain(self.measured_c.iter().copied())
            .collect()
    }

    /// With N = 6: the rounded unknowns `w` with the guards `breaks` breaks mended
    /// ([`off_lines`]); `None` when it breaks none, none could be mended, or the guards are
    /// mended in every rounding already (quads). `measured`: the local step's gaps.
    pub fn off_lines_try(
        &self,
        w: &[f64],
        measured: &[[f64; 2]],
        breaks: Breaks,
    ) -> Option<Vec<f64>> {
        if self.mend_in_round {
            return None;
        }
        let mut mended = w.to_vec();
        self.keep_off_lines(&mut mended, &self.target(measured), breaks);
        (mended != w).then_some(mended)
    }

    /// The reduced basis of the integer solutions of `rows` (those of [`Traced::involved`]),
    /// computed on first use.
    fn kernel(&self, rows: &[Vec<(usize, i128)>], n: usize) -> Result<&Vec<Vec<i128>>, String> {
        self.kernel
            .get_or_init(|| super::integer::reduced_kernel(rows, n))
            .as_ref()
            .map_err(Clone::clone)
    }

    /// The unknowns in some equation, and the equations over them renumbered in that order.
    fn involved(&self) -> (Vec<usize>, Vec<Vec<(usize, i128)>>) {
        let mut involved: Vec<usize> = self
            .rows
            .iter()
            .flat_map(|(r, _)| r.iter().map(|&(k, _)| k))
            .collect();
        involved.sort_unstable();
        involved.dedup();
        let local: BTreeMap<usize, usize> =
            involved.iter().enumerate().map(|(i, &k)| (k, i)).collect();
        let rows = self
            .rows
            .iter()
            .map(|(r, _)| r.iter().map(|&(k, a)| (local[&k], a)).collect())
            .collect();
        (involved, rows)
    }

    /// The solution of C_c w = 0 nearest to `w` with unknown `k` moved by `step`: the other
    /// gaps are held hard, the curve values c_κ give way first. `None` when no integer
    /// solution keeps the step (or the arithmetic overflows).
    pub fn stepped(&self, w: &[f64], k: usize, step: f64) -> Option<Vec<f64>> {
        let mut out = w.to_vec();
        out[k] += step;
        if self.holds(&out) {
            return Some(out);
        }
        let (involved, rows) = self.involved();
        let at = involved.iter().position(|&x| x == k)?;
        let m = 2 * self.n_gaps;
        let n = involved.len();
        // Diagonal: by its rows' single entries.
        let metric: Vec<Vec<(usize, f64)>> = involved
            .iter()
            .enumerate()
            .map(|(i, &x)| {
                let weight = if i == at {
                    1e8
                } else if x < m {
                    1e4
                } else {
                    1.0
                };
                vec![(i, weight)]
            })
            .collect();
        let t: Vec<f64> = involved.iter().map(|&x| out[x]).collect();
        let basis = self.kernel(&rows, n).ok()?;
        let sol = super::integer::nearest_in_lattice(basis, n, &t, Some(&metric)).ok()?;
        if sol[at] as f64 != out[k] {
            return None;
        }
        for (i, &x) in involved.iter().enumerate() {
            out[x] = sol[i] as f64;
        }
        Some(out)
    }

    /// The gap components the energy metric needs: both of every gap some equation involves
    /// (the lattice basis mixes them).
    pub fn metric_gap_components(&self) -> Vec<usize> {
        let m = 2 * self.n_gaps;
        let mut out: Vec<usize> = self
            .rows
            .iter()
            .flat_map(|(r, _)| r.iter().map(|&(k, _)| k))
            .filter(|&k| k < m)
            .flat_map(|k| [k & !1, k | 1])
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The energy metric on the involved unknowns in lattice coordinates: Lᵀ H L on gap pairs, a
    /// small weight on the c_κ, a small regularisation throughout. `hessian` is H on the
    /// components [`Traced::metric_gap_components`] gives.
    fn metric(&self, hessian: &[f64], involved: &[usize]) -> Vec<f64> {
        let m = 2 * self.n_gaps;
        let comps = self.metric_gap_components();
        let kc = comps.len();
        let at: BTreeMap<usize, usize> = comps.iter().enumerate().map(|(i, &c)| (c, i)).collect();
        let h = |a: usize, b: usize| -> f64 {
            match (at.get(&a), at.get(&b)) {
                (Some(&x), Some(&y)) if hessian.len() == kc * kc => hessian[x * kc + y],
                _ => 0.0,
            }
        };
        let n = involved.len();
        let l = self.lines.basis; // columns
        // In lattice coordinates: Σ_{r,c} L[r][i] H[2k+r][2q+c] L[c][j].
        let entry = |a: usize, b: usize| -> f64 {
            if a >= m || b >= m {
                return 0.0;
            }
            let (k, i) = (a / 2, a % 2);
            let (q, j) = (b / 2, b % 2);
            let mut s = 0.0;
            for r in 0..2 {
                for c in 0..2 {
                    s += l[i][r] * h(2 * k + r, 2 * q + c) * l[j][c];
                }
            }
            s
        };
        let mut out = vec![0.0; n * n];
        for (x, &a) in involved.iter().enumerate() {
            for (y, &b) in involved.iter().enumerate() {
                out[x * n + y] = entry(a, b);
            }
        }
        let trace: f64 = (0..n).map(|i| out[i * n + i]).sum::<f64>();
        let eps = 1e-6 * (trace / n.max(1) as f64).max(1e-12);
        for (x, &a) in involved.iter().enumerate() {
            out[x * n + x] += if a >= m { 1e-3 * eps.max(1e-9) } else { eps };
        }
        out
    }

    /// The global step's vertex constraints for the rounded unknowns `w` (lattice coordinates
    /// and c_κ, as [`Traced::round`] returns them).
    pub fn fixes(&self, w: &[f64]) -> BTreeMap<usize, VertexFix> {
        let s = self.lines.spacing;
        let mut out = BTreeMap::new();
        for (&v, lines_v) in &self.at_vertex {
            let geo: Vec<&VertexLine> = lines_v.iter().filter(|l| l.geometric).collect();
            let Some(first) = geo.first() else { continue };
            let second = geo
                .iter()
                .find(|l| (l.m[0] * first.m[0] + l.m[1] * first.m[1]).abs() < 1.0 - 1e-6);
            let a = s * eval(&first.form, w);
            let fix = match second {
                None => VertexFix::One {
                    m: first.m,
                    value: a,
                },
                Some(l2) => {
                    let b = s * eval(&l2.form, w);
                    let (m1, m2) = (first.m, l2.m);
                    let det = m1[0] * m2[1] - m1[1] * m2[0];
                    VertexFix::Both {
                        x: [(a * m2[1] - b * m1[1]) / det, (m1[0] * b - m2[0] * a) / det],
                    }
                }
            };
            out.insert(v, fix);
        }
        out
    }

    /// Whether the integer unknowns `w` (as [`Traced::round`] returns them) satisfy every
    /// combinatorial equation C_c w = 0 exactly.
    pub fn holds(&self, w: &[f64]) -> bool {
        self.rows.iter().all(|(row, _)| {
            row.iter()
                .map(|&(k, a)| a * w[k].round() as i128)
                .sum::<i128>()
                == 0
        })
    }

    /// Lattice coordinates of a gap vector (what `w` holds per gap).
    pub fn lattice_coords(&self, g: [f64; 2]) -> [f64; 2] {
        self.lines.coords(g)
    }

    /// The gaps (uv vectors) of the integer unknowns `w`.
    pub fn gaps(&self, w: &[f64]) -> Vec<[f64; 2]> {
        (0..self.n_gaps)
            .map(|k| self.lines.vector([w[2 * k], w[2 * k + 1]]))
            .collect()
    }

    /// The unknowns of the curve values c_κ whose lines hold `vertex` (indices into w), in
    /// curve order.
    pub fn value_unknowns_at(&self, vertex: usize) -> Vec<usize> {
        self.at_vertex.get(&vertex).map_or_else(Vec::new, |ls| {
            ls.iter()
                .filter(|l| l.geometric)
                .map(|l| 2 * self.n_gaps + l.curve)
                .collect()
        })
    }

    /// [`Traced::fixes`] at unknowns 0: which components the geometric curves fix and along
    /// which normals, all that the constrained step's matrix depends on.
    pub fn fix_pattern(&self) -> BTreeMap<usize, VertexFix> {
        self.fixes(&vec![0.0; 2 * self.n_gaps + self.measured_c.len()])
    }

    pub fn has_geometric(&self) -> bool {
        self.at_vertex
            .values()
            .any(|ls| ls.iter().any(|l| l.geometric))
    }

    /// A solver failure of the global step under the geometric curves, as an error naming them
    /// (the editor draws them red and keeps the last good result; the CLI names them). Other
    /// errors pass through.
    pub fn name_failure(&self, e: ParamError) -> ParamError {
        let ParamError::Solver(e) = e else { return e };
        let involved: Vec<usize> = (0..self.geometric.len())
            .filter(|&c| self.geometric[c])
            .collect();
        contradiction(
            &self.ids,
            &involved,
            format!(
                "the global step under geometric {} failed ({e})",
                names(&self.ids, &involved)
            ),
        )
    }

    /// How each curve sits in the final map `uv` (per corner).
    pub fn fits(&self, rots: &Rots, uv: &[[f64; 2]], w: &[f64]) -> Vec<CurveFit> {
        let ng = self.n_gaps;
        let gaps: Vec<[f64; 2]> = (0..ng)
            .map(|k| self.lines.vector([w[2 * k], w[2 * k + 1]]))
            .collect();
        (0..self.ids.len())
            .map(|ci| {
                let n0 = self.lines.normals[self.family[ci] as usize];
                let value = self.lines.spacing * w[2 * ng + ci];
                let max_offset = self.emits[ci]
                    .iter()
                    .filter(|(v, _, _)| !self.ears[ci].contains(v))
                    .map(|(_, corner, chart)| {
                        let n = apply(rots.get(chart.rot as i64), n0);
                        let t = chart.lin.eval(&gaps);
                        let psi = uv[*corner];
                        let line = value + n[0] * t[0] + n[1] * t[1];
                        (n[0] * psi[0] + n[1] * psi[1] - line).abs()
                    })
                    .fold(0.0, f64::max);
                CurveFit {
                    id: self.ids[ci],
                    geometric: self.geometric[ci],
                    family: self.family[ci],
                    value,
                    max_offset,
                    singular_vertices: self.singular_on[ci].clone(),
                    ear_tips: self.ears[ci].clone(),
                }
            })
            .collect()
    }
}

/// Form evaluated on the gap unknowns only (curve values are not in `w_gaps`).
fn eval_partial(form: &Form, w_gaps: &[f64]) -> f64 {
    form.iter()
        .filter(|(k, _)| **k < w_gaps.len())
        .map(|(&k, &v)| v * w_gaps[k])
        .sum()
}

/// A run of a curve along one line family, oriented so that its left faces exist.
struct Piece {
    curve: usize,
    vertices: Vec<usize>,
    closed: bool,
}

/// Runs of a jagged curve shorter than [`SHORT_RUN`] cells along their line, as the field maps
/// them: the lines bounding such a run (its neighbours' lines, of the other family) round to one
/// value,
/// which collapses the run to a point and its faces to zero area (a scanned boundary's
/// staircase). They are given to a neighbour's family instead, shortest first, so the
/// staircase becomes one line; the curve then crosses the field there for less than half a
/// cell.
const SHORT_RUN: f64 = 0.5;

/// Runs whose image turns from a neighbour's by less than the angle between line families less
/// this (60° for quads, 30° for G6) join it too, whatever their length: a real corner of the
/// curve's line turns by the whole angle, and a run put on the other family although its image
/// turns by less is one the field crosses at about half the angle (the last edges before an
/// acute apex, whose faces the corner's turning frames hold: a 25° prism's base, meshed at a few
/// edges per cell, was split one edge before its apex, and the wedge collapsed). Measured on
/// prisms over 10°–35° corners and fandisk: 60° for quads is needed (49.5° left 14 folds on the
/// 10° prism), 40° for G6 gave fandisk with N = 6 up to 36 more folds, 30° none.
const SLIGHT_TURN: f64 = std::f64::consts::FRAC_PI_6;

/// Reassigns the edges of short runs (see [`SHORT_RUN`]) and, with `slight_turns`, of runs
/// turning slightly from a neighbour (see [`SLIGHT_TURN`]) to a neighbouring run's family;
/// `back[i]` is edge i's image in the first chart. A curve of one run is left alone.
fn merge_short_runs(
    classes: &mut [usize],
    back: &[[f64; 2]],
    closed: bool,
    lines: &Lines,
    slight_turns: bool,
) {
    let ne = classes.len();
    // The image of a run (first edge, length): the sum of its edges'.
    let image = |(first, len): (usize, usize)| {
        (0..len).fold([0.0, 0.0], |d, i| {
            let e = back[(first + i) % ne];
            [d[0] + e[0], d[1] + e[1]]
        })
    };
    loop {
        // Maximal runs as (first edge, length), cyclic for closed curves.
        let start = if closed {
            match (0..ne).find(|&j| classes[j] != classes[(j + ne - 1) % ne]) {
                Some(j) => j,
                None => return,
            }
        } else {
            0
        };
        let mut runs: Vec<(usize, usize)> = Vec::new();
        let mut k = 0;
        while k < ne {
            let first = (start + k) % ne;
            let mut len = 1;
            while k + len < ne && classes[(start + k + len) % ne] == classes[first] {
                len += 1;
            }
            runs.push((first, len));
            k += len;
        }
        if runs.len() < 2 {
            return;
        }
        // Each run's image, once per round.
        let images: Vec<[f64; 2]> = runs.iter().map(|&run| image(run)).collect();
        // How far run r goes along its own line: the distance between the lines of the other
        // family that bound it.
        let extent = |r: usize| {
            let (d, n) = (images[r], lines.normals[classes[runs[r].0]]);
            (n[1] * d[0] - n[0] * d[1]).abs()
        };
        let nr = runs.len();
        let neighbours_of = |r: usize| -> Vec<usize> {
            if closed {
                vec![(r + nr - 1) % nr, (r + 1) % nr]
            } else {
                [r.checked_sub(1), (r + 1 < nr).then_some(r + 1)]
                    .into_iter()
                    .flatten()
                    .collect()
            }
        };
        // How far the run's image turns away from its neighbours' (the least over them).
        let turn = |r: usize| {
            let a = images[r];
            neighbours_of(r)
                .into_iter()
                .map(|q| {
                    let b = images[q];
                    (a[0] * b[1] - a[1] * b[0])
                        .atan2(a[0] * b[0] + a[1] * b[1])
                        .abs()
                })
                .fold(f64::INFINITY, f64::min)
        };
        let jog = std::f64::consts::PI / lines.normals.len() as f64 - SLIGHT_TURN;
        let Some((r, _)) = (0..nr)
            .map(|r| (r, extent(r)))
            .filter(|&(r, x)| x < SHORT_RUN || (slight_turns && turn(r) < jog))
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
        else {
            return;
        };
        let neighbours = neighbours_of(r);
        // The neighbour family the run's own direction crosses least.
        let (first, len) = runs[r];
        let d = images[r];
        let family = neighbours
            .iter()
            .map(|&q| classes[runs[q].0])
            .min_by(|&a, &b| {
                let f = |l: usize| (lines.normals[l][0] * d[0] + lines.normals[l][1] * d[1]).abs();
                f(a).total_cmp(&f(b)).then(a.cmp(&b))
            })
            .expect("a curve of two runs or more has a neighbour run");
        for i in 0..len {
            classes[(first + i) % ne] = family;
        }
    }
}

/// Splits geometric curves where the field's line family along them changes (the curve turns a
/// corner of the grid there: the vertex lands on a lattice point; at a branch point the cone
/// angle splits into both sides' multiples of 2π/N). Each curve is oriented so that its left
/// faces exist (the reversed one along a boundary with the surface on its right).
fn split_by_family(
    mesh: &TriMesh,
    cut: &CutGraph,
    rots: &Rots,
    lines: &Lines,
    families: FamilyFrames,
    curves: &[ConstraintCurve],
    ids: &[u32],
) -> Result<Vec<Piece>, ParamError> {
    let frames = families.frames();
    let mut out = Vec::new();
    for (ci, c) in curves.iter().enumerate() {
        let reversed: Vec<usize> = c.vertices.iter().rev().copied().collect();
        let (verts, walk) = match walk_left(mesh, cut, rots, frames, c.vertices, c.closed) {
            Some(w) => (c.vertices.to_vec(), w),
            None => match walk_left(mesh, cut, rots, frames, &reversed, c.closed) {
                Some(w) => (reversed, w),
                None => {
                    return Err(contradiction(
                        ids,
                        &[ci],
                        format!(
                            "curve {} runs along the boundary with the surface on either side in turn; split it where it changes side",
                            c.id
                        ),
                    ));
                }
            },
        };
        let ne = walk.edges.len();
        // Each edge's image in the first face's chart, smoothed over its neighbours (a jagged
        // edge path zigzags about its direction).
        let back: Vec<[f64; 2]> = walk
            .edges
            .iter()
            .map(|e| apply(rots.get(-(e.chart_rot as i64)), e.d))
            .collect();
        let class = |i: usize| -> usize {
            let mut d = back[i];
            let around = [
                i.checked_sub(1).or(c.closed.then(|| ne - 1)),
                (i + 1 < ne).then_some(i + 1).or(c.closed.then_some(0)),
            ];
            for j in around.into_iter().flatten() {
                d[0] += back[j][0];
                d[1] += back[j][1];
            }
            (0..lines.normals.len())
                .min_by(|&a, &b| {
                    let f =
                        |l: usize| (lines.normals[l][0] * d[0] + lines.normals[l][1] * d[1]).abs();
                    f(a).total_cmp(&f(b))
                })
                .expect("a family")
        };
        let mut classes: Vec<usize> = (0..ne).map(class).collect();
        if c.geometric {
            merge_short_runs(&mut classes, &back, c.closed, lines, families.is_field());
        }
        // Edge i runs from verts[i] to verts[(i + 1) % len]; a split at vertex index j sits
        // between edges j − 1 and j.
        let nv = verts.len();
        let mut splits: Vec<usize> = (1..ne).filter(|&j| classes[j] != classes[j - 1]).collect();
        if c.closed && ne > 1 && classes[0] != classes[ne - 1] {
            splits.insert(0, 0);
        }
        if !c.geometric || splits.is_empty() {
            out.push(Piece {
                curve: ci,
                vertices: verts,
                closed: c.closed,
            });
            continue;
        }
        // A change at a branch point is a corner there as at a regular vertex: both runs end
        // on it, and each gives an integer equation (eq. 4.9) putting its lattice point on the
        // run's line. The cone angle splits into the two sides' multiples of 2π/N (a +1/4
        // singularity on a straight crease: 90° on one side, 180° on the other).
        let cyc = |k: usize| verts[k % nv];
        let bounds: Vec<usize> = if c.closed {
            let mut b = splits.clone();
            b.push(splits[0] + nv);
            b
        } else {
            let mut b = vec![0];
            b.extend(&splits);
            b.push(nv - 1);
            b
        };
        for w in bounds.windows(2) {
            out.push(Piece {
                curve: ci,
                vertices: (w[0]..=w[1]).map(cyc).collect(),
                closed: false,
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    #[test]
    fn short_runs_of_a_staircase_join_their_neighbours() {
        let lines = Lines::new(Lattice::Z2);
        // Along u (family 1: normal (0, 1)) with steps of 0.2 along v, and one long step.
        let back = [
            [0.7, 0.0],
            [0.0, -0.2],
            [0.7, 0.0],
            [0.0, -0.2],
            [0.7, 0.0],
            [0.0, -1.5],
            [0.7, 0.0],
        ];
        let mut classes = vec![1, 0, 1, 0, 1, 0, 1];
        merge_short_runs(&mut classes, &back, false, &lines, true);
        assert_eq!(
            classes,
            vec![1, 1, 1, 1, 1, 0, 1],
            "the long step stays a corner pair"
        );
        // Closed: a short run across the start joins too; a curve of one run is left alone.
        let mut classes = vec![0, 1, 1, 1, 1, 1, 1];
        merge_short_runs(&mut classes, &back, true, &lines, true);
        assert_eq!(classes, vec![1; 7]);
        let mut one = vec![0; 7];
        merge_short_runs(&mut one, &back, false, &lines, true);
        assert_eq!(one, vec![0; 7]);
    }

    #[test]
    fn a_run_turning_slightly_joins_its_neighbour() {
        let lines = Lines::new(Lattice::Z2);
        // Along u for 3 cells, then two edges at 50° (put on the other family, one cell along
        // it): a jog, joined when the family is read from the field. Turning by 80° instead is
        // a corner and stays.
        let at = |deg: f64| {
            let a = deg.to_radians();
            [0.7 * a.cos(), 0.7 * a.sin()]
        };
        for (deg, joined) in [(50.0, true), (80.0, false)] {
            let back = [at(0.0), at(0.0), at(0.0), at(0.0), at(deg), at(deg)];
            let split = vec![1, 1, 1, 1, 0, 0];
            let mut classes = split.clone();
            merge_short_runs(&mut classes, &back, false, &lines, true);
            let want = if joined { vec![1; 6] } else { split.clone() };
            assert_eq!(classes, want, "{deg}°");
            let mut classes = split.clone();
            merge_short_runs(&mut classes, &back, false, &lines, false);
            assert_eq!(classes, split, "{deg}°, curl*-free frames");
        }
    }

    #[test]
    fn ear_tips_are_the_middle_corners_of_a_face() {
        // 2 × 1 grid: vertices 0 1 2 / 3 4 5; its triangles split each square along a diagonal.
        let m = generate::grid(2, 1, 2.0, 1.0);
        let face_with = |a: usize, b: usize, c: usize| {
            (0..m.n_faces()).any(|f| {
                let v = m.face(f);
                v.contains(&a) && v.contains(&b) && v.contains(&c)
            })
        };
        // Along the bottom edge 0-1-2 no face holds all three; around a face, the middle one is
        // a tip.
        assert!(!is_ear_tip(&m, &[0, 1, 2], false, 1));
        let tri: Vec<usize> = (0..6)
            .flat_map(|a| (0..6).flat_map(move |b| (0..6).map(move |c| [a, b, c])))
            .find(|&[a, b, c]| a != b && b != c && a != c && face_with(a, b, c))
            .expect("a face")
            .to_vec();
        assert!(is_ear_tip(&m, &tri, false, 1));
        assert!(
            !is_ear_tip(&m, &tri, false, 0),
            "an end of an open curve is no tip"
        );
        assert!(
            is_ear_tip(&m, &tri, true, 0),
            "on a closed curve every corner of it is"
        );
    }
}

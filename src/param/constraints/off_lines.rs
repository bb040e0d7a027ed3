//! Branch points kept off the lines of geometric curves they are not on (alg. 7 step 5).
//!
//! The integer unknowns round to the nearest solution of C_c w = 0 from the local step's map,
//! which is not yet held to the curves: a curve is straightened at its average value, and near a
//! branch point that average may lie a fraction of a cell from it although the branch point is
//! cells away in space. Rounded onto the curve's line, the branch point collapses the faces
//! between them: the repair can only wind it wrongly (a −1/4 whose fan turns by 90° and a
//! neighbour that takes its 360°), one patched place in the remesh each. A box cut by a sphere
//! at 3000 vertices, features at 40°: 17 of its −1/4 singularities, two cells beside the rims of
//! its six holes, rounded onto the rims' lines, 36 wrongly wound vertices, 18 patched places.
//!
//! A [`Guard`] is a branch point and the line of a geometric curve beside it, seen from the
//! branch point's side: the offset F(w) = nᵀψ_b(W)/s − (c_κ + nᵀt(W)/s) between them in the
//! chart of the branch point's sector (both sides affine in the integer unknowns) must keep the
//! sign the side has. After the rounding, broken guards are mended one lattice step of one
//! unknown at a time (the others re-solved to keep C_c w = 0, [`Traced::stepped`]), choosing the
//! step that leaves the fewest broken and, among those, stays nearest the measured values.
//!
//! For quads every rounding is mended so ([`Breaks::Across`]). With N = 6 the rounding is left
//! as it is, and only a map that still folds after the repair is made again from the rounding
//! with the guards mended, first those that have the branch point on the line itself
//! ([`Breaks::OnLine`]), then, if that map folds too, those with it across the line as well
//! ([`Traced::off_lines_try`]): mended in every rounding, they folded prisms that were
//! fold-free without them (a T-shaped prism at 20 000 vertices, 0 → 11 folded faces with the
//! first, 0 → 13 with the second).
//!
//! Corners (branch points on curves, where curves meet) have guards of their own, never
//! mended: against the lines of parallel curves less than [`STRIP_CELLS`] away. With quads on
//! 2Z² every corner is on an even lattice point, so such a strip rounds to zero or two cells;
//! one rounded to zero although half a cell or more wide in the local step's map (a comb's
//! slot at 1.3 cells) folds from end to end, and no repair or mending lifts it (each step keeps
//! C_c w = 0 by narrowing another strip). [`Traced::collapsed_strips`] counts them, for the
//! caller to solve on Z² instead (`Base::solve_previewing`).

use std::collections::{HashMap, HashSet, VecDeque};

use glam::DVec3;

use super::{DENOMINATOR, Form, Lines, Traced, eval, form_add, lin_form};
use crate::mesh::TriMesh;
use crate::param::cut::{CutGraph, NONE};
use crate::param::global::GlobalSystem;

/// A branch point's sector reaches this many grid cells for curves beside it (3 missed the
/// box's branch points inside its cavity, 2.9 cells from the rims in space and rounded onto
/// their lines all the same).
const REACH_CELLS: f64 = 5.0;
/// Mending steps at most per broken guard (each mends one or more, or the mending stops).
const STEPS_PER_GUARD: usize = 2;
/// A strip at least this wide in the local step's map (in line spacings) that the rounding
/// closes is collapsed ([`Traced::collapsed_strips`]). With 1 the gear's teeth at 1000 target
/// vertices went unseen (0 counted, 49 at ½) and took 24 s of crowded tries; at ½ the scans
/// with features count a few (fertility 3, fandisk 1), harmless there: only a map that keeps
/// folds acts on the count.
const COLLAPSED_CELLS: f64 = 0.5;
/// Corners are guarded against the lines of curves within this many grid cells: the strips
/// that the 2Z² rounding, which puts corners on even lattice points, can only collapse or
/// widen to two cells.
const STRIP_CELLS: f64 = 2.0;

/// A branch point beside the line of a geometric curve piece, which the rounding must leave on
/// its side: `side` · F(w) > 0.
#[derive(Clone, Debug)]
pub(super) struct Guard {
    /// F in the integer unknowns (units of the line spacing).
    form: Form,
    /// The sign F has on the branch point's side of the line.
    side: f64,
    /// side · F at the measured values (the local step's map).
    measured: f64,
}

/// What breaks a guard.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Breaks {
    /// The branch point on the line or across it (quads).
    Across,
    /// The branch point on the line only (N = 6's first try: the cross plate's folds go
    /// 117 → 0 with it, none with crossings mended as well; docs/untangling.md).
    OnLine,
}

/// A geometric piece's line where it constrains a face on its left: the normal n in the face's
/// disk frame, the line's value c_κ + nᵀt(W)/s as a form, and the sign nᵀ(φ − line) has on
/// the left of the piece.
pub(super) struct LineAt {
    pub face: usize,
    pub piece: usize,
    pub n: [f64; 2],
    pub line: Form,
    pub left: f64,
}

/// The guards of every branch point that lies on no geometric piece (`on_piece`: per vertex)
/// beside the pieces' lines `lines_at`; with `corners`, instead those of the branch points on
/// pieces (the corners where curves meet) beside the lines of pieces within [`STRIP_CELLS`].
/// `edge_piece`: per edge the geometric piece running along it (NONE: none), `ends` per piece
/// its end vertices (none when closed). `frames`: per face, grid size 1 / |U|. `measured`: the
/// integer unknowns' measured values.
#[allow(clippy::too_many_arguments)]
pub(super) fn guards(
    mesh: &TriMesh,
    cut: &CutGraph,
    global: &GlobalSystem,
    lines: &Lines,
    frames: &[[DVec3; 2]],
    on_piece: &[bool],
    edge_piece: &[u32],
    lines_at: &[LineAt],
    ends: &[Vec<usize>],
    measured: &[f64],
    corners: bool,
) -> Vec<Guard> {
    let mut at_face: HashMap<usize, Vec<&LineAt>> = HashMap::new();
    for l in lines_at {
        at_face.entry(l.face).or_default().push(l);
    }
    let cut_edge = |e: usize| !cut.transitions[e].is_identity();
    let mut out = Vec::new();
    let mut seen_forms: HashSet<(usize, Vec<(usize, i64)>)> = HashSet::new();
    for v in (0..mesh.n_vertices()).filter(|&v| cut.singular[v] && on_piece[v] == corners) {
        let p = mesh.position(v);
        let cells: Vec<f64> = mesh
            .outgoing(v)
            .map(|h| frames[mesh.face_of(h)][0].length())
            .filter(|u| *u > 0.0 && u.is_finite())
            .map(|u| 1.0 / u)
            .collect();
        if cells.is_empty() {
            continue;
        }
        let reach = REACH_CELLS * cells.iter().sum::<f64>() / cells.len() as f64;
        let mut done: HashSet<usize> = HashSet::new();
        for h in mesh.outgoing(v) {
            let f0 = mesh.face_of(h);
            if done.contains(&f0) {
                continue;
            }
            // The branch point's sector within reach: faces joined by edges on neither the cut
            // (one chart) nor a curve (one side).
            let mut region = vec![f0];
            let mut queue = VecDeque::from([f0]);
            done.insert(f0);
            while let Some(f) = queue.pop_front() {
                for g in 3 * f..3 * f + 3 {
                    let e = mesh.edge(g);
                    if cut_edge(e) || edge_piece[e] != NONE {
                        continue;
                    }
                    let Some(t) = mesh.twin(g) else { continue };
                    let nf = mesh.face_of(t);
                    if done.contains(&nf) || mesh.face_centroid(nf).distance(p) > reach {
                        continue;
                    }
                    done.insert(nf);
                    region.push(nf);
                    queue.push_back(nf);
                }
            }
            let cone = &global.corner_lin[h];
            // Per piece the sector reaches: whether its point nearest the branch point is one
            // of its ends. Beyond an end the branch point is not beside the piece, and its
            // line may well run through it (a separatrix meeting a crease's end).
            let mut nearest: HashMap<u32, (f64, bool)> = HashMap::new();
            for &f in &region {
                for g in 3 * f..3 * f + 3 {
                    let piece = edge_piece[mesh.edge(g)];
                    if piece == NONE {
                        continue;
                    }
                    let (a, b) = (mesh.from(g), mesh.to(g));
                    let (d, at) = nearest_on_segment(p, mesh.position(a), mesh.position(b));
                    let at_end = match at {
                        Some(0) => ends[piece as usize].contains(&a),
                        Some(_) => ends[piece as usize].contains(&b),
                        None => false,
                    };
                    let best = nearest.entry(piece).or_insert((f64::INFINITY, false));
                    if d < best.0 {
                        *best = (d, at_end);
                    }
                }
            }
            for &f in &region {
                for g in 3 * f..3 * f + 3 {
                    let e = mesh.edge(g);
                    let piece = edge_piece[e];
                    let Some(&(d, at_end)) = nearest.get(&piece) else {
                        continue;
                    };
                    // A corner is beside the pieces that do not run through it and come
                    // within a strip's width, their ends included (a slot's far wall is
                    // nearest at its foot, the slot floor's other corner).
                    let beside = if corners {
                        d > 1e-12 && d <= STRIP_CELLS * reach / REACH_CELLS
                    } else {
                        !at_end
                    };
                    if piece == NONE || !beside {
                        continue;
                    }
                    // The piece's line in this chart: from this face when it is the piece's
                    // left, else from the face across (one chart unless the edge is cut).
                    let left_of = |f: usize| {
                        at_face
                            .get(&f)
                            .is_some_and(|ls| ls.iter().any(|l| l.piece == piece as usize))
                    };
                    let (face, sign) = if left_of(f) {
                        (f, 1.0)
                    } else {
                        match mesh.twin(g) {
                            Some(t) if !cut_edge(e) && left_of(mesh.face_of(t)) => {
                                (mesh.face_of(t), -1.0)
                            }
                            _ => continue,
                        }
                    };
                    for l in at_face.get(&face).into_iter().flatten() {
                        if l.piece != piece as usize {
                            continue;
                        }
                        let mut form = lin_form(cone, l.n, lines);
                        form_add(&mut form, &l.line, -1.0);
                        let key: Vec<(usize, i64)> = form
                            .iter()
                            .map(|(&k, &a)| (k, (a * DENOMINATOR).round() as i64))
                            .filter(|&(_, a)| a != 0)
                            .collect();
                        let side = sign * l.left;
                        // Beyond a piece's end its line may pass the branch point on either
                        // side: only a side the measured values agree with is kept.
                        if key.is_empty()
                            || side * eval(&form, measured) <= 0.0
                            || !seen_forms.insert((v, key))
                        {
                            continue;
                        }
                        out.push(Guard {
                            measured: side * eval(&form, measured),
                            form,
                            side,
                        });
                    }
                }
            }
        }
    }
    out
}

/// The distance from `p` to the segment a–b, and which end is nearest when an end is (0: a,
/// 1: b).
fn nearest_on_segment(p: DVec3, a: DVec3, b: DVec3) -> (f64, Option<u8>) {
    let t = crate::mesh::segment_parameter(p, a, b);
    if t <= 0.0 {
        (p.distance(a), Some(0))
    } else if t >= 1.0 {
        (p.distance(b), Some(1))
    } else {
        (p.distance(a + t * (b - a)), None)
    }
}

impl Guard {
    /// Whether `w` puts a corner on or across the line of a parallel curve at least
    /// [`COLLAPSED_CELLS`] from it in the measured map: the strip between them collapses.
    fn collapsed_by(&self, w: &[f64]) -> bool {
        self.measured >= COLLAPSED_CELLS && self.broken_by(w, Breaks::Across)
    }

    /// Whether `w` breaks the guard: the branch point on the line beside it (or across it,
    /// [`Breaks::Across`]).
    fn broken_by(&self, w: &[f64], breaks: Breaks) -> bool {
        let f = self.side * eval(&self.form, w);
        match breaks {
            Breaks::Across => f <= 1e-9,
            Breaks::OnLine => f.abs() <= 1e-9,
        }
    }
}

impl Traced {
    /// The corners `w` puts on or across the line of a parallel curve beside them that was at
    /// least [`COLLAPSED_CELLS`] away in the local step's map ([`Traced::corner_guards`]).
    pub fn collapsed_strips(&self, w: &[f64]) -> usize {
        self.corner_guards
            .iter()
            .filter(|g| g.collapsed_by(w))
            .count()
    }

    /// The guards `w` breaks.
    fn broken(&self, w: &[f64], breaks: Breaks) -> usize {
        self.guards
            .iter()
            .filter(|g| g.broken_by(w, breaks))
            .count()
    }

    /// Mends the guards the rounded unknowns `w` break (see the module's comment); `target`:
    /// the measured values in the same coordinates.
    pub(super) fn keep_off_lines(&self, w: &mut Vec<f64>, target: &[f64], breaks: Breaks) {
        let mut broken = self.broken(w, breaks);
        for _ in 0..STEPS_PER_GUARD * broken {
            if broken == 0 {
                return;
            }
            let dist =
                |x: &[f64]| -> f64 { x.iter().zip(target).map(|(a, b)| (a - b) * (a - b)).sum() };
            let mut best: Option<(usize, f64, Vec<f64>)> = None;
            for g in self.guards.iter().filter(|g| g.broken_by(w, breaks)) {
                for (&k, &a) in &g.form {
                    if (a * DENOMINATOR).round() == 0.0 {
                        continue;
                    }
                    let Some(next) = self.stepped(w, k, (g.side * a).signum()) else {
                        continue;
                    };
                    let score = (self.broken(&next, breaks), dist(&next));
                    if best
                        .as_ref()
                        .is_none_or(|b| (score.0, score.1) < (b.0, b.1))
                    {
                        best = Some((score.0, score.1, next));
                    }
                }
            }
            match best {
                Some((left, _, next)) if left < broken => {
                    *w = next;
                    broken = left;
                }
                _ => return,
            }
        }
    }
}

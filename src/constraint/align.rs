//! The field's side of geometric curves (alg. 7 needs a field along which the curve is a
//! parameter line): every face with an edge on a geometric curve takes the edge's direction as
//! an alignment constraint, strong enough that one of the N directions runs along it (on sharp
//! creases the curvature directions are unreliable anyway); the smoothing propagates it.

use glam::DVec3;

use super::{Curve, CurveKind, halfedge_between};
use crate::mesh::TriMesh;

/// One face's alignment to one curve edge: the unit edge direction (in the face's plane).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurveAlignment {
    pub face: usize,
    pub direction: DVec3,
}

/// The alignments the geometric curves ask for: one per (face, curve edge) with the face on
/// either side of the edge, in curve and edge order (a face at a corner of a curve, or on two
/// curves, appears once per edge; the field combines them modulo its symmetry).
///
/// The direction is the curve's chord over `scale` (model units) beyond either end of the
/// edge, within the curve: a scanned boundary zigzags at the scale of its edges, and the
/// zigzag's edges, combined modulo 2π/N, would turn the field away from where the curve runs
/// (edges ±30° off the curve's course average to 45° off it for N = 4). `scale` = 0 takes
/// each edge's own direction.
pub fn alignment<'a>(
    mesh: &TriMesh,
    curves: impl IntoIterator<Item = &'a Curve>,
    scale: f64,
) -> Vec<CurveAlignment> {
    let mut out = Vec::new();
    for c in curves {
        if c.kind != CurveKind::Geometric {
            continue;
        }
        let segments = c.segments();
        let m = segments.len();
        let length = |i: usize| {
            let (a, b) = segments[i];
            (mesh.position(b) - mesh.position(a)).length()
        };
        // The curve's point at least `scale` beyond segment i's end (`forward`) or start.
        let reach = |i: usize, forward: bool| -> usize {
            let mut len = 0.0;
            let mut j = i;
            for _ in 1..m {
                if len >= scale {
                    break;
                }
                let next = if forward {
                    if j + 1 < m {
                        j + 1
                    } else if c.closed {
                        0
                    } else {
                        break;
                    }
                } else if j > 0 {
                    j - 1
                } else if c.closed {
                    m - 1
                } else {
                    break;
                };
                j = next;
                len += length(j);
            }
            if forward {
                segments[j].1
            } else {
                segments[j].0
            }
        };
        for (i, &(a, b)) in segments.iter().enumerate() {
            let Some(h) = halfedge_between(mesh, a, b) else {
                continue;
            };
            let edge = mesh.vector(h);
            let chord = if scale > 0.0 {
                mesh.position(reach(i, true)) - mesh.position(reach(i, false))
            } else {
                edge
            };
            // A chord that doubles back (a curve tighter than the scale) falls back to the
            // edge.
            let d = if chord.dot(edge) > 0.0 { chord } else { edge };
            let d = d.normalize_or_zero();
            if d == DVec3::ZERO {
                continue;
            }
            out.push(CurveAlignment {
                face: mesh.face_of(h),
                direction: d,
            });
            if let Some(t) = mesh.twin(h) {
                out.push(CurveAlignment {
                    face: mesh.face_of(t),
                    direction: -d,
                });
            }
        }
    }
    out
}

/// Alignments for the faces inside an acute corner between two geometric curves: where two
/// curves meet at a vertex (a crease that turns back sharply and was split there, two creases
/// meeting) and the faces between them span an angle α near or under π/N on the surface, the
/// field would turn by α across them and both curves would run along one direction of the N-fold
/// frame: one parameter line, the faces between them squeezed to zero area (fandisk at 40°:
/// two creases meeting at 19° left a fold no repair can undo). These faces are held instead to
/// a frame that turns by α − 2π/N from one curve to the other, linearly in the angle around the
/// vertex, so the second curve runs along the frame's next direction: the corner becomes a
/// lattice corner of 2π/N (90° for quads, 60° for triangles), its faces stretched, not folded.
/// Corners within one curve are left alone (a jagged boundary's notch is no corner at the
/// grid's scale; `detect` splits curves at real corners). N = 2 has no next direction of another
/// family and gets none.
///
/// A corner is acute below [`ACUTE_FRACTION`] of 2π/N, a little above the π/N where the
/// smallest turn would already choose the lattice corner: at π/N exactly (a right isosceles
/// triangle's 45° corners, N = 4) the smoothing's choice is a coin toss, and the wrong side
/// collapses the corner. At an apex on the boundary the faces beyond its fan within `reach`
/// (model units) are held too ([`beyond_the_fan`]); an interior apex's fan closes around it,
/// and holding the fan is enough. Corners under [`HELD_FRACTION`] of 2π/N that are not acute
/// are held the same way, with the faces within `reach` at interior apexes too, and so are
/// boundary corners halfway between two lattice corners, to the corner [`lattice_corners`]
/// decides for their loop (their alignments are returned, not their apexes or wedges).
pub fn acute_corners<'a>(
    mesh: &TriMesh,
    curves: impl IntoIterator<Item = &'a Curve>,
    n: u32,
    reach: f64,
) -> AcuteCorners {
    let mut out = AcuteCorners::default();
    if n < 4 {
        return out;
    }
    let step = 2.0 * std::f64::consts::PI / n as f64;
    let (sectors, curve_of) = curve_sectors(mesh, curves);
    let lattice = lattice_corners(mesh, &sectors, step);
    out.rotations = crease_rotations(mesh, &sectors, &lattice, step);
    for (s, corner) in sectors.iter().zip(lattice) {
        let Some(corner) = corner else { continue };
        let acute = s.alpha < step * ACUTE_FRACTION;
        if acute {
            out.apexes.push(s.apex);
        }
        // Beyond the fan at an interior apex too, unless acute: an apex's fan is often one face
        // per corner (a tetrahedron's, remeshed), which turns no path around the apex but its
        // own one ring. Acute interior apexes keep their fan only (their singularity is placed
        // by the design, `Base::off_curves_in_wedges`): held beyond it, camelhead with
        // features at 40° (corners of 1°–3° where a ridge turns back) 12 → 38 folded faces.
        let interior = !acute && !s.boundary;
        let wedge = hold_sector(
            mesh,
            s,
            corner,
            0.0,
            interior,
            &curve_of,
            reach,
            &mut out.alignments,
        );
        if acute {
            out.wedges.push((s.apex, wedge));
        }
    }
    out.apexes.dedup();
    out
}

/// The frame's rotation across each curve edge between two held sectors ([`lattice_corners`])
/// of one apex, from the last face of the sector before it to the first face of the one after
/// it (counter-clockwise about the apex): what the two sectors' turning frames
/// ([`hold_sector`]) ask for at those faces' middles. A held face spans its sector's angle at
/// most, and its frame lies between its two curves' lattice directions; across a crease
/// between two such faces the nearest turn is the wrong one when the two corners add up to
/// less than 2π/N (a hexagonal pyramid's apex, six corners of 37°, one face each: the nearest
/// turns made the apex +3/4 instead of −1/2). Such rotations, more than half a step
/// (`step`), are prescribed (`FieldParams::fixed_rotations`); the others are the nearest turn
/// already and are left to the rounding.
fn crease_rotations(
    mesh: &TriMesh,
    sectors: &[Sector],
    lattice: &[Option<f64>],
    step: f64,
) -> Vec<(u32, u32, f64)> {
    let held: Vec<(&Sector, f64)> = sectors
        .iter()
        .zip(lattice)
        .filter_map(|(s, c)| c.map(|c| (s, c)))
        .collect();
    let mut out = Vec::new();
    for &(s, c) in &held {
        let Some(&(t, c2)) = held
            .iter()
            .find(|(t, _)| t.apex == s.apex && t.first == s.last)
        else {
            continue;
        };
        let (Some(&last), Some(&first)) = (s.faces.last(), t.faces.first()) else {
            continue;
        };
        // The frame's angle at a face's middle, from its sector's first curve (`hold_sector`).
        let last_angle = mesh.corner_angle(s.fan[last]);
        let before = (s.alpha - last_angle / 2.0) * (s.alpha - c) / s.alpha;
        let after = mesh.corner_angle(t.fan[first]) / 2.0 * (t.alpha - c2) / t.alpha;
        // From the first sector's first curve: its corner α, less the lattice corner c that
        // makes the frame at its end the next one's start.
        let rotation = s.alpha + after - before - c;
        if rotation.abs() <= step / 2.0 {
            continue;
        }
        out.push((
            mesh.face_of(s.fan[last]) as u32,
            mesh.face_of(t.fan[first]) as u32,
            rotation,
        ));
    }
    out
}

/// Holds the faces of sector `s` to a frame that turns linearly in the angle around the apex
/// from the first curve's direction (turned by `offset`) to the second's, so that the sector
/// becomes the lattice corner `corner` ([`acute_corners`]); at a boundary apex, or where
/// `interior` asks for it, the faces beyond the fan within `reach` too ([`beyond_the_fan`]).
/// Returns the faces held.
#[allow(clippy::too_many_arguments)]
fn hold_sector(
    mesh: &TriMesh,
    s: &Sector,
    corner: f64,
    offset: f64,
    interior: bool,
    curve_of: &[Option<u32>],
    reach: f64,
    out: &mut Vec<CurveAlignment>,
) -> Vec<usize> {
    let (m, fan, first, last, alpha) = (s.apex, &s.fan, s.first, s.last, s.alpha);
    let k = fan.len();
    let mut wedge: Vec<usize> = s.faces.iter().map(|&i| mesh.face_of(fan[i])).collect();
    let turn = (alpha - corner) / alpha;
    let mut before = 0.0;
    for &i in &s.faces {
        let h = fan[i];
        let angle = mesh.corner_angle(h);
        // The frame's angle at the face's middle, from the face's first edge.
        let theta = (before + angle / 2.0) * turn - before + offset;
        let f = mesh.face_of(h);
        let e = mesh.vector(h).normalize_or_zero();
        let normal = mesh.face_normal(f);
        out.push(CurveAlignment {
            face: f,
            direction: theta.cos() * e + theta.sin() * normal.cross(e),
        });
        before += angle;
    }
    // The far ends of the two curves' edges at the apex.
    let far = |i: usize| {
        if i < k {
            mesh.to(fan[i])
        } else {
            mesh.from(mesh.prev(fan[k - 1]))
        }
    };
    let (d1, d2) = (
        mesh.position(far(first)) - mesh.position(m),
        mesh.position(far(last)) - mesh.position(m),
    );
    let beyond = if s.boundary || interior {
        beyond_the_fan(mesh, curve_of, m, &wedge, [d1, d2], reach)
    } else {
        Vec::new()
    };
    for (f, beta) in beyond {
        // The curve's direction in the face's plane, turned by the frame's angle there.
        let normal = mesh.face_normal(f);
        let e = (d1 - normal * normal.dot(d1)).normalize_or_zero();
        let theta = beta * alpha * turn + offset;
        out.push(CurveAlignment {
            face: f,
            direction: theta.cos() * e + theta.sin() * normal.cross(e),
        });
        wedge.push(f);
    }
    wedge
}

/// N = 2: the corner two curves meeting at `alpha` make in the map, of one family (`one`: a
/// multiple of π) or of two (π/2 + kπ): the nearest that is not degenerate, ties to the
/// smaller (a concave 270° corner of one family opens to 180°, not 360°, which would be a
/// −1/2 singularity beside the apex's own; an acute one of one family opens to 180°, it
/// cannot close to 0).
fn stripe_corner(alpha: f64, one: bool) -> f64 {
    use std::f64::consts::{FRAC_PI_2, PI};
    let nearest = |x: f64| (x - 0.5).ceil();
    if one {
        PI * nearest(alpha / PI).max(1.0)
    } else {
        FRAC_PI_2 + PI * nearest((alpha - FRAC_PI_2) / PI).max(0.0)
    }
}

/// N = 2: the corners between curves that [`stripe_across`] could not give their natural
/// turn (`across`: the curves held across the stripes). Two curves of one family meet at a
/// multiple of π in the map, of two families at π/2 + kπ; where the nearest such corner that
/// is not degenerate is more than π/4 from the corner's angle α (two curves of one family at a
/// right angle: one of the three corners at a box's apex), the smoothing would take the
/// smallest turn and collapse it to 0 or open it to π at random, and a collapsed corner is a
/// +1/2 singularity at the apex, around which no map is one-to-one. Such corners are held to
/// their corner with the turning frame of [`acute_corners`].
pub fn stripe_corners<'a>(
    mesh: &TriMesh,
    curves: impl IntoIterator<Item = &'a Curve>,
    across: &std::collections::BTreeSet<u32>,
    reach: f64,
) -> AcuteCorners {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    let mut out = AcuteCorners::default();
    let (sectors, curve_of) = curve_sectors(mesh, curves);
    for s in sectors.iter().filter(|s| !s.boundary) {
        let [a, b] = s.curves;
        let (fa, fb) = (across.contains(&a), across.contains(&b));
        let corner = stripe_corner(s.alpha, fa == fb);
        if (corner - s.alpha).abs() <= FRAC_PI_4 {
            continue;
        }
        let offset = if fa { FRAC_PI_2 } else { 0.0 };
        hold_sector(
            mesh,
            s,
            corner,
            offset,
            false,
            &curve_of,
            reach,
            &mut out.alignments,
        );
    }
    out
}

/// N = 2 (stripes): the geometric curves the field is held across rather than along. A line
/// field has no quarter turn: held along two curves that meet at a right angle it must turn by
/// 90° inside the corner, which no line field's index allows, and the smoothing puts ±1/2
/// singularities beside the corner, around which the map folds (fandisk with features at 40°:
/// 533 folded faces, 366 after the repair). Held along one and across the other it turns by
/// none. So two curves meeting at α want one family where α is nearer a multiple of π, two
/// where it is nearer π/2 + kπ. Decided as a weighted two-colouring of the curves: the corners
/// by how strongly they prefer (strongest first) joined into components with a parity (Kruskal
/// with union–find), then single curves flipped while the summed cost falls; each component
/// with a corner as a whole is then held the way `agreement` prefers (summed over its curves:
/// `Base` passes the unconstrained field's agreement with holding the curve along,
/// Σ cos 2(α − θ), so that stripes keep following the curvature where the curves leave them
/// free); a curve without an interior corner stays along. Corners at boundary apexes are not
/// counted. Where the corners form an odd cycle (three creases at a box's corner) one corner
/// keeps its turn: no colouring avoids it. In curve order: deterministic.
pub fn stripe_across<'a>(
    mesh: &TriMesh,
    curves: impl IntoIterator<Item = &'a Curve>,
    agreement: impl Fn(&Curve) -> f64,
) -> std::collections::BTreeSet<u32> {
    let curves: Vec<&Curve> = curves
        .into_iter()
        .filter(|c| c.kind == CurveKind::Geometric)
        .collect();
    let index: std::collections::BTreeMap<u32, usize> =
        curves.iter().enumerate().map(|(i, c)| (c.id, i)).collect();
    let (sectors, _) = curve_sectors(mesh, curves.iter().copied());
    // Per corner (curve i, curve j, cost of one family − cost of two): for two families the
    // squared distance to the corner it would be held to ([`stripe_corner`]); for one, to the
    // nearest multiple of π, 0 included. An acute corner of one family is then cheap (and is
    // held open to 180° by [`stripe_corners`]); costed by its corner of 180° instead, the star
    // prism's 38° tips went to two families and a wall's 90° corner was opened instead
    // (fandisk at 40°: 165 → 1333 folded faces).
    let off = |x: f64| {
        let r = x.rem_euclid(std::f64::consts::PI);
        r.min(std::f64::consts::PI - r)
    };
    let cost = |alpha: f64, one: bool| {
        if one {
            off(alpha).powi(2)
        } else {
            (stripe_corner(alpha, false) - alpha).powi(2)
        }
    };
    // Corners on the boundary are left out: a boundary apex is no cone the field must close
    // around, and colouring an aligned boundary's pieces turned the stripes against scanned
    // boundaries (camelhead at 1500 vertices: a fold left after the repair).
    let corners: Vec<(usize, usize, f64)> = sectors
        .iter()
        .filter(|s| !s.boundary)
        .filter_map(|s| {
            let (i, j) = (index[&s.curves[0]], index[&s.curves[1]]);
            (i != j).then(|| (i, j, cost(s.alpha, true) - cost(s.alpha, false)))
        })
        .collect();
    let n = curves.len();
    // Union–find with the parity of each curve against its parent.
    let mut parent: Vec<usize> = (0..n).collect();
    let mut parity = vec![false; n];
    fn root(parent: &mut [usize], parity: &mut [bool], i: usize) -> (usize, bool) {
        let mut path = Vec::new();
        let mut r = i;
        while parent[r] != r {
            path.push(r);
            r = parent[r];
        }
        // Compress: each node on the path points at the root with its parity to it.
        let mut acc = false;
        for &x in path.iter().rev() {
            acc ^= parity[x];
            parity[x] = acc;
            parent[x] = r;
        }
        (r, if path.is_empty() { false } else { parity[i] })
    }
    let mut order: Vec<usize> = (0..corners.len()).collect();
    order.sort_by(|&a, &b| {
        corners[b]
            .2
            .abs()
            .total_cmp(&corners[a].2.abs())
            .then(a.cmp(&b))
    });
    for k in order {
        let (i, j, pref) = corners[k];
        let (ri, pi) = root(&mut parent, &mut parity, i);
        let (rj, pj) = root(&mut parent, &mut parity, j);
        if ri != rj {
            parent[rj] = ri;
            parity[rj] = pi ^ pj ^ (pref > 0.0);
        }
    }
    let mut across: Vec<bool> = (0..n)
        .map(|i| root(&mut parent, &mut parity, i).1)
        .collect();
    // Single flips while the cost falls (a curve's corners only).
    let mut at: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (k, &(i, j, _)) in corners.iter().enumerate() {
        at[i].push(k);
        at[j].push(k);
    }
    let cost = |across: &[bool], k: usize, corners: &[(usize, usize, f64)]| {
        let (i, j, pref) = corners[k];
        if across[i] == across[j] {
            pref.max(0.0)
        } else {
            (-pref).max(0.0)
        }
    };
    for _ in 0..n.max(1) {
        let mut changed = false;
        for i in 0..n {
            let now: f64 = at[i].iter().map(|&k| cost(&across, k, &corners)).sum();
            across[i] = !across[i];
            let flipped: f64 = at[i].iter().map(|&k| cost(&across, k, &corners)).sum();
            if flipped < now - 1e-12 {
                changed = true;
            } else {
                across[i] = !across[i];
            }
        }
        if !changed {
            break;
        }
    }
    // Each component with a corner the way the free field prefers; a curve without one stays
    // along the stripes.
    let mut sum = vec![0.0; n];
    let roots: Vec<usize> = (0..n)
        .map(|i| root(&mut parent, &mut parity, i).0)
        .collect();
    let mut cornered = vec![false; n];
    for &(i, _, _) in &corners {
        cornered[roots[i]] = true;
    }
    for i in (0..n).filter(|&i| cornered[roots[i]]) {
        let a = agreement(curves[i]);
        sum[roots[i]] += if across[i] { -a } else { a };
    }
    (0..n)
        .filter(|&i| across[i] != (sum[roots[i]] < 0.0))
        .map(|i| curves[i].id)
        .collect()
}

/// The corners between two geometric curves: at every end of an open geometric curve, each
/// pair of consecutive curve edges around it that belong to different curves, with the faces
/// between them; and per mesh edge the geometric curve along it (the first one).
fn curve_sectors<'a>(
    mesh: &TriMesh,
    curves: impl IntoIterator<Item = &'a Curve>,
) -> (Vec<Sector>, Vec<Option<u32>>) {
    // Per mesh edge: the geometric curve along it (the first one).
    let mut curve_of: Vec<Option<u32>> = vec![None; mesh.n_edges()];
    let mut corners: Vec<usize> = Vec::new();
    for c in curves {
        if c.kind != CurveKind::Geometric {
            continue;
        }
        for (a, b) in c.segments() {
            if let Some(h) = halfedge_between(mesh, a, b) {
                curve_of[mesh.edge(h)].get_or_insert(c.id);
            }
        }
        if !c.closed && c.vertices.len() >= 2 {
            corners.extend([c.vertices[0], c.vertices[c.vertices.len() - 1]]);
        }
    }
    corners.sort_unstable();
    corners.dedup();
    let mut sectors = Vec::new();
    for m in corners {
        let fan: Vec<usize> = mesh.outgoing(m).collect();
        let k = fan.len();
        let boundary = mesh.is_boundary_vertex(m);
        // The fan's edges in counter-clockwise order: face i lies between edges i and i + 1
        // (cyclic inside; at the boundary one more edge closes the fan).
        let mut edges: Vec<usize> = fan.iter().map(|&h| mesh.edge(h)).collect();
        if boundary {
            edges.push(mesh.edge(mesh.prev(fan[k - 1])));
        }
        let marked: Vec<usize> = (0..edges.len())
            .filter(|&i| curve_of[edges[i]].is_some())
            .collect();
        if marked.len() < 2 {
            continue;
        }
        let pairs: Vec<(usize, usize)> = if boundary {
            marked.windows(2).map(|w| (w[0], w[1])).collect()
        } else {
            (0..marked.len())
                .map(|i| (marked[i], marked[(i + 1) % marked.len()]))
                .collect()
        };
        for (first, last) in pairs {
            let (Some(a), Some(b)) = (curve_of[edges[first]], curve_of[edges[last]]) else {
                continue;
            };
            if a == b {
                continue;
            }
            let faces: Vec<usize> = if last > first {
                (first..last).collect()
            } else {
                (first..k).chain(0..last).collect()
            };
            if faces.is_empty() {
                continue;
            }
            let alpha: f64 = faces.iter().map(|&i| mesh.corner_angle(fan[i])).sum();
            sectors.push(Sector {
                apex: m,
                fan: fan.clone(),
                first,
                last,
                faces,
                alpha,
                boundary,
                curves: [a, b],
            });
        }
    }
    (sectors, curve_of)
}

/// The faces of an acute corner beyond the apex's own fan: those within `reach` of the apex
/// that the fan's faces (`wedge`) reach without crossing a curve edge and that lie between the
/// two curves' first edges `d` (seen from the apex, projected into the wedge's mean plane), with
/// their position between the curves as a fraction of the corner's angle (0 at the first
/// curve). A fan of one or two faces is a dead end of the dual graph: holding only it turns
/// the field across no path around the apex, and the smoothing takes the smallest turn round
/// it after all (a flat 20°–70°–90° triangle with its boundary aligned came out with no
/// singularity and its acute corner collapsed). Holding the faces within a cell turns every
/// path around the apex that close by (at least three of the fan's longest edges); the frame,
/// linear in the polar angle, is harmonic there.
fn beyond_the_fan(
    mesh: &TriMesh,
    curve_of: &[Option<u32>],
    apex: usize,
    wedge: &[usize],
    d: [DVec3; 2],
    reach: f64,
) -> Vec<(usize, f64)> {
    if reach <= 0.0 {
        return Vec::new();
    }
    let at = mesh.position(apex);
    // At least three rings of the fan's edges, so that paths round the apex exist when a cell
    // is smaller than the mesh's edges.
    let ring = mesh
        .outgoing(apex)
        .map(|h| mesh.vector(h).length())
        .fold(0.0, f64::max);
    let reach = reach.max(3.0 * ring);
    let normal = wedge
        .iter()
        .map(|&f| mesh.face_normal(f))
        .sum::<DVec3>()
        .normalize_or_zero();
    let flat = |x: DVec3| x - normal * normal.dot(x);
    let d1 = flat(d[0]);
    let polar = |x: DVec3| {
        let x = flat(x);
        normal.dot(d1.cross(x)).atan2(d1.dot(x))
    };
    let full = polar(d[1]);
    if normal == DVec3::ZERO || full <= 0.0 {
        return Vec::new();
    }
    faces_reached(
        mesh,
        |e| curve_of[e].is_some(),
        wedge,
        |g| {
            let centre = mesh
                .face(g)
                .iter()
                .map(|&v| mesh.position(v))
                .sum::<DVec3>()
                / 3.0;
            let beta = polar(centre - at);
            ((centre - at).length() <= reach && (0.0..=full).contains(&beta)).then(|| beta / full)
        },
    )
}

/// The faces reached from `start` across edges that are not curve edges (`is_curve`) and that
/// `accept` takes, with what it says of each (`start` itself not listed), sorted by face.
pub fn faces_reached<T>(
    mesh: &TriMesh,
    is_curve: impl Fn(usize) -> bool,
    start: &[usize],
    mut accept: impl FnMut(usize) -> Option<T>,
) -> Vec<(usize, T)> {
    let mut out = Vec::new();
    let mut seen: std::collections::BTreeSet<usize> = start.iter().copied().collect();
    let mut stack: Vec<usize> = start.to_vec();
    while let Some(f) = stack.pop() {
        for h in 3 * f..3 * f + 3 {
            if is_curve(mesh.edge(h)) {
                continue;
            }
            let Some(t) = mesh.twin(h) else { continue };
            let g = mesh.face_of(t);
            if seen.contains(&g) {
                continue;
            }
            if let Some(x) = accept(g) {
                seen.insert(g);
                stack.push(g);
                out.push((g, x));
            }
        }
    }
    out.sort_unstable_by_key(|&(f, _)| f);
    out
}

/// A corner between two curves: the apex's faces `faces` (indices into `fan`, the apex's
/// outgoing half-edges) between the curve edges `first` and `last`, spanning `alpha`.
struct Sector {
    apex: usize,
    fan: Vec<usize>,
    first: usize,
    last: usize,
    faces: Vec<usize>,
    alpha: f64,
    boundary: bool,
    /// The curves of the edges `first` and `last`.
    curves: [u32; 2],
}

/// The lattice corner (a multiple of `step` = 2π/N) each sector is held to, or None where the
/// smoothing's smallest turn is left to choose. Sectors under [`HELD_FRACTION`] of a step
/// (the acute ones, [`ACUTE_FRACTION`], among them) take one step. A boundary sector halfway
/// between two lattice corners (within [`AMBIGUOUS_BAND`] of
/// (j + ½) step: 90° for N = 6, 135° for N = 4) is a coin toss for the smoothing too (flat,
/// the relaxed field of a square's rim, N = 6, is real: +1 along two sides, −1 along the other
/// two, zero on the diagonals), and tossed independently the corners of one loop add up to
/// the wrong turn: a flat square with its boundary aligned, N = 6, got a ±1/6 pair beside a
/// corner and a patched place, a 10 × 1 rectangle four singularities. Such sectors are decided
/// per boundary loop, so that the loop's corners together turn as its geometry does: the sum
/// of (lattice corner − α) over the loop's corners, the others at their nearest lattice
/// corner, kept nearest 0, corner by corner along the loop (ties: the smaller corner), on
/// loops with at least two such corners. A disc
/// bounded by lattice lines turns by Σ (π − corner) in the plane of the map, by Σ (π − α) +
/// ∫K + ∫k_g on the surface; the difference is what its singularities must make up, and for
/// the square it is none: two corners of 60° and two of 120°. Sectors at an interior
/// apex (three creases meeting at a box's corner) are left to the smoothing: their corners
/// also make the apex a cone, which the sums do not weigh (decided by the patches, and with
/// the apex's sum as a second term, a box with features at 40°, N = 6, went from no fold to
/// 103).
fn lattice_corners(mesh: &TriMesh, sectors: &[Sector], step: f64) -> Vec<Option<f64>> {
    let ambiguous = |s: &Sector| {
        let x = s.alpha / step;
        s.boundary && x >= ACUTE_FRACTION && (x.fract() - 0.5).abs() < AMBIGUOUS_BAND
    };
    let mut out: Vec<Option<f64>> = sectors
        .iter()
        .map(|s| (s.alpha < step * HELD_FRACTION).then_some(step))
        .collect();
    if !sectors.iter().any(ambiguous) {
        return out;
    }
    // Each boundary vertex's loop and place along it.
    let loops = mesh.boundary_loops();
    let mut rank = vec![(usize::MAX, 0); mesh.n_vertices()];
    for (l, lp) in loops.iter().enumerate() {
        for (i, &h) in lp.iter().enumerate() {
            rank[mesh.from(h)] = (l, i);
        }
    }
    // Per loop the sum of (lattice corner − α) over its decided corners.
    let mut excess = vec![0.0; loops.len()];
    for (s, corner) in sectors.iter().zip(&out) {
        let l = rank[s.apex].0;
        if l < loops.len() && !ambiguous(s) {
            let c = corner.unwrap_or_else(|| step * (s.alpha / step).round().max(1.0));
            excess[l] += c - s.alpha;
        }
    }
    // Along each loop, so that a rectangle's corners alternate (a parallelogram in the map; in
    // the order of the apexes' numbers a 10 × 1 rectangle got a trapezoid, whose parallel sides
    // differ in length by more than a cell, and two singularities).
    let mut order: Vec<usize> = (0..sectors.len())
        .filter(|&i| out[i].is_none() && ambiguous(&sectors[i]))
        .collect();
    order.sort_by_key(|&i| (rank[sectors[i].apex], i));
    // A loop with a single halfway corner is left to the smoothing: balanced, it is decided by
    // the other corners' distance to their lattice corners alone (camelhead's 270° corner,
    // N = 6: the remesh's boundary along the input's 98.0 → 96.0 %). Two or more must
    // complement each other.
    let mut halfway = vec![0usize; loops.len()];
    for &i in &order {
        halfway[rank[sectors[i].apex].0] += 1;
    }
    order.retain(|&i| halfway[rank[sectors[i].apex].0] >= 2);
    for i in order {
        let s = &sectors[i];
        let l = rank[s.apex].0;
        let below = step * (s.alpha / step).floor().max(1.0);
        let above = below + step;
        let c = if (excess[l] + below - s.alpha).abs() <= (excess[l] + above - s.alpha).abs() {
            below
        } else {
            above
        };
        excess[l] += c - s.alpha;
        out[i] = Some(c);
    }
    out
}

/// Half the width of the band of corner angles, as a fraction of 2π/N around (j + ½) 2π/N,
/// that [`lattice_corners`] decides per loop: 0.05, 87°–93° for N = 6, 130.5°–139.5° for
/// N = 4. A CAD part's or a generated shape's right angles are well inside; 0.1 also took
/// corners of scanned holes (the bunny's 233° corner at the scale of its edges, N = 4), where
/// the loop's other corners are noise and the sum decided by it (4 → 10 patched places).
pub const AMBIGUOUS_BAND: f64 = 0.05;

/// Below this fraction of 2π/N a corner between two curves is acute ([`acute_corners`]): 0.52
/// (46.8° for quads) takes the 45° corners of a right isosceles triangle whatever the mesh's
/// noise; 0.6 (54°) also took a corner between 47° and 54° on the kitten with features at
/// 40°, whose smallest turn was right, and its map kept 10 folds instead of 7.
pub const ACUTE_FRACTION: f64 = 0.52;

/// Below this fraction of 2π/N a corner between two curves is held to a lattice corner of
/// 2π/N ([`lattice_corners`]), acute or not: narrower than one step it has no other corner to
/// become but 0, where its two curves would run along one line. Above [`ACUTE_FRACTION`] the
/// smoothing's smallest turn picks 2π/N too, but its choice is global: a tetrahedron with
/// features at 40° (N = 4, three corners of 60° at each apex) came out with one corner of each
/// apex at 0° at 15 000 target vertices (an apex of +1/2 instead of +1/4 and ±1/4 pairs round
/// it: 26 folded faces after the repair, 73 patched places in the remesh), and right at 1500,
/// 6500 and 30 000. At 0.9 (81° for quads) right angles, which a triangulation makes 89.99° or
/// 90.01°, are left to the smoothing as before.
pub const HELD_FRACTION: f64 = 0.9;

/// What [`acute_corners`] finds.
#[derive(Clone, Debug, Default)]
pub struct AcuteCorners {
    /// The turning frames of the faces inside the corners (and the halfway boundary corners).
    pub alignments: Vec<CurveAlignment>,
    /// The corners' apexes, sorted by vertex, without repeats.
    pub apexes: Vec<usize>,
    /// Per corner its apex and the faces of its wedge (the apex's faces between the two curves).
    pub wedges: Vec<(usize, Vec<usize>)>,
    /// Rotations to prescribe across creases between held corners ([`crease_rotations`]):
    /// first face, second face, angle.
    pub rotations: Vec<(u32, u32, f64)>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::constraint::CurveOrigin;

    fn curve(id: u32, vertices: &[usize], kind: CurveKind) -> Curve {
        Curve {
            id,
            vertices: vertices.to_vec(),
            closed: false,
            kind,
            origin: CurveOrigin::Drawn,
        }
    }

    /// A flat fan around vertex 0, its ring vertices 1..=8 at 0°, 20°, 40°, 100°, 160°, 220°,
    /// 280° and 330°.
    fn flat_fan() -> TriMesh {
        let angles = [0.0f64, 20.0, 40.0, 100.0, 160.0, 220.0, 280.0, 330.0];
        let mut positions = vec![DVec3::ZERO];
        positions.extend(
            angles
                .iter()
                .map(|a| DVec3::new(a.to_radians().cos(), a.to_radians().sin(), 0.0)),
        );
        let k = angles.len() as u32;
        let faces: Vec<[u32; 3]> = (0..k).map(|i| [0, 1 + i, 1 + (i + 1) % k]).collect();
        TriMesh::from_triangles(positions, faces).unwrap()
    }

    /// The frame's angle in degrees modulo 90° (N = 4), in [0, 90).
    fn mod90(d: DVec3) -> f64 {
        d.y.atan2(d.x).to_degrees().rem_euclid(90.0)
    }

    #[test]
    fn the_faces_of_an_acute_corner_turn_to_the_next_direction() {
        let mesh = flat_fan();
        // Two curves meeting at 0 at 40°: the two faces between them turn the frame from the
        // first curve (0°) by 40° − 90° = −50°, linearly: −12.5° and −37.5° at their middles.
        let a = curve(0, &[1, 0], CurveKind::Geometric);
        let b = curve(1, &[0, 3], CurveKind::Geometric);
        let found = acute_corners(&mesh, [&a, &b], 4, 0.0);
        let (turned, apexes) = (found.alignments, found.apexes);
        assert_eq!(apexes, vec![0]);
        assert_eq!(found.wedges.len(), 1);
        assert_eq!(found.wedges[0].1.len(), 2, "the wedge's two faces");
        assert_eq!(turned.len(), 2);
        for (t, expected) in turned.iter().zip([-12.5f64, -37.5]) {
            let f = mesh.face(t.face);
            assert!(f.contains(&0), "a face at the apex");
            let got = mod90(t.direction);
            let want = expected.rem_euclid(90.0);
            assert!((got - want).abs() < 1e-9, "{got} against {want}");
        }
        // Faces in order from the first curve: the one at 0°-20° first.
        let first = mesh.face(turned[0].face);
        assert!(first.contains(&1) && first.contains(&2));
        // Not acute for N = 6 (under 31.2° only), but under 0.9 of 60°: held to 60° all the
        // same (turned by 40° − 60° = −20°: −5° and −15° at the faces' middles), with no apex
        // or wedge for the design. None for N = 2.
        let six = acute_corners(&mesh, [&a, &b], 6, 0.0);
        assert!(six.apexes.is_empty() && six.wedges.is_empty());
        assert_eq!(six.alignments.len(), 2);
        for (t, expected) in six.alignments.iter().zip([-5.0f64, -15.0]) {
            let got = t
                .direction
                .y
                .atan2(t.direction.x)
                .to_degrees()
                .rem_euclid(60.0);
            let want = expected.rem_euclid(60.0);
            assert!((got - want).abs() < 1e-9, "N = 6: {got} against {want}");
        }
        assert!(acute_corners(&mesh, [&a, &b], 2, 0.0).alignments.is_empty());
        // A turn within one curve, or a combinatorial curve, is no corner.
        let through = curve(2, &[1, 0, 3], CurveKind::Geometric);
        assert!(
            acute_corners(&mesh, [&through], 4, 0.0)
                .alignments
                .is_empty()
        );
        let loose = curve(1, &[0, 3], CurveKind::Combinatorial);
        assert!(
            acute_corners(&mesh, [&a, &loose], 4, 0.0)
                .alignments
                .is_empty()
        );
        // A corner of 100° is none either.
        let c = curve(1, &[0, 4], CurveKind::Geometric);
        assert!(acute_corners(&mesh, [&a, &c], 4, 0.0).alignments.is_empty());
    }

    #[test]
    fn a_crease_between_two_held_single_face_corners_gets_its_rotation() {
        // Curves leave vertex 0 at 0°, 20° and 40°: two corners of 20°, one face each, both
        // held to 90°. At their faces' middles (10° into each corner) the frames are turned by
        // 10° × (20° − 90°) / 20° = −35°, from the first curve and from the second, so across
        // the crease at 20° the frame rotates by 20° − 35° + 35° − 90° = −70° (the nearest
        // turn would say +20°).
        let mesh = flat_fan();
        let a = curve(0, &[1, 0], CurveKind::Geometric);
        let b = curve(1, &[0, 2], CurveKind::Geometric);
        let c = curve(2, &[0, 3], CurveKind::Geometric);
        let found = acute_corners(&mesh, [&a, &b, &c], 4, 0.0);
        assert_eq!(found.rotations.len(), 1, "{:?}", found.rotations);
        let (f, g, rotation) = found.rotations[0];
        let (f, g) = (mesh.face(f as usize), mesh.face(g as usize));
        assert!(f.contains(&1) && f.contains(&2), "{f:?}");
        assert!(g.contains(&2) && g.contains(&3), "{g:?}");
        assert!(
            (rotation.to_degrees() + 70.0).abs() < 1e-9,
            "{}",
            rotation.to_degrees()
        );
        // Two corners of 40° and 60° (0°, 40°, 100°): two faces and one, their crease's
        // rotation within half a step, which the nearest turn gets right: none prescribed.
        let d = curve(1, &[0, 3], CurveKind::Geometric);
        let e = curve(2, &[0, 4], CurveKind::Geometric);
        assert!(
            acute_corners(&mesh, [&a, &d, &e], 4, 0.0)
                .rotations
                .is_empty()
        );
    }

    #[test]
    fn stripes_take_right_angled_curves_in_two_families() {
        // Curves leave vertex 0 at 0°, 100° and 160°.
        let mesh = flat_fan();
        let a = curve(0, &[1, 0], CurveKind::Geometric);
        let b = curve(1, &[0, 4], CurveKind::Geometric);
        let c = curve(2, &[0, 5], CurveKind::Geometric);
        let len = |c: &Curve| c.vertices.len() as f64;
        // 100° (and 260° the other way round): one along the stripes, one across.
        let across = stripe_across(&mesh, [&a, &b], len);
        assert_eq!(across.len(), 1, "{across:?}");
        // Nothing to hold: both corners are within 10° of π/2 + kπ.
        assert!(
            stripe_corners(&mesh, [&a, &b], &across, 0.0)
                .alignments
                .is_empty()
        );
        // 160° and 200°: one family.
        let across = stripe_across(&mesh, [&a, &c], len);
        assert!(across.is_empty() || across.len() == 2, "{across:?}");
        // Held in one family, both corners (100° and 260°) are held to 180°: all eight faces.
        let one = std::collections::BTreeSet::new();
        assert_eq!(
            stripe_corners(&mesh, [&a, &b], &one, 0.0).alignments.len(),
            8
        );
        // All three: 100°, 60° and 200°; the 60° corner between b and c prefers two families
        // as the 100° one does, so a and c share one: 200° is their natural corner.
        let across = stripe_across(&mesh, [&a, &b, &c], len);
        assert_eq!(across.contains(&0), across.contains(&2), "{across:?}");
        assert_ne!(across.contains(&0), across.contains(&1), "{across:?}");
    }
}

//! Singularities of positive integral index, poles (thesis sec. 4.3, alg. 6, eq. 4.3): the UV
//! sphere with frames along the parallels (a +1 vortex at both poles) for N = 2 and N = 4, the
//! same through the whole pipeline on spheroids (curvature lines), the shared meshes at N = 2,
//! the quads' seams, UV.obj round trips and extraction around a pole.

use std::f64::consts::PI;

use glam::DVec3;
use quadcover::extract::{ExtractOptions, Origin, extract};
use quadcover::field::{FieldParams, Symmetry};
use quadcover::mesh::TriMesh;
use quadcover::mesh::generate::uv_sphere;
use quadcover::param::{
    ParamOptions, Parameterization, Pole, QuadCover, fit_matchings, pipeline::field_then_quadcover,
};

#[path = "support/meshes.rs"]
mod meshes;
#[path = "support/remesh_checks.rs"]
mod remesh_checks;

/// Grid units per unit length of the frames below.
const SCALE: f64 = 4.0;

/// Per face an orthonormal frame (scaled by SCALE): U = east (along the parallels) or north
/// (along the meridians), V = n × U.
fn sphere_frames(mesh: &TriMesh, east: bool) -> Vec<[DVec3; 2]> {
    (0..mesh.n_faces())
        .map(|f| {
            let [a, b, c] = mesh.faces()[f].map(|v| mesh.position(v as usize));
            let m = (a + b + c) / 3.0;
            let n = mesh.face_normal(f);
            let e = DVec3::new(-m.y, m.x, 0.0);
            let d = if east { e } else { n.cross(e) };
            let u = (d - n * n.dot(d)).normalize() * SCALE;
            [u, n.cross(u)]
        })
        .collect()
}

fn solve(mesh: &TriMesh, n: usize, frames: &[[DVec3; 2]], no_poles: bool) -> Parameterization {
    let m = fit_matchings(mesh, n, frames);
    let opts = ParamOptions {
        no_poles,
        ..Default::default()
    };
    QuadCover::new(mesh, n, &m, opts)
        .unwrap()
        .solve(mesh, frames)
        .unwrap()
}

#[path = "support/seams.rs"]
#[allow(dead_code)] // contract_error: the poles' star edges are checked by their quads here
mod seams;

fn rot(n: usize, t: u8, p: [f64; 2]) -> [f64; 2] {
    seams::rot(n, t as usize, p)
}

fn close(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// The output contract with poles: across every interior edge the reported transition maps
/// the corners of one face onto the other's, except at a pole itself, where the star faces'
/// quads must agree instead (q_k of face k and of face k − 1 across star edge k, eq. 4.3).
/// Returns the worst error.
fn seam_error_with_poles(mesh: &TriMesh, p: &Parameterization) -> f64 {
    let n = p.symmetry;
    let pole_vertex: std::collections::HashSet<usize> = p.poles.iter().map(|x| x.vertex).collect();
    let mut worst: f64 = 0.0;
    for e in 0..mesh.n_edges() {
        let (h0, Some(h1)) = mesh.edge_halfedges(e) else {
            continue;
        };
        let t = p.transitions[e];
        let map = |x: [f64; 2]| {
            let r = rot(n, t.rotation, x);
            [r[0] + t.translation[0], r[1] + t.translation[1]]
        };
        for (ci, cj) in [(h0, mesh.next(h1)), (mesh.next(h0), h1)] {
            if pole_vertex.contains(&mesh.from(ci)) {
                continue;
            }
            worst = worst.max(close(map(p.uv[ci]), p.uv[cj]));
        }
    }
    for pole in &p.poles {
        let d = pole.faces.len();
        for k in 0..d {
            // Star edge k = (p, a_k) between faces k − 1 and k: corner q_k is quads[k][3] in
            // face k and quads[k − 1][2] in face k − 1; a_k is quads[k][0] and quads[k − 1][1].
            let (fk, fk1) = (pole.faces[k], pole.faces[(k + d - 1) % d]);
            let h = (0..3)
                .map(|c| 3 * fk + c)
                .find(|&h| mesh.from(h) == pole.vertex)
                .unwrap();
            let e = mesh.edge(h);
            let t = p.transitions[e];
            let (h0, _) = mesh.edge_halfedges(e);
            let (from, to) = if mesh.face_of(h0) == fk1 {
                (
                    [
                        pole.quads[(k + d - 1) % d][2],
                        pole.quads[(k + d - 1) % d][1],
                    ],
                    [pole.quads[k][3], pole.quads[k][0]],
                )
            } else {
                (
                    [pole.quads[k][3], pole.quads[k][0]],
                    [
                        pole.quads[(k + d - 1) % d][2],
                        pole.quads[(k + d - 1) % d][1],
                    ],
                )
            };
            for i in 0..2 {
                let r = rot(n, t.rotation, from[i]);
                worst = worst.max(close(
                    [r[0] + t.translation[0], r[1] + t.translation[1]],
                    to[i],
                ));
            }
        }
    }
    worst
}

/// How the map winds around a pole: the sum of the quads' outer edges a_j → a_{j+1}, each
/// rotated from its face's chart into face 0's by the star edges' transitions (in grid units).
fn winding(p: &Parameterization, pole: &Pole, mesh: &TriMesh) -> [f64; 2] {
    let (d, n) = (pole.faces.len(), p.symmetry as i64);
    let mut rho = 0i64; // rotation from face j's chart to face 0's
    let mut total = [0.0, 0.0];
    for j in 0..d {
        if j > 0 {
            // Star edge j between faces j − 1 and j: the rotation from j − 1 to j.
            let fj = pole.faces[j];
            let h = (0..3)
                .map(|c| 3 * fj + c)
                .find(|&h| mesh.from(h) == pole.vertex)
                .unwrap();
            let e = mesh.edge(h);
            let (h0, _) = mesh.edge_halfedges(e);
            let r = p.transitions[e].rotation as i64;
            rho -= if mesh.face_of(h0) == pole.faces[j - 1] {
                r
            } else {
                -r
            };
        }
        let q = pole.quads[j];
        let step = rot(
            p.symmetry,
            rho.rem_euclid(n) as u8,
            [q[1][0] - q[0][0], q[1][1] - q[0][1]],
        );
        total[0] += step[0];
        total[1] += step[1];
    }
    total
}

/// The polar layout survives relaxation: the vertices within `radius` of the pole lie on rings
/// around it. Their distances to the pole, sorted, fall into clusters separated by gaps of more
/// than 10 %; each cluster (a ring) must be within 5 % (zigzag rings would fill the gaps).
fn assert_rings(r: &quadcover::extract::Remesh, pole: u32, radius: f64, what: &str) {
    let c = r.positions[pole as usize];
    let mut d: Vec<f64> = r
        .positions
        .iter()
        .map(|p| (*p - c).length())
        .filter(|&x| x > 0.0 && x < radius)
        .collect();
    d.sort_by(f64::total_cmp);
    assert!(d.len() >= 3, "{what}: {} vertices near the pole", d.len());
    let mut start = 0;
    for i in 0..d.len() {
        if i + 1 == d.len() || d[i + 1] > 1.1 * d[i] {
            assert!(
                d[i] < 1.05 * d[start],
                "{what}: a ring around the pole from {} to {}",
                d[start],
                d[i]
            );
            start = i + 1;
        }
    }
}

/// The default extraction of `p` with its poles.
fn extract_with_poles(mesh: &TriMesh, p: &Parameterization) -> quadcover::extract::Remesh {
    let opts = ExtractOptions {
        poles: p.poles.clone(),
        ..Default::default()
    };
    extract(mesh, &p.uv, p.symmetry as u8, &opts).unwrap()
}

/// The vertices of positive integral index (poles) among the map's singularities.
fn positive_integral(p: &Parameterization) -> Vec<usize> {
    p.singularities
        .iter()
        .filter(|s| s.holonomy == 0 && s.index >= 1.0)
        .map(|s| s.vertex)
        .collect()
}

fn range(p: &Parameterization, c: usize) -> f64 {
    let lo = p.uv.iter().map(|x| x[c]).fold(f64::INFINITY, f64::min);
    let hi = p.uv.iter().map(|x| x[c]).fold(f64::NEG_INFINITY, f64::max);
    hi - lo
}

/// Per face the angle cosine between the gradient of texture coordinate `c` and `dir(face)`.
fn gradient_alignment(mesh: &TriMesh, p: &Parameterization, c: usize, east: bool) -> f64 {
    let frames = sphere_frames(mesh, east);
    let mut worst: f64 = 1.0;
    for f in 0..mesh.n_faces() {
        let [a, b, d] = mesh.faces()[f].map(|v| mesh.position(v as usize));
        let (u0, u1, u2) = (p.uv[3 * f][c], p.uv[3 * f + 1][c], p.uv[3 * f + 2][c]);
        let n = (b - a).cross(d - a);
        let area2 = n.length_squared();
        // ∇u = Σ u_i (n × e_i) / |n|², e_i the edge opposite corner i.
        let g = (n.cross(d - b) * u0 + n.cross(a - d) * u1 + n.cross(b - a) * u2) / area2;
        let dir = frames[f][0];
        worst = worst.min((g.dot(dir) / (g.length() * dir.length())).abs());
    }
    worst
}

/// Two +1 vortices (N = 2: +2/2): stripes of u (U along the meridians) are latitude circles
/// around both poles over the whole meridian; v winds around each pole. Without alg. 6 the
/// winding coordinate collapses and the map folds everywhere (fig. 4.14, left).
#[test]
fn stripes_on_the_uv_sphere_are_latitude_circles_around_both_poles() {
    let mesh = uv_sphere(24, 32);
    let frames = sphere_frames(&mesh, false);
    let p = solve(&mesh, 2, &frames, false);
    let poles: Vec<(usize, f64)> = p.poles.iter().map(|x| (x.vertex, x.index)).collect();
    assert_eq!(poles, vec![(0, 1.0), (mesh.n_vertices() - 1, 1.0)]);
    assert!(p.untreated_poles.is_empty());
    assert_eq!(p.flipped_faces, 0);
    let seam = seam_error_with_poles(&mesh, &p);
    assert!(seam < 1e-6, "seam error {seam:e}");
    // The stripe coordinate u runs pole to pole: at least 90 % of π · SCALE.
    let ideal = PI * SCALE;
    assert!(
        range(&p, 0) >= 0.9 * ideal,
        "u range {} of {ideal}",
        range(&p, 0)
    );
    // Its iso-lines are latitude circles: its gradient points along the meridians.
    let align = gradient_alignment(&mesh, &p, 0, false);
    assert!(
        align > 0.95,
        "worst |cos| between ∇u and the meridian: {align}"
    );
    // v winds around each pole by a whole number of grid units, not 0.
    for pole in &p.poles {
        let w = winding(&p, pole, &mesh);
        assert!(
            w[1].abs() >= 5.0 && (w[1] - w[1].round()).abs() < 1e-6,
            "winding {w:?}"
        );
        assert!(w[0].abs() < 1e-6, "u does not wind: {w:?}");
    }
    // The stripes: closed latitude circles (constant z), as many as the integer levels of u.
    let r = extract_with_poles(&mesh, &p);
    assert!(r.polylines.len() >= 10, "{} stripes", r.polylines.len());
    for l in &r.polylines {
        let z: Vec<f64> = l.iter().map(|&v| r.positions[v as usize].z).collect();
        let spread = z.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - z.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(spread < 0.05, "a stripe spans {spread} in z");
    }

    // Without alg. 6 the same frames fold the map: the construction needs the treatment.
    let plain = solve(&mesh, 2, &frames, true);
    assert!(plain.poles.is_empty());
    assert!(
        plain.flipped_faces > 100,
        "{} folds without alg. 6",
        plain.flipped_faces
    );
}

/// Stripes along the parallels' normal direction (U east): now u is the winding coordinate,
/// its stripes are meridians meeting at both poles; without alg. 6 u collapses to a constant.
#[test]
fn winding_stripes_meet_at_the_poles_instead_of_collapsing() {
    let mesh = uv_sphere(24, 32);
    let frames = sphere_frames(&mesh, true);
    let p = solve(&mesh, 2, &frames, false);
    assert_eq!(p.poles.len(), 2);
    assert_eq!(p.flipped_faces, 0);
    assert!(seam_error_with_poles(&mesh, &p) < 1e-6);
    let w = winding(&p, &p.poles[0], &mesh);
    assert!(w[0].abs() >= 5.0, "u winds around the pole: {w:?}");
    assert!(range(&p, 1) >= 0.9 * PI * SCALE);
    let plain = solve(&mesh, 2, &frames, true);
    assert!(
        range(&plain, 0) < 1e-3 * range(&p, 0),
        "untreated u range {}",
        range(&plain, 0)
    );

    // The stripes of u: meridians, each running into both poles (welded pole vertices).
    let r = extract_with_poles(&mesh, &p);
    let at_pole = |v: u32| matches!(r.origins[v as usize], Origin::Vertex(x) if x == 0 || x as usize == mesh.n_vertices() - 1);
    assert_eq!(r.polylines.len() as f64, w[0].abs().round());
    for l in &r.polylines {
        assert!(
            at_pole(l[0]) && at_pole(*l.last().unwrap()),
            "a meridian stripe ends off the poles"
        );
    }
}

/// N = 4 with two +4/4 poles: seamless quads, no folds, the latitude coordinate over the whole
/// meridian; the remesh is all quads, manifold, a sphere, with one vertex at each pole.
#[test]
fn quads_around_two_plus_four_quarter_poles() {
    let mesh = uv_sphere(24, 32);
    for pure_quad in [false, true] {
        let frames = sphere_frames(&mesh, true);
        let m = fit_matchings(&mesh, 4, &frames);
        let opts = ParamOptions {
            pure_quad,
            ..Default::default()
        };
        let p = QuadCover::new(&mesh, 4, &m, opts)
            .unwrap()
            .solve(&mesh, &frames)
            .unwrap();
        let what = format!("pure_quad {pure_quad}");
        assert_eq!(
            p.poles.iter().map(|x| x.index).collect::<Vec<_>>(),
            vec![1.0, 1.0],
            "{what}"
        );
        assert_eq!(p.flipped_faces, 0, "{what}");
        assert!(seam_error_with_poles(&mesh, &p) < 1e-6, "{what}");
        assert!(
            range(&p, 1) >= 0.9 * PI * SCALE,
            "{what}: v range {}",
            range(&p, 1)
        );
        for pole in &p.poles {
            assert!(
                (0..pole.faces.len()).all(|j| !pole.quad_folded(j)),
                "{what}"
            );
            let w = winding(&p, pole, &mesh);
            assert!(w[0].abs() >= 5.0, "{what}: {w:?}");
            if pure_quad {
                let half = w[0] / 2.0;
                assert!(
                    (half - half.round()).abs() < 1e-6,
                    "{what}: 2Z² gaps, even winding {w:?}"
                );
            }
        }
        let opts = ExtractOptions {
            poles: p.poles.clone(),
            ..Default::default()
        };
        let r = extract(&mesh, &p.uv, 4, &opts).unwrap();
        remesh_checks::assert_manifold(&r, &what);
        assert!(
            r.faces.iter().all(|f| f.len() == 4),
            "{what}: not all quads"
        );
        assert_eq!(r.euler_characteristic(), 2, "{what}");
        for pv in [0, mesh.n_vertices() - 1] {
            let ids: Vec<usize> = (0..r.positions.len())
                .filter(|&v| r.origins[v] == Origin::Vertex(pv as u32))
                .collect();
            assert_eq!(ids.len(), 1, "{what}: one output vertex at pole {pv}");
            let valence = r
                .faces
                .iter()
                .filter(|f| f.contains(&(ids[0] as u32)))
                .count();
            assert!(valence >= 3, "{what}: pole valence {valence}");
            let first = r
                .faces
                .iter()
                .filter_map(|f| {
                    let k = f.iter().position(|&v| v == ids[0] as u32)?;
                    Some(
                        (r.positions[f[(k + 1) % f.len()] as usize] - r.positions[ids[0]]).length(),
                    )
                })
                .fold(0.0f64, f64::max);
            assert_rings(&r, ids[0] as u32, 1.01 * first, &what);
        }
    }
}

/// Curvature lines of spheroids through the whole pipeline: the prolate one's umbilics are two
/// +4/4 poles at N = 4, the oblate one's two +2/2 at N = 2, a 6/6 at N = 6; all treated,
/// seamless, unfolded, and the remesh keeps its polar rings.
#[test]
fn spheroid_umbilics_are_treated_poles() {
    // The prolate one at N = 2 keeps one +2/2 pole (the other splits) whose ring runs
    // backwards in places: eq. 4.3's inner corners fold three quads there until they move.
    let cases = [
        (4, 1.6, Symmetry::Four),
        (2, 0.6, Symmetry::Two),
        (2, 1.6, Symmetry::Two),
        (6, 1.6, Symmetry::Six),
    ];
    for (n, stretch, symmetry) in cases {
        let mut mesh = uv_sphere(24, 32);
        let pos: Vec<DVec3> = mesh
            .positions()
            .iter()
            .map(|p| DVec3::new(p.x, p.y, p.z * stretch))
            .collect();
        mesh.set_positions(pos);
        let params = FieldParams {
            symmetry,
            ..Default::default()
        };
        // The command line's default for N = 4: gaps in 2Z², so an even winding around the
        // poles, whose fans of triangles then join into quads pairwise.
        let opts = ParamOptions {
            pure_quad: n == 4,
            ..Default::default()
        };
        let (field, qc) = field_then_quadcover(&mesh, &params, n, &opts).unwrap();
        let p = qc.solve(&mesh, &field.field.frames).unwrap();
        let what = format!("N = {n}, z × {stretch}");
        let integral = positive_integral(&p);
        assert!(
            !integral.is_empty(),
            "{what}: expected poles at the umbilics"
        );
        let treated: Vec<usize> = p.poles.iter().map(|x| x.vertex).collect();
        assert_eq!(treated, integral, "{what}");
        assert_eq!(p.flipped_faces, 0, "{what}");
        assert!(seam_error_with_poles(&mesh, &p) < 1e-6, "{what}");
        if n != 2 {
            // At N = 4 about 76 grid lines run into each pole: relaxation left free would pull
            // the thin polar cells into zigzag rings. N = 6 keeps one 6/6 pole (the other
            // splits): a fan of triangles.
            let r = extract_with_poles(&mesh, &p);
            remesh_checks::assert_manifold(&r, &what);
            assert!(
                r.faces
                    .iter()
                    .all(|f| f.len() == if n == 4 { 4 } else { 3 }),
                "{what}"
            );
            assert_eq!(r.euler_characteristic(), 2, "{what}");
            for pole in &p.poles {
                let v = (0..r.positions.len())
                    .find(|&v| r.origins[v] == Origin::Vertex(pole.vertex as u32))
                    .unwrap();
                // (N = 6: the rows of the triangle lattice inside the star are bilinear images,
                // up to 7 % off a circle at the first row; only the quads' rings are checked.)
                if n == 4 {
                    assert_rings(&r, v as u32, 0.3, &what);
                }
            }
        }
    }
}

/// The shared meshes at N = 2 (the default field): every singularity of positive integral
/// index is treated, and no star quad folds.
#[test]
fn shared_meshes_leave_no_pole_untreated_at_n2() {
    for name in meshes::EVERY_BUT_IGEA {
        let Some(mesh) = meshes::load_shared(name) else {
            return;
        };
        let params = FieldParams {
            symmetry: Symmetry::Two,
            ..Default::default()
        };
        let (field, qc) =
            field_then_quadcover(&mesh, &params, 2, &ParamOptions::default()).unwrap();
        let p = qc.solve(&mesh, &field.field.frames).unwrap();
        let integral = positive_integral(&p);
        let treated: Vec<usize> = p.poles.iter().map(|x| x.vertex).collect();
        assert_eq!(treated, integral, "{name}");
        assert!(p.untreated_poles.is_empty(), "{name}");
        for pole in &p.poles {
            assert!(
                (0..pole.faces.len()).all(|j| !pole.quad_folded(j)),
                "{name}"
            );
        }
        assert!(seam_error_with_poles(&mesh, &p) < 1e-6, "{name}");
    }
}

/// UV.obj writes the star faces as quads `a b p p` with the quads' coordinates; reading it back
/// gives the same poles (what `quadcover extract` does), and the same remesh.
#[test]
fn uv_obj_round_trips_pole_quads() {
    let mesh = uv_sphere(16, 20);
    let frames = sphere_frames(&mesh, true);
    let p = solve(&mesh, 4, &frames, false);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("uv.obj");
    quadcover::export::write_uv_obj(&path, &mesh, &p.uv, &p.poles).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let quads = text
        .lines()
        .filter(|l| l.starts_with("f ") && l.split_whitespace().count() == 5);
    assert_eq!(quads.count(), 40, "two stars of 20 faces");
    let data = quadcover::io::read_obj_bytes(text.as_bytes()).unwrap();
    // Face order kept; a quad's triangle starts at a_j instead of the pole.
    assert_eq!(data.soup.triangles.len(), mesh.n_faces());
    for (f, t) in data.soup.triangles.iter().enumerate() {
        let m = mesh.faces()[f];
        assert!(
            (0..3).any(|r| (0..3).all(|k| t[k] == m[(k + r) % 3])),
            "face {f} changed"
        );
    }
    assert_eq!(data.pole_quads.len(), 40);
    let file_quads: Vec<quadcover::param::FileQuad> = data
        .pole_quads
        .iter()
        .map(|q| quadcover::param::FileQuad {
            face: q.triangle,
            vertices: data.soup.triangles[q.triangle].map(|v| v as usize),
            uv: q.uv,
        })
        .collect();
    let back = quadcover::param::poles_from_quads(&mesh, &file_quads).unwrap();
    assert_eq!(back.len(), 2);
    for (a, b) in back.iter().zip(&p.poles) {
        assert_eq!(
            (a.vertex, &a.faces, &a.ring, &a.quads),
            (b.vertex, &b.faces, &b.ring, &b.quads)
        );
    }
    // A star with a triangle left is an error naming the vertex, not a panic.
    let err = quadcover::param::poles_from_quads(&mesh, &file_quads[1..]).unwrap_err();
    assert!(err.contains("vertex"), "{err}");
}

//! Unit tests of connectivity, validation, geometry and topology on small generated meshes.

use std::f64::consts::{PI, TAU};

use glam::DVec3;
use proptest::prelude::*;

use super::generate::{cylinder, disc, grid, icosphere, subdivide, torus};
use super::*;

fn octahedron() -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let p = vec![
        DVec3::X,
        DVec3::Y,
        DVec3::NEG_X,
        DVec3::NEG_Y,
        DVec3::Z,
        DVec3::NEG_Z,
    ];
    let f = vec![
        [0, 1, 4],
        [1, 2, 4],
        [2, 3, 4],
        [3, 0, 4],
        [1, 0, 5],
        [2, 1, 5],
        [3, 2, 5],
        [0, 3, 5],
    ];
    (p, f)
}

/// Structural invariants every built mesh must satisfy.
fn check_invariants(m: &TriMesh) {
    for h in 0..m.n_halfedges() {
        if let Some(t) = m.twin(h) {
            assert_eq!(m.twin(t), Some(h));
            assert_eq!(m.from(t), m.to(h));
            assert_eq!(m.to(t), m.from(h));
            assert_eq!(m.edge(t), m.edge(h));
        }
        assert_eq!(m.next(m.prev(h)), h);
        assert_eq!(m.face_of(m.next(h)), m.face_of(h));
    }
    let mut incident = vec![0usize; m.n_vertices()];
    for f in m.faces() {
        for &v in f {
            incident[v as usize] += 1;
        }
    }
    for v in 0..m.n_vertices() {
        let out: Vec<usize> = m.outgoing(v).collect();
        assert_eq!(out.len(), incident[v], "fan of vertex {v} is incomplete");
        assert!(out.iter().all(|&h| m.from(h) == v));
    }
}

fn gauss_bonnet(m: &TriMesh) -> f64 {
    (0..m.n_vertices()).map(|v| m.angle_defect(v)).sum::<f64>()
        - TAU * m.euler_characteristic() as f64
}

#[test]
fn octahedron_is_a_closed_sphere() {
    let (p, f) = octahedron();
    let m = TriMesh::from_triangles(p, f).unwrap();
    check_invariants(&m);
    let t = m.topology();
    assert_eq!((t.vertices, t.edges, t.faces), (6, 12, 8));
    assert_eq!(
        (t.euler_characteristic, t.genus, t.boundary_loops),
        (2, 0, 0)
    );
    assert!(gauss_bonnet(&m).abs() < 1e-12);
    // Each vertex of the octahedron has 4 right angles around it: defect 2π − 4·π/3.
    assert!((m.angle_defect(0) - (TAU - 4.0 * PI / 3.0)).abs() < 1e-12);
}

#[test]
fn one_rings_are_counter_clockwise_about_the_normal() {
    let m = icosphere(2);
    check_invariants(&m);
    let normals = m.vertex_normals();
    for v in 0..m.n_vertices() {
        let ring = m.one_ring(v);
        let c = m.position(v);
        for k in 0..ring.len() {
            let a = m.position(ring[k]) - c;
            let b = m.position(ring[(k + 1) % ring.len()]) - c;
            assert!(
                a.cross(b).dot(normals[v]) > 0.0,
                "ring of {v} not CCW at {k}"
            );
        }
    }
}

#[test]
fn generated_meshes_have_their_known_topology() {
    let cases: Vec<(&str, TriMesh, i64, usize, i64)> = vec![
        ("grid", grid(4, 3, 1.0, 1.0), 1, 1, 0),
        ("disc", disc(1.0, 6), 1, 1, 0),
        ("cylinder", cylinder(1.0, 2.0, 12, 4), 0, 2, 0),
        ("torus", torus(2.0, 0.5, 16, 8), 0, 0, 1),
        ("icosphere", icosphere(1), 2, 0, 0),
    ];
    for (name, m, chi, loops, genus) in cases {
        check_invariants(&m);
        let t = m.topology();
        assert_eq!(t.euler_characteristic, chi, "{name}");
        assert_eq!(t.boundary_loops, loops, "{name}");
        assert_eq!(t.genus, genus, "{name}");
        assert!(
            gauss_bonnet(&m).abs() < 1e-9,
            "{name}: Gauss–Bonnet off by {}",
            gauss_bonnet(&m)
        );
    }
}

#[test]
fn boundary_loops_follow_the_boundary_in_order() {
    let m = grid(4, 3, 1.0, 1.0);
    let loops = m.boundary_loops();
    assert_eq!(loops.len(), 1);
    assert_eq!(loops[0].len(), 2 * (4 + 3));
    for w in loops[0].windows(2) {
        assert_eq!(m.to(w[0]), m.from(w[1]));
    }
    assert_eq!(m.to(*loops[0].last().unwrap()), m.from(loops[0][0]));
    // The surface lies on the left: the loop runs counter-clockwise around the grid.
    let area: f64 = loops[0]
        .iter()
        .map(|&h| {
            let (a, b) = (m.position(m.from(h)), m.position(m.to(h)));
            a.x * b.y - b.x * a.y
        })
        .sum();
    assert!((area / 2.0 - 1.0).abs() < 1e-12);
}

#[test]
fn geometry_of_a_right_triangle() {
    let m =
        TriMesh::from_triangles(vec![DVec3::ZERO, DVec3::X, DVec3::Y], vec![[0, 1, 2]]).unwrap();
    assert!((m.face_area(0) - 0.5).abs() < 1e-15);
    assert_eq!(m.face_normal(0), DVec3::Z);
    assert!((m.corner_angle(0) - PI / 2.0).abs() < 1e-15);
    assert!((m.corner_angle(1) - PI / 4.0).abs() < 1e-15);
    let (e1, e2) = m.face_basis(0);
    assert_eq!((e1, e2), (DVec3::X, DVec3::Y));
    // Edge 0→1 is opposite the 45° corner at vertex 2: weight ½ cot 45° = ½.
    assert!((m.cotan_weight(m.edge(0)) - 0.5).abs() < 1e-15);
}

#[test]
fn subdivision_keeps_topology_and_quadruples_faces() {
    let m = torus(2.0, 0.5, 8, 6);
    let s = subdivide(&m);
    assert_eq!(s.n_faces(), 4 * m.n_faces());
    assert_eq!(s.topology().genus, 1);
    check_invariants(&s);
}

// --- validation -----------------------------------------------------------------------------

fn tri(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

#[test]
fn three_faces_on_one_edge_is_a_non_manifold_edge() {
    let p = vec![
        tri([0., 0., 0.]),
        tri([1., 0., 0.]),
        tri([0., 1., 0.]),
        tri([0., -1., 0.]),
        tri([0., 0., 1.]),
    ];
    let err = TriMesh::from_triangles(p, vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]]).unwrap_err();
    match err {
        MeshError::NonManifoldEdge {
            count,
            v0,
            v1,
            faces,
            ..
        } => {
            assert_eq!((count, v0.min(v1), v0.max(v1), faces), (1, 0, 1, 3));
        }
        e => panic!("wrong error {e}"),
    }
}

#[test]
fn two_fans_at_one_vertex_is_a_non_manifold_vertex() {
    let p = vec![
        tri([0., 0., 0.]),
        tri([1., 0., 0.]),
        tri([0., 1., 0.]),
        tri([-1., 0., 0.]),
        tri([0., -1., 0.]),
    ];
    let err = TriMesh::from_triangles(p, vec![[0, 1, 2], [0, 3, 4]]).unwrap_err();
    assert!(
        matches!(
            err,
            MeshError::NonManifoldVertex {
                count: 1,
                fans: 2,
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("vertex 0"), "{err}");
}

#[test]
fn moebius_strip_is_non_orientable() {
    // A band of 6 quads whose ends are glued with a half twist.
    let n = 6;
    let mut p = Vec::new();
    for i in 0..n {
        let a = PI * i as f64 / n as f64 * 2.0;
        let w = a / 2.0;
        for s in [-0.3, 0.3] {
            let r = 1.0 + s * w.cos();
            p.push(DVec3::new(r * a.cos(), r * a.sin(), s * w.sin()));
        }
    }
    let mut f = Vec::new();
    for i in 0..n {
        let (a, b) = (2 * i as u32, 2 * i as u32 + 1);
        let (c, d) = if i + 1 < n { (a + 2, b + 2) } else { (1, 0) };
        f.push([a, c, d]);
        f.push([a, d, b]);
    }
    let err = TriMesh::from_triangles(p.clone(), f.clone()).unwrap_err();
    assert!(matches!(err, MeshError::NonOrientable { .. }), "{err}");
}

/// The face a non-orientable surface's conflict is reported at is the same every time: it
/// depended on a hash map's order (a Klein bottle's name changed from run to run).
#[test]
fn non_orientable_conflict_is_reported_at_one_face() {
    // A Möbius band of n × m quads: column n is column 0 with its rows reversed.
    let (n, m) = (40, 8);
    let mut p = Vec::new();
    for i in 0..n {
        let a = PI * i as f64 / n as f64 * 2.0;
        for j in 0..=m {
            let s = -0.3 + 0.6 * j as f64 / m as f64;
            let r = 1.0 + s * (a / 2.0).cos();
            p.push(DVec3::new(r * a.cos(), r * a.sin(), s * (a / 2.0).sin()));
        }
    }
    let at = |i: usize, j: usize| {
        let (i, j) = if i == n { (0, m - j) } else { (i, j) };
        (i * (m + 1) + j) as u32
    };
    let mut f = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            f.push([a, b, c]);
            f.push([a, c, d]);
        }
    }
    let first = TriMesh::from_triangles(p.clone(), f.clone()).unwrap_err();
    assert!(matches!(first, MeshError::NonOrientable { .. }), "{first}");
    for _ in 0..16 {
        let again = TriMesh::from_triangles(p.clone(), f.clone()).unwrap_err();
        assert_eq!(again.to_string(), first.to_string());
    }
}

#[test]
fn inconsistent_orientation_is_repaired_with_a_warning() {
    let (p, mut f) = octahedron();
    f[2].swap(0, 1);
    f[6].swap(1, 2);
    let soup = PolygonSoup {
        positions: p,
        triangles: f,
        ..Default::default()
    };
    let (m, report) = TriMesh::from_soup(&soup).unwrap();
    assert_eq!(report.flipped_faces, vec![2, 6]);
    assert!(
        report.warnings[0].contains("re-oriented 2 face"),
        "{:?}",
        report.warnings
    );
    check_invariants(&m);
    assert_eq!(m.topology().genus, 0);
    // Outward normals everywhere again (the octahedron is centred at the origin).
    assert!((0..8).all(|f| m.face_normal(f).dot(m.face_centroid(f)) > 0.0));
}

#[test]
fn duplicates_and_unreferenced_vertices_are_dropped_keeping_order() {
    let (mut p, mut f) = octahedron();
    p.insert(0, DVec3::splat(9.0)); // unreferenced
    for t in &mut f {
        for v in t.iter_mut() {
            *v += 1;
        }
    }
    f.push([f[3][1], f[3][2], f[3][0]]); // same face, rotated
    let soup = PolygonSoup {
        positions: p,
        triangles: f,
        ..Default::default()
    };
    let (m, report) = TriMesh::from_soup(&soup).unwrap();
    assert_eq!((m.n_vertices(), m.n_faces()), (6, 8));
    assert_eq!(report.original_vertex, vec![1, 2, 3, 4, 5, 6]);
    assert_eq!(report.original_face, (0..8).collect::<Vec<u32>>());
    assert_eq!(report.warnings.len(), 2, "{:?}", report.warnings);
}

/// Two triangles meeting along an edge by position but not by index (an unwelded soup): built
/// as they are (two components, four boundary edges each side), with a warning naming the
/// first doubled vertex; welded ones, and a closed mesh, get none.
#[test]
fn an_unwelded_soup_is_warned_about() {
    let p = vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
    ];
    let soup = PolygonSoup {
        positions: p.clone(),
        triangles: vec![[0, 1, 2], [3, 4, 5]],
        ..Default::default()
    };
    let (m, report) = TriMesh::from_soup(&soup).unwrap();
    assert_eq!(m.n_vertices(), 6);
    assert_eq!(report.warnings.len(), 1, "{:?}", report.warnings);
    assert!(
        report.warnings[0].contains("2 boundary vertex(es) lie exactly on another one")
            && report.warnings[0].contains("vertex 3"),
        "{:?}",
        report.warnings
    );
    let welded = PolygonSoup {
        positions: vec![p[0], p[1], p[2], p[4]],
        triangles: vec![[0, 1, 2], [1, 3, 2]],
        ..Default::default()
    };
    assert!(TriMesh::from_soup(&welded).unwrap().1.warnings.is_empty());
    let (p, f) = octahedron();
    let closed = PolygonSoup {
        positions: p,
        triangles: f,
        ..Default::default()
    };
    assert!(TriMesh::from_soup(&closed).unwrap().1.warnings.is_empty());
}

#[test]
fn degenerate_nan_range_and_empty_inputs_are_errors() {
    let p = vec![
        tri([0., 0., 0.]),
        tri([1., 0., 0.]),
        tri([2., 0., 0.]),
        tri([0., 1., 0.]),
    ];
    let e = TriMesh::from_triangles(p.clone(), vec![[0, 1, 3], [0, 1, 2]]).unwrap_err();
    assert!(
        matches!(e, MeshError::DegenerateFace { count: 1, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("face 1"), "{e}");
    let e = TriMesh::from_triangles(p.clone(), vec![[0, 1, 3], [0, 0, 3]]).unwrap_err();
    assert!(matches!(e, MeshError::DegenerateFace { .. }), "{e}");
    let e = TriMesh::from_triangles(p.clone(), vec![[0, 1, 7]]).unwrap_err();
    assert!(
        matches!(
            e,
            MeshError::IndexOutOfRange {
                index: 7,
                vertex_count: 4,
                ..
            }
        ),
        "{e}"
    );
    let mut q = p.clone();
    q[3].y = f64::NAN;
    let e = TriMesh::from_triangles(q, vec![[0, 1, 3]]).unwrap_err();
    assert!(e.to_string().contains("vertex 3"), "{e}");
    assert!(matches!(
        TriMesh::from_triangles(p, vec![]),
        Err(MeshError::Empty(_))
    ));
    assert!(matches!(
        TriMesh::from_triangles(vec![], vec![]),
        Err(MeshError::Empty(_))
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]
    /// Random soups over a few vertices: building never panics, and what builds is consistent.
    #[test]
    fn random_soups_build_or_fail_cleanly(
        faces in prop::collection::vec(prop::array::uniform3(0u32..9), 1..14),
        jitter in prop::collection::vec(-1.0f64..1.0, 27),
    ) {
        let p: Vec<DVec3> = (0..9).map(|i| DVec3::new(jitter[3*i], jitter[3*i+1], jitter[3*i+2])).collect();
        if let Ok(m) = TriMesh::from_triangles(p, faces) {
            check_invariants(&m);
            let t = m.topology();
            let sum_chi: i64 = t.components.iter().map(|c| c.euler_characteristic).sum();
            prop_assert_eq!(sum_chi, t.euler_characteristic);
            prop_assert!(gauss_bonnet(&m).abs() < 1e-6);
        }
    }
}

/// Coordinates so large that face areas overflow are refused by name (an octahedron at 1e300
/// was "a mesh of zero area" to the field); one at 1e70 is fine.
#[test]
fn coordinates_whose_squares_overflow_are_refused() {
    let (p, f) = octahedron();
    let huge: Vec<DVec3> = p.iter().map(|x| *x * 1e300).collect();
    let e = TriMesh::from_triangles(huge, f.clone()).unwrap_err();
    assert!(matches!(e, MeshError::Huge { count: 6, .. }), "{e}");
    assert!(e.to_string().contains("vertex 0"), "{e}");
    let large: Vec<DVec3> = p.iter().map(|x| *x * 1e70).collect();
    let m = TriMesh::from_triangles(large, f).unwrap();
    assert!(m.total_area().is_finite() && m.total_area() > 0.0);
}

/// A remesh asked for far too many vertices is refused before any work (a torus at 10⁸
/// target vertices filled 9.7 GB within a minute).
#[test]
fn a_remesh_past_the_vertex_limit_is_refused() {
    use crate::mesh::isotropic::{IsotropicOptions, MAX_VERTICES, isotropic_remesh};
    let (p, f) = octahedron();
    let m = TriMesh::from_triangles(p, f).unwrap();
    let opts = IsotropicOptions::for_vertices(&m, (4.0 * MAX_VERTICES) as usize, 35.0);
    let e = isotropic_remesh(&m, &opts).unwrap_err();
    assert!(matches!(e, MeshError::TooLarge { .. }), "{e}");
    let fine = IsotropicOptions::for_vertices(&m, 500, 35.0);
    assert!(isotropic_remesh(&m, &fine).is_ok());
}

//! Feature and boundary curves on real meshes (shared/meshes): every chosen edge on exactly one
//! curve, every curve a valid edge path, curves ending exactly at split points.

use std::collections::HashMap;

use quadcover::constraint::detect::SHARP_TURN_DEG;
use quadcover::constraint::{
    DetectedCurve, boundary_curves, check_path, detect_features, feature_edges, halfedge_between,
};
use quadcover::mesh::TriMesh;

#[path = "support/meshes.rs"]
mod meshes;
use meshes::shared;

fn load(name: &str) -> Option<TriMesh> {
    shared(name).map(|p| quadcover::load::load_mesh(&p).unwrap().mesh)
}

fn curve_edges(mesh: &TriMesh, c: &DetectedCurve) -> Vec<usize> {
    let v = &c.vertices;
    let n = v.len();
    (0..n - 1)
        .map(|i| (i, i + 1))
        .chain(c.closed.then_some((n - 1, 0)))
        .map(|(i, j)| mesh.edge(halfedge_between(mesh, v[i], v[j]).unwrap()))
        .collect()
}

/// Checks `curves` against the rules: valid paths, `chosen` covered exactly once and nothing
/// else, interior vertices no split points, open ends split points (or the half-way cut of a
/// loop with one split point, shared by two consecutive curves), output by smallest edge id.
fn check_rules(mesh: &TriMesh, curves: &[DetectedCurve], chosen: &[usize], boundary_splits: bool) {
    let mut count: HashMap<usize, usize> = HashMap::new();
    let mut smallest = Vec::new();
    for c in curves {
        check_path(mesh, &c.vertices, c.closed).unwrap_or_else(|e| panic!("{c:?}: {e}"));
        let es = curve_edges(mesh, c);
        smallest.push(*es.iter().min().unwrap());
        for e in es {
            *count.entry(e).or_default() += 1;
        }
    }
    for &e in chosen {
        assert_eq!(count.remove(&e), Some(1), "edge {e}");
    }
    assert!(count.is_empty(), "edges not chosen on curves: {count:?}");
    // Non-decreasing (the two halves of a one-split loop are in walking order, not sorted).
    let mut chain_min = smallest.clone();
    for i in 1..curves.len() {
        let (a, b) = (&curves[i - 1], &curves[i]);
        if a.vertices.last() == b.vertices.first() && a.vertices[0] == *b.vertices.last().unwrap() {
            chain_min[i] = chain_min[i].min(chain_min[i - 1]);
            chain_min[i - 1] = chain_min[i];
        }
    }
    assert!(chain_min.windows(2).all(|w| w[0] <= w[1]));

    let mut adj: HashMap<usize, Vec<usize>> = HashMap::new();
    for &e in chosen {
        let [a, b] = mesh.edge_vertices(e);
        adj.entry(a).or_default().push(b);
        adj.entry(b).or_default().push(a);
    }
    let sharp = SHARP_TURN_DEG.to_radians();
    let is_split = |v: usize| {
        let n = &adj[&v];
        if n.len() != 2 || (boundary_splits && mesh.is_boundary_vertex(v)) {
            return true;
        }
        let a = mesh.position(v) - mesh.position(n[0]);
        let b = mesh.position(n[1]) - mesh.position(v);
        a.angle_between(b) > sharp
    };
    for (i, c) in curves.iter().enumerate() {
        let v = &c.vertices;
        let inner = if c.closed { &v[..] } else { &v[1..v.len() - 1] };
        for &x in inner {
            assert!(!is_split(x), "curve {i} passes split point {x}");
        }
        if c.closed {
            continue;
        }
        let last = *v.last().unwrap();
        if !is_split(v[0]) {
            let prev = &curves[i - 1];
            assert_eq!(
                prev.vertices.last(),
                Some(&v[0]),
                "curve {i} starts off a split"
            );
            assert!(is_split(last) && prev.vertices[0] == last);
        }
        if !is_split(last) {
            let next = &curves[i + 1];
            assert_eq!(
                next.vertices.first(),
                Some(&last),
                "curve {i} ends off a split"
            );
            assert!(is_split(v[0]) && *next.vertices.last().unwrap() == v[0]);
        }
    }
}

fn summary(curves: &[DetectedCurve]) -> String {
    let closed = curves.iter().filter(|c| c.closed).count();
    let edges: usize = curves
        .iter()
        .map(|c| c.vertices.len() - usize::from(!c.closed))
        .sum();
    format!(
        "{} curves ({closed} closed, {} open), {edges} edges",
        curves.len(),
        curves.len() - closed
    )
}

fn boundary_edges(mesh: &TriMesh) -> Vec<usize> {
    (0..mesh.n_edges())
        .filter(|&e| mesh.is_boundary_edge(e))
        .collect()
}

#[test]
fn fandisk_features_cover_every_feature_edge_once() {
    let Some(m) = load("fandisk.obj") else {
        return;
    };
    for angle in [35.0, 40.0] {
        let fe = feature_edges(&m, angle);
        let curves = detect_features(&m, angle, 0.0);
        eprintln!(
            "fandisk {angle}°: {} feature edges, {}",
            fe.len(),
            summary(&curves)
        );
        assert!(!fe.is_empty());
        check_rules(&m, &curves, &fe, true);
        assert_eq!(curves, detect_features(&m, angle, 0.0), "deterministic");
    }
}

#[test]
fn camelhead_boundary_covers_every_boundary_edge_once() {
    let Some(m) = load("camelhead.obj") else {
        return;
    };
    let be = boundary_edges(&m);
    let curves = boundary_curves(&m, 0.0);
    eprintln!(
        "camelhead boundary: {} edges, {}",
        be.len(),
        summary(&curves)
    );
    assert!(!curves.is_empty());
    check_rules(&m, &curves, &be, false);
    // Along the boundary halfedges (surface on the left).
    for c in &curves {
        for w in c.vertices.windows(2) {
            let h = halfedge_between(&m, w[0], w[1]).unwrap();
            assert_eq!((m.from(h), m.to(h)), (w[0], w[1]));
        }
    }
}

#[test]
fn bunny_boundary_covers_its_five_loops() {
    let Some(m) = load("bunny.obj") else {
        return;
    };
    let be = boundary_edges(&m);
    assert_eq!(be.len(), 80 + 42 + 40 + 39 + 22);
    let curves = boundary_curves(&m, 0.0);
    eprintln!("bunny boundary: {} edges, {}", be.len(), summary(&curves));
    check_rules(&m, &curves, &be, false);
}

/// Feature detection at an angle below a mesh's facets warns, at a crease angle it does not:
/// fandisk at 40° (35 curves, none under two cells) and spot at 30° are quiet; spot at 20°
/// (544 curves, 226 of them under two cells, 339 folds in the map) and fandisk at 5° warn.
#[test]
fn features_below_the_facets_angle_are_warned_about() {
    use quadcover::constraint::detect::noise_warning;
    use quadcover::edit::{Base, Settings};
    for (name, angle, warned) in [
        ("fandisk.obj", 40.0, false),
        ("fandisk.obj", 5.0, true),
        ("spot.obj", 30.0, false),
        ("spot.obj", 20.0, true),
    ] {
        let Some(mesh) = load(name) else { return };
        let mesh = std::sync::Arc::new(mesh);
        let scale = Base::for_mesh(mesh.clone(), Settings::default())
            .unwrap()
            .grid_size();
        let curves = detect_features(&mesh, angle, scale);
        let w = noise_warning(&mesh, curves.iter().map(|c| c.vertices.as_slice()), scale);
        assert_eq!(w.is_some(), warned, "{name} at {angle}°: {w:?}");
    }
}

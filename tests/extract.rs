//! Remeshing from seamless parameterizations (issue #5).

use std::collections::HashMap;
use std::f64::consts::TAU;

use quadcover::extract::{ExtractOptions, Remesh, dual, extract, quality};
use quadcover::mesh::TriMesh;
use quadcover::mesh::generate;

/// Checks each directed edge is used once and each undirected edge by at most two faces.
fn assert_manifold(r: &Remesh) {
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for f in &r.faces {
        assert!(f.len() >= 3);
        for k in 0..f.len() {
            let e = (f[k], f[(k + 1) % f.len()]);
            assert_ne!(e.0, e.1, "degenerate edge in {f:?}");
            *directed.entry(e).or_default() += 1;
        }
    }
    for (e, c) in &directed {
        assert_eq!(*c, 1, "directed edge {e:?} used {c} times");
    }
}

fn euler(r: &Remesh) -> i64 {
    let mut edges = std::collections::HashSet::new();
    for f in &r.faces {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            edges.insert((a.min(b), a.max(b)));
        }
    }
    r.positions.len() as i64 - edges.len() as i64 + r.faces.len() as i64
}

fn vertex_uvs(mesh: &TriMesh, f: impl Fn(glam::DVec3) -> [f64; 2]) -> Vec<[f64; 2]> {
    mesh.faces()
        .iter()
        .flat_map(|t| t.map(|v| f(mesh.position(v as usize))))
        .collect()
}

#[test]
fn flat_grid_regular() {
    let mesh = generate::grid(10, 10, 1.0, 1.0);
    for s in [10.0, 5.0, 3.0, 7.3] {
        let uv = vertex_uvs(&mesh, |p| [s * p.x, s * p.y]);
        let r = extract(&mesh, &uv, 4, &ExtractOptions::default()).unwrap();
        assert_manifold(&r);
        let q = quality(&r, &mesh);
        println!("s = {s}\n{q}");
        let n = s.floor() as usize;
        if s.fract() == 0.0 {
            assert_eq!(r.positions.len(), (n + 1) * (n + 1));
            assert_eq!(r.faces.len(), n * n);
            assert!(q.rsd_edge < 1e-9);
        }
        assert_eq!(q.irregular_vertices, 0);
        assert_eq!(euler(&r), 1);
    }
}

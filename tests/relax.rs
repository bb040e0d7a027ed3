//! Tangential relaxation of remeshes on the input surface (`extract::relax`).
//!
//! On every shared mesh (igea only with `QUADCOVER_BIG_TESTS=1`), N = 4 and 6: relaxation lowers
//! RSD edge and RSD angle, keeps the connectivity, keeps moved vertices on the input and
//! boundary vertices on the input boundary, leaves chain corners bit-identical, flips no face,
//! does not lower the smallest corner angle, and is deterministic. A meta-test feeds the checks
//! deliberately broken results, so that each check is known to be able to fail.

#[path = "support/meshes.rs"]
mod meshes;
#[path = "support/remesh_checks.rs"]
mod remesh_checks;

use glam::DVec3;
use quadcover::extract::relax::{RelaxOptions, relax};
use quadcover::extract::surface::Surface;
use quadcover::extract::{ExtractOptions, Origin, Remesh, extract, quality};
use quadcover::mesh::{TriMesh, generate};
use remesh_checks::boundary_vertices;

fn shared(name: &str) -> Option<TriMesh> {
    meshes::load_shared(name)
}

/// Field, QuadCover (default options) and extraction at a coarse density.
fn remesh_of(mesh: &TriMesh, n: u32, target: usize) -> Remesh {
    use quadcover::field::{Density, FieldParams, Symmetry, compute_field};
    use quadcover::param::{FieldRef, ParamOptions, parameterize};
    let params = FieldParams {
        symmetry: Symmetry::from_n(n).unwrap(),
        density: Density::TargetVertices(target),
        ..Default::default()
    };
    let field = compute_field(mesh, &params).unwrap().field;
    let fr = FieldRef {
        symmetry: n as usize,
        frames: &field.frames,
        matchings: &field.matchings,
    };
    let p = parameterize(mesh, fr, &ParamOptions::default()).unwrap();
    extract(mesh, &p.uv, n as u8, &unrelaxed()).unwrap()
}

fn diag(mesh: &TriMesh) -> f64 {
    let (lo, hi) = mesh.bounding_box();
    (hi - lo).length()
}

fn newell(p: &[DVec3], f: &[u32]) -> DVec3 {
    (0..f.len())
        .map(|k| p[f[k] as usize].cross(p[f[(k + 1) % f.len()] as usize]))
        .sum()
}

/// Remesh vertices at input boundary vertices where the boundary turns by more than 30°, both
/// between the vertex's neighbours and between the points a mean remesh edge length away along
/// the boundary (or where it ends).
fn boundary_corners(mesh: &TriMesh, r: &Remesh) -> Vec<usize> {
    let lengths = quadcover::extract::edge_lengths(r);
    let mean = lengths.iter().sum::<f64>() / lengths.len().max(1) as f64;
    boundary_corners_at(mesh, r, mean)
}

/// [`boundary_corners`] with the turn also measured `scale` away (0: between the neighbours
/// only).
fn boundary_corners_at(mesh: &TriMesh, r: &Remesh, scale: f64) -> Vec<usize> {
    let mut nbrs: Vec<Vec<usize>> = vec![Vec::new(); mesh.n_vertices()];
    for e in 0..mesh.n_edges() {
        if mesh.is_boundary_edge(e) {
            let [a, b] = mesh.edge_vertices(e);
            nbrs[a].push(b);
            nbrs[b].push(a);
        }
    }
    let corner = |u: usize| {
        if nbrs[u].is_empty() {
            return false;
        }
        if nbrs[u].len() != 2 {
            return true;
        }
        let p = mesh.position(u);
        let turn = |a: DVec3, b: DVec3| {
            (p - a)
                .normalize()
                .dot((b - p).normalize())
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees()
                > 30.0
        };
        // walk from u through w until `scale` along, a branch or an end (or 64 edges)
        let far = |w: usize| {
            let (mut prev, mut at) = (u, w);
            let mut len = (mesh.position(w) - p).length();
            for _ in 0..64 {
                if len >= scale || nbrs[at].len() != 2 || at == u {
                    break;
                }
                let next = if nbrs[at][0] == prev {
                    nbrs[at][1]
                } else {
                    nbrs[at][0]
                };
                len += (mesh.position(next) - mesh.position(at)).length();
                (prev, at) = (at, next);
            }
            mesh.position(at)
        };
        let (a, b) = (nbrs[u][0], nbrs[u][1]);
        turn(mesh.position(a), mesh.position(b)) && turn(far(a), far(b))
    };
    (0..r.positions.len())
        .filter(|&v| matches!(r.origins[v], Origin::Vertex(u) if corner(u as usize)))
        .collect()
}

/// What relaxation must preserve, between `before` and `after` of the same input. Returns the
/// violations (empty = fine).
fn violations(mesh: &TriMesh, surface: &Surface, before: &Remesh, after: &Remesh) -> Vec<String> {
    let mut out = Vec::new();
    let tol = 1e-9 * diag(mesh);
    if before.faces != after.faces
        || before.polylines != after.polylines
        || before.origins != after.origins
        || before.positions.len() != after.positions.len()
    {
        out.push("connectivity changed".to_string());
        return out;
    }
    // moved vertices on the input surface
    let off: Vec<usize> = (0..after.positions.len())
        .filter(|&v| after.positions[v] != before.positions[v])
        .filter(|&v| surface.distance(after.positions[v]) > tol)
        .collect();
    if !off.is_empty() {
        out.push(format!(
            "{} moved vertices off the surface: {:?}",
            off.len(),
            &off[..off.len().min(5)]
        ));
    }
    // boundary vertices (that were on the input boundary) stay on it
    let segs: Vec<(DVec3, DVec3)> = (0..mesh.n_edges())
        .filter(|&e| mesh.is_boundary_edge(e))
        .map(|e| {
            let [a, b] = mesh.edge_vertices(e);
            (mesh.position(a), mesh.position(b))
        })
        .collect();
    let to_boundary = |p: DVec3| {
        segs.iter()
            .map(|&(a, b)| remesh_checks::segment_distance(p, a, b))
            .fold(f64::INFINITY, f64::min)
    };
    let bd = boundary_vertices(before);
    let left: Vec<usize> = (0..before.positions.len())
        .filter(|&v| bd[v] && to_boundary(before.positions[v]) <= tol)
        .filter(|&v| to_boundary(after.positions[v]) > tol)
        .collect();
    if !left.is_empty() {
        out.push(format!(
            "{} boundary vertices left the boundary: {:?}",
            left.len(),
            &left[..left.len().min(5)]
        ));
    }
    // corners bit-identical
    let moved_corners: Vec<usize> = boundary_corners(mesh, before)
        .into_iter()
        .filter(|&v| after.positions[v] != before.positions[v])
        .collect();
    if !moved_corners.is_empty() {
        out.push(format!("corners moved: {moved_corners:?}"));
    }
    // no new flips: Newell normal against the input normal at the centroid's closest point
    let vn = mesh.vertex_normals();
    let orient = |r: &Remesh, f: &Vec<u32>| {
        let c = f.iter().map(|&v| r.positions[v as usize]).sum::<DVec3>() / f.len() as f64;
        let pr = surface.project(c);
        let [a, b, cc] = mesh.face(pr.face);
        let n = vn[a] * pr.bary[0] + vn[b] * pr.bary[1] + vn[cc] * pr.bary[2];
        newell(&r.positions, f).dot(n)
    };
    let flipped = (0..before.faces.len())
        .filter(|&f| {
            orient(before, &before.faces[f]) > 0.0 && orient(after, &after.faces[f]) <= 0.0
        })
        .count();
    if flipped > 0 {
        out.push(format!("{flipped} faces flipped"));
    }
    let (qb, qa) = (quality(before, mesh), quality(after, mesh));
    if qa.min_angle_deg < qb.min_angle_deg - 1e-9 {
        out.push(format!(
            "min angle {:.3}° -> {:.3}°",
            qb.min_angle_deg, qa.min_angle_deg
        ));
    }
    out
}

/// Extraction without its own relaxation (these tests relax themselves).
fn unrelaxed() -> ExtractOptions {
    ExtractOptions {
        relax: None,
        ..Default::default()
    }
}

/// Relaxes, checks, and prints a table row.
fn check(name: &str, mesh: &TriMesh, n: u32, target: usize) {
    let before = remesh_of(mesh, n, target);
    let surface = Surface::new(mesh);
    let mut after = before.clone();
    let t = std::time::Instant::now();
    let stats = relax(&mut after, mesh, &[], &RelaxOptions::default());
    let ms = t.elapsed().as_secs_f64() * 1e3;
    let (qb, qa) = (quality(&before, mesh), quality(&after, mesh));
    println!(
        "| {name} | {n} | {} | {:.2} → {:.2} | {:.2} → {:.2} | {:.1}–{:.1} → {:.1}–{:.1} | {:.2e} → {:.2e} | {:.2e} → {:.2e} | {ms:.0} ms | {stats:?}",
        before.positions.len(),
        100.0 * qb.rsd_edge,
        100.0 * qa.rsd_edge,
        100.0 * qb.rsd_angle,
        100.0 * qa.rsd_angle,
        qb.min_angle_deg,
        qb.max_angle_deg,
        qa.min_angle_deg,
        qa.max_angle_deg,
        qb.mean_distance,
        qa.mean_distance,
        qb.hausdorff,
        qa.hausdorff,
    );
    let v = violations(mesh, &surface, &before, &after);
    assert!(v.is_empty(), "{name} N={n}: {v:?}");
    assert!(
        stats.moved > before.positions.len() / 2,
        "{name} N={n}: {stats:?}"
    );
    assert!(
        qa.rsd_edge < qb.rsd_edge,
        "{name} N={n}: RSD edge {} -> {}",
        qb.rsd_edge,
        qa.rsd_edge
    );
    assert!(
        qa.rsd_angle < qb.rsd_angle,
        "{name} N={n}: RSD angle {} -> {}",
        qb.rsd_angle,
        qa.rsd_angle
    );
    // Deterministic: the same input gives bit-identical output.
    let mut again = before.clone();
    let stats2 = relax(&mut again, mesh, &[], &RelaxOptions::default());
    assert_eq!(again.positions, after.positions, "{name} N={n}");
    assert_eq!(stats, stats2);
    // Boundary meshes: vertices slid along the boundary.
    if (0..mesh.n_edges()).any(|e| mesh.is_boundary_edge(e)) {
        assert!(stats.sliding > 0, "{name} N={n}: {stats:?}");
    }
}

fn run(name: &str) {
    let Some(mesh) = shared(name) else { return };
    for n in [4, 6] {
        check(name, &mesh, n, 2000);
    }
}

/// A scan's jagged boundary is not all corners: on the bunny, boundary vertices at input
/// vertices where the boundary turns by more than 30° between the neighbours but not over a
/// remesh edge length slide along it (they stayed fixed when corners were the neighbours' turn
/// alone), while the corners by both measures stay.
#[test]
fn jagged_boundaries_slide() {
    let Some(mesh) = shared("bunny.obj") else {
        return;
    };
    let before = remesh_of(&mesh, 4, 2000);
    let mut after = before.clone();
    relax(&mut after, &mesh, &[], &RelaxOptions::default());
    let corners = boundary_corners(&mesh, &before);
    let jagged: Vec<usize> = boundary_corners_at(&mesh, &before, 0.0)
        .into_iter()
        .filter(|v| !corners.contains(v))
        .collect();
    let slid = jagged
        .iter()
        .filter(|&&v| after.positions[v] != before.positions[v])
        .count();
    println!(
        "{} corners, {} jagged-only corners, {slid} of them slid",
        corners.len(),
        jagged.len()
    );
    assert!(jagged.len() >= 10, "{jagged:?}");
    assert!(2 * slid >= jagged.len(), "{slid} of {}", jagged.len());
    assert!(
        corners
            .iter()
            .all(|&v| after.positions[v] == before.positions[v])
    );
}

/// Corners outside [30°, 150°] of a remesh.
fn corners_outside(r: &Remesh) -> usize {
    r.faces
        .iter()
        .map(|f| {
            let n = f.len();
            (0..n)
                .filter(|&k| {
                    let p = r.positions[f[k] as usize];
                    let a = r.positions[f[(k + 1) % n] as usize] - p;
                    let b = r.positions[f[(k + n - 1) % n] as usize] - p;
                    let t = a.angle_between(b).to_degrees();
                    !(30.0..=150.0).contains(&t)
                })
                .count()
        })
        .sum()
}

/// Where the grid meets the bunny's unaligned holes obliquely, the boundary vertices slide to
/// even out the corners around them (`RelaxOptions::even_corners`): fewer corners outside
/// [30°, 150°] than without, the other checks (no flip, no smaller smallest corner, on the
/// surface, boundary on the boundary) as they are.
#[test]
fn boundary_corners_are_evened_out() {
    let Some(mesh) = shared("bunny.obj") else {
        return;
    };
    let before = remesh_of(&mesh, 4, 2000);
    let relaxed = |even_corners| {
        let mut r = before.clone();
        let opts = RelaxOptions {
            even_corners,
            ..Default::default()
        };
        let stats = relax(&mut r, &mesh, &[], &opts);
        (r, stats)
    };
    let ((plain, _), (evened, stats)) = (relaxed(false), relaxed(true));
    let (n_plain, n_evened) = (corners_outside(&plain), corners_outside(&evened));
    println!(
        "bunny at 2000 vertices: {} corners outside [30°, 150°] unrelaxed, {n_plain} relaxed, \
         {n_evened} with the corners evened out ({} vertices slid)",
        corners_outside(&before),
        stats.evened
    );
    assert!(stats.evened > 0);
    assert!(n_evened < n_plain, "{n_evened} against {n_plain}");
    let v = violations(&mesh, &Surface::new(&mesh), &before, &evened);
    assert!(v.is_empty(), "{v:?}");
}

#[test]
fn relax_bunny() {
    run("bunny.obj");
}
#[test]
fn relax_kitten() {
    run("kitten.obj");
}
#[test]
fn relax_eight() {
    run("eight.obj");
}
#[test]
fn relax_fertility() {
    run("fertility.obj");
}
#[test]
fn relax_fandisk() {
    run("fandisk.obj");
}
#[test]
fn relax_camelhead() {
    run("camelhead.obj");
}
#[test]
fn relax_cerebral_vessels() {
    run("cerebral-vessels.obj");
}
#[test]
fn relax_max_planck() {
    run("max-planck.obj");
}
#[test]
fn relax_spot() {
    run("spot.obj");
}
#[test]
fn relax_igea() {
    if std::env::var_os("QUADCOVER_BIG_TESTS").is_none() {
        eprintln!("skipping igea (set QUADCOVER_BIG_TESTS=1)");
        return;
    }
    run("igea.obj");
}

/// Runtime on the bunny at about 6500 remesh vertices (measurement only, `--ignored`).
#[test]
#[ignore]
fn bunny_timing() {
    let Some(mesh) = shared("bunny.obj") else {
        return;
    };
    for n in [4, 6] {
        check("bunny.obj", &mesh, n, 6500);
    }
}

/// Each check can fail: broken results (a vertex lifted off the surface, a boundary vertex
/// pulled inside, a corner nudged, a face flipped, a face list changed) are all reported.
#[test]
fn checks_catch_broken_results() {
    let mesh = generate::grid(12, 12, 1.0, 1.0);
    let uv: Vec<[f64; 2]> = mesh
        .faces()
        .iter()
        .flat_map(|t| {
            t.map(|v| {
                [
                    6.0 * mesh.position(v as usize).x,
                    6.0 * mesh.position(v as usize).y,
                ]
            })
        })
        .collect();
    let r = extract(&mesh, &uv, 4, &unrelaxed()).unwrap();
    let surface = Surface::new(&mesh);
    assert!(violations(&mesh, &surface, &r, &r).is_empty());
    let corners = boundary_corners(&mesh, &r);
    assert_eq!(corners.len(), 4, "the grid's four corners");
    let bd = boundary_vertices(&r);
    let interior = (0..r.positions.len()).find(|&v| !bd[v]).unwrap();
    let side = (0..r.positions.len())
        .find(|&v| bd[v] && !corners.contains(&v))
        .unwrap();
    let broken = |f: &dyn Fn(&mut Remesh)| {
        let mut b = r.clone();
        f(&mut b);
        violations(&mesh, &surface, &r, &b)
    };
    let lifted = broken(&|b| b.positions[interior].z += 1e-3);
    assert!(
        lifted.iter().any(|s| s.contains("off the surface")),
        "{lifted:?}"
    );
    let inside = broken(&|b| {
        let c = DVec3::new(0.5, 0.5, 0.0);
        let p = b.positions[side];
        b.positions[side] = p + (c - p) * 0.01;
    });
    assert!(
        inside.iter().any(|s| s.contains("left the boundary")),
        "{inside:?}"
    );
    let corner =
        broken(&|b| b.positions[corners[0]].x += 1e-12 * (1.0 + b.positions[corners[0]].x.abs()));
    assert!(
        corner.iter().any(|s| s.contains("corners moved")),
        "{corner:?}"
    );
    let flipped = broken(&|b| {
        // mirror an interior vertex far across a neighbour: its faces turn over
        let f = b
            .faces
            .iter()
            .find(|f| f.contains(&(interior as u32)))
            .unwrap()
            .clone();
        let k = f.iter().position(|&x| x as usize == interior).unwrap();
        let opposite = b.positions[f[(k + 2) % 4] as usize];
        let p = b.positions[interior];
        b.positions[interior] = p + 2.2 * (opposite - p);
    });
    assert!(flipped.iter().any(|s| s.contains("flipped")), "{flipped:?}");
    assert!(
        flipped.iter().any(|s| s.contains("min angle")),
        "{flipped:?}"
    );
    let refaced = broken(&|b| b.faces[0].rotate_left(1));
    assert!(
        refaced.iter().any(|s| s.contains("connectivity")),
        "{refaced:?}"
    );
}

/// A perturbed regular grid relaxes back towards regular: interior vertices on the plane,
/// boundary vertices on their sides, the four corners fixed; a feature line stays straight.
#[test]
fn perturbed_grid_relaxes_to_regular() {
    let mesh = generate::grid(30, 30, 1.0, 1.0);
    let uv: Vec<[f64; 2]> = mesh
        .faces()
        .iter()
        .flat_map(|t| {
            t.map(|v| {
                [
                    10.0 * mesh.position(v as usize).x,
                    10.0 * mesh.position(v as usize).y,
                ]
            })
        })
        .collect();
    let clean = extract(&mesh, &uv, 4, &unrelaxed()).unwrap();
    let mut noisy = clean.clone();
    let mut seed = 99u64;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let bd = boundary_vertices(&clean);
    for v in 0..noisy.positions.len() {
        let p = &mut noisy.positions[v];
        let on_x = p.x == 0.0 || p.x == 1.0;
        let on_y = p.y == 0.0 || p.y == 1.0;
        let (dx, dy) = (0.03 * rnd(), 0.03 * rnd());
        if !bd[v] {
            p.x += dx;
            p.y += dy;
        } else if on_x && !on_y {
            p.y += dy;
        } else if on_y && !on_x {
            p.x += dx;
        }
        // origins no longer exact for moved boundary points: they lie on a boundary edge
        // somewhere, so mark them Unknown (relax finds the chain by proximity).
        if bd[v] && !(on_x && on_y) {
            noisy.origins[v] = Origin::Unknown;
        }
    }
    let mut relaxed = noisy.clone();
    let stats = relax(
        &mut relaxed,
        &mesh,
        &[],
        &RelaxOptions {
            iterations: 60,
            ..Default::default()
        },
    );
    let (qn, qr) = (quality(&noisy, &mesh), quality(&relaxed, &mesh));
    println!(
        "noisy {:.4} {:.4} relaxed {:.4} {:.4} {stats:?}",
        qn.rsd_edge, qn.rsd_angle, qr.rsd_edge, qr.rsd_angle
    );
    assert!(
        qr.rsd_edge < 0.3 * qn.rsd_edge,
        "{} -> {}",
        qn.rsd_edge,
        qr.rsd_edge
    );
    assert!(
        qr.rsd_angle < 0.3 * qn.rsd_angle,
        "{} -> {}",
        qn.rsd_angle,
        qr.rsd_angle
    );
    assert_eq!(stats.fixed, 4, "{stats:?}");
    let surface = Surface::new(&mesh);
    let v = violations(&mesh, &surface, &noisy, &relaxed);
    assert!(v.is_empty(), "{v:?}");
    for (v, p) in relaxed.positions.iter().enumerate() {
        assert!(p.z.abs() < 1e-12);
        if bd[v] {
            let q = noisy.positions[v];
            // stays on its side of the square
            assert!(
                (q.x == 0.0 && p.x == 0.0)
                    || (q.x == 1.0 && p.x == 1.0)
                    || (q.y == 0.0 && p.y == 0.0)
                    || (q.y == 1.0 && p.y == 1.0),
                "{q:?} -> {p:?}"
            );
        }
    }
}

/// Vertices on a constrained input edge chain slide along it and stay on it; where two
/// constrained chains cross, the vertex is fixed.
#[test]
fn constraint_chain_is_kept() {
    let mesh = generate::grid(20, 20, 1.0, 1.0);
    // constrain the input edges on the line x = 0.5 and on y = 0.5
    let mut constrained = vec![false; mesh.n_edges()];
    for e in 0..mesh.n_edges() {
        let [a, b] = mesh.edge_vertices(e);
        let (p, q) = (mesh.position(a), mesh.position(b));
        if (p.x == 0.5 && q.x == 0.5) || (p.y == 0.5 && q.y == 0.5) {
            constrained[e] = true;
        }
    }
    assert!(constrained.iter().filter(|&&c| c).count() >= 40);
    let uv: Vec<[f64; 2]> = mesh
        .faces()
        .iter()
        .flat_map(|t| {
            t.map(|v| {
                [
                    8.0 * mesh.position(v as usize).x,
                    8.0 * mesh.position(v as usize).y,
                ]
            })
        })
        .collect();
    let mut r = extract(&mesh, &uv, 4, &unrelaxed()).unwrap();
    // shift every interior grid vertex except those on the lines a bit in x and y: the
    // line vertices then want to slide (along the line, by the neighbours' pull along it)
    let mut seed = 5u64;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let bd = boundary_vertices(&r);
    let on_line: Vec<bool> = r
        .positions
        .iter()
        .map(|p| p.x == 0.5 || p.y == 0.5)
        .collect();
    for v in 0..r.positions.len() {
        if !bd[v] {
            let p = &mut r.positions[v];
            if p.x == 0.5 && p.y != 0.5 {
                p.y += 0.04 * rnd();
            } else if p.y == 0.5 && p.x != 0.5 {
                p.x += 0.04 * rnd();
            } else if !on_line[v] {
                p.x += 0.04 * rnd();
                p.y += 0.04 * rnd();
            }
        }
    }
    // origins of line vertices that were shifted no longer name the right element: find it
    for v in 0..r.positions.len() {
        if on_line[v] && !bd[v] {
            let p = r.positions[v];
            let mut best = (f64::INFINITY, Origin::Unknown);
            for e in 0..mesh.n_edges() {
                if constrained[e] {
                    let [a, b] = mesh.edge_vertices(e);
                    let d = remesh_checks::segment_distance(p, mesh.position(a), mesh.position(b));
                    if d < best.0 {
                        best = (d, Origin::Edge(e as u32));
                    }
                }
            }
            for u in 0..mesh.n_vertices() {
                if mesh.position(u) == p {
                    best = (0.0, Origin::Vertex(u as u32));
                }
            }
            r.origins[v] = best.1;
        }
    }
    let mut relaxed = r.clone();
    let stats = relax(&mut relaxed, &mesh, &constrained, &RelaxOptions::default());
    println!("{stats:?}");
    let center = r
        .positions
        .iter()
        .position(|p| p.x == 0.5 && p.y == 0.5)
        .unwrap();
    assert_eq!(
        relaxed.positions[center], r.positions[center],
        "crossing fixed"
    );
    let mut slid = 0;
    for v in 0..r.positions.len() {
        if on_line[v] && !bd[v] {
            let (p, q) = (r.positions[v], relaxed.positions[v]);
            if p.x == 0.5 {
                assert_eq!(q.x, 0.5, "{p:?} -> {q:?}");
            } else {
                assert_eq!(q.y, 0.5, "{p:?} -> {q:?}");
            }
            if p != q {
                slid += 1;
            }
        }
    }
    assert!(slid > 5, "line vertices slid: {slid}");
    let q = quality(&relaxed, &mesh);
    assert!(q.rsd_edge < quality(&r, &mesh).rsd_edge);
}

/// Stripes (polylines only) are left unchanged.
#[test]
fn stripes_are_left_alone() {
    let mesh = generate::grid(10, 10, 1.0, 1.0);
    let uv: Vec<[f64; 2]> = mesh
        .faces()
        .iter()
        .flat_map(|t| {
            t.map(|v| {
                [
                    5.0 * mesh.position(v as usize).x,
                    5.0 * mesh.position(v as usize).y,
                ]
            })
        })
        .collect();
    let r = extract(&mesh, &uv, 2, &unrelaxed()).unwrap();
    assert!(r.faces.is_empty() && !r.polylines.is_empty());
    let mut s = r.clone();
    let stats = relax(&mut s, &mesh, &[], &RelaxOptions::default());
    assert_eq!(stats.moved, 0);
    assert_eq!(s.positions, r.positions);
    let q = quality(&r, &mesh);
    assert_eq!(q.hausdorff, q.max_distance);
}

/// Parameter sweep (measurement only): `cargo test --release --test relax sweep -- --ignored
/// --nocapture`. Prints, per option set, the mean ratio after/before of RSD edge and RSD angle
/// over the shared meshes (N = 4 and 6), and the worst min angle change.
#[test]
#[ignore]
fn sweep() {
    let mut cases = Vec::new();
    for name in meshes::EVERY_BUT_IGEA {
        let Some(mesh) = shared(name) else { return };
        for n in [4, 6] {
            let r = remesh_of(&mesh, n, 2000);
            let q = quality(&r, &mesh);
            cases.push((name, n, mesh.clone(), r, q));
        }
    }
    let mut sets = Vec::new();
    for pull in [0.02, 0.1, 0.5] {
        for iterations in [3, 6, 9, 18] {
            sets.push(RelaxOptions {
                iterations,
                pull,
                ..Default::default()
            });
        }
    }
    for o in sets {
        let (mut se, mut sa, mut worst) = (0.0, 0.0, f64::INFINITY);
        let mut rows = String::new();
        for (name, n, mesh, r, q) in &cases {
            let mut a = r.clone();
            relax(&mut a, mesh, &[], &o);
            let qa = quality(&a, mesh);
            se += qa.rsd_edge / q.rsd_edge;
            sa += qa.rsd_angle / q.rsd_angle;
            worst = worst.min(qa.min_angle_deg - q.min_angle_deg);
            if qa.min_angle_deg < q.min_angle_deg {
                println!(
                    "{name} {n}: min angle {} -> {}",
                    q.min_angle_deg, qa.min_angle_deg
                );
            }
            rows += &format!(
                " {}{n}:{:.2}/{:.2}",
                &name[..3],
                qa.rsd_edge / q.rsd_edge,
                qa.rsd_angle / q.rsd_angle
            );
        }
        let k = cases.len() as f64;
        println!(
            "pull {} it {}: edge {:.3} angle {:.3} min-angle change {:.2}\n   {rows}",
            o.pull,
            o.iterations,
            se / k,
            sa / k,
            worst
        );
    }
}

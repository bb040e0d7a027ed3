//! Frame field tests (issue #3): index theorem on real meshes, alignment on generated surfaces,
//! smoothing behaviour, matching consistency, JSON round-trip.

#[path = "support/meshes.rs"]
mod meshes;

use std::f64::consts::{PI, TAU};
use std::path::PathBuf;
use std::time::Instant;

use glam::{DQuat, DVec3};
use quadcover::field::{
    self, Density, FieldError, FieldParams, FrameField, Guidance, Relaxation, ScaleFunction,
    Symmetry, compute_field, compute_indices, io,
};
use quadcover::mesh::{TriMesh, generate};

const SYMS: [Symmetry; 3] = [Symmetry::Two, Symmetry::Four, Symmetry::Six];

fn mesh_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/meshes"))
}

/// Minimal OBJ reader (`v` and triangular `f` lines; the shared meshes have nothing else).
fn load(name: &str) -> Option<TriMesh> {
    let path = mesh_dir().join(name);
    let Ok(text) = std::fs::read_to_string(&path) else {
        println!("skipping {name}: {} not found", path.display());
        return None;
    };
    let mut p = Vec::new();
    let mut f = Vec::new();
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f64> = it.take(3).map(|x| x.parse().unwrap()).collect();
                p.push(DVec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let c: Vec<u32> = it
                    .map(|x| x.split('/').next().unwrap().parse::<u32>().unwrap() - 1)
                    .collect();
                for k in 1..c.len() - 1 {
                    f.push([c[0], c[k], c[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Some(TriMesh::from_triangles(p, f).expect("valid mesh"))
}

fn params(symmetry: Symmetry) -> FieldParams {
    FieldParams {
        symmetry,
        ..FieldParams::default()
    }
}

/// Angle of the tangent vector `u` relative to `reference` about normal `n`, reduced modulo 2π/N
/// into (−π/N, π/N].
fn angle_mod(u: DVec3, reference: DVec3, n: DVec3, sym: Symmetry) -> f64 {
    let a = reference.cross(u).dot(n).atan2(reference.dot(u));
    let step = TAU / sym.n() as f64;
    let mut x = a.rem_euclid(step);
    if x > step / 2.0 {
        x -= step;
    }
    x
}

#[test]
fn closed_meshes_index_sum_is_n_times_euler_characteristic() {
    let meshes = [
        ("kitten.obj", 1),
        ("eight.obj", 2),
        ("fertility.obj", 4),
        ("fandisk.obj", 0),
        ("max-planck.obj", 0),
        ("spot.obj", 0),
    ];
    let mut checked = 0;
    for (name, genus) in meshes {
        let Some(mesh) = load(name) else { continue };
        assert_eq!(mesh.genus(), genus, "{name}: genus");
        for sym in SYMS {
            let n = sym.n() as i64;
            let t = Instant::now();
            let res = compute_field(&mesh, &params(sym)).unwrap();
            let rep = &res.indices;
            assert_eq!(
                rep.interior_sum_k,
                n * (2 - 2 * genus),
                "{name} N={n}: Σk = N(2 − 2g)"
            );
            assert_eq!(rep.boundary_contribution, 0.0);
            assert!(
                rep.max_rounding_residual < 1e-6,
                "{name} N={n}: residual {}",
                rep.max_rounding_residual
            );
            for v in 0..mesh.n_vertices() {
                let (k, fk) = (rep.index_k[v].unwrap(), rep.fractional_k[v].unwrap());
                assert_eq!(
                    k.rem_euclid(n as i32) as u32,
                    fk,
                    "{name} N={n} v={v}: eq. 2.37 vs full index"
                );
            }
            // The stored frames alone (3-D vectors + matchings) give the same indices.
            let again = compute_indices(&mesh, &res.field);
            assert_eq!(
                again.index_k, rep.index_k,
                "{name} N={n}: indices from exported frames"
            );
            let pos: usize = rep.singularities.iter().filter(|s| s.k > 0).count();
            println!(
                "{name:15} N={n}: {} singularities ({pos} positive), E_smooth {:.3}, passes {}, {:.3} s",
                rep.singularities.len(),
                res.e_smooth,
                res.passes,
                t.elapsed().as_secs_f64()
            );
            checked += 1;
        }
    }
    println!("checked {checked} mesh/symmetry pairs");
}

#[test]
fn igea_index_sum() {
    let Some(mesh) = load("igea.obj") else { return };
    let t = Instant::now();
    let res = compute_field(&mesh, &params(Symmetry::Four)).unwrap();
    assert_eq!(res.indices.interior_sum_k, 8);
    println!(
        "igea ({} faces) N=4: {:.2} s {:?}",
        mesh.n_faces(),
        t.elapsed().as_secs_f64(),
        res.timings
    );
}

#[test]
fn generated_closed_surfaces_satisfy_index_theorem() {
    let sphere = generate::icosphere(3);
    let torus = generate::torus(3.0, 1.0, 48, 16);
    for sym in SYMS {
        let n = sym.n() as i64;
        let s = compute_field(&sphere, &params(sym)).unwrap();
        assert_eq!(s.indices.interior_sum_k, 2 * n, "sphere N={n}");
        let t = compute_field(&torus, &params(sym)).unwrap();
        assert_eq!(t.indices.interior_sum_k, 0, "torus N={n}");
    }
}

/// A sphere is umbilic everywhere: its curvature directions are noise and must guide nothing
/// (`field::curvature::UMBILIC_RATIO`). Its quad field then has the eight +1/4 singularities of
/// a cube's layout; guided by the noise it had 88 on this icosphere.
#[test]
fn a_sphere_is_guided_by_no_curvature_direction() {
    let sphere = generate::icosphere(5);
    let res = compute_field(&sphere, &params(Symmetry::Four)).unwrap();
    let ks: Vec<i32> = res.indices.singularities.iter().map(|s| s.k).collect();
    assert_eq!(ks, vec![1; 8], "singularities {ks:?}");
    assert!(res.omega.iter().all(|w| *w == 0.0), "weights on umbilics");
}

#[test]
fn flat_disc_has_no_interior_singularities_and_boundary_convention_holds() {
    let disc = generate::disc(1.0, 24);
    for sym in SYMS {
        for guidance in [Guidance::Curvature, Guidance::Smooth] {
            let res = compute_field(
                &disc,
                &FieldParams {
                    guidance,
                    ..params(sym)
                },
            )
            .unwrap();
            assert!(
                res.indices.singularities.is_empty(),
                "N={} {:?}",
                sym.n(),
                res.indices.singularities
            );
            // Σ_interior ind = χ − B with B from the boundary's geodesic curvature + field turning.
            assert!(res.indices.poincare_hopf_defect().abs() < 1e-9);
            assert!((res.indices.boundary_contribution - 1.0).abs() < 1e-9);
            assert!(
                res.e_smooth < 1e-16,
                "flat: a parallel field has zero energy"
            );
        }
    }
}

#[test]
fn boundary_convention_on_real_open_meshes() {
    for name in ["bunny.obj", "camelhead.obj"] {
        let Some(mesh) = load(name) else { continue };
        let res = compute_field(&mesh, &params(Symmetry::Four)).unwrap();
        let rep = &res.indices;
        let b = rep.boundary_contribution;
        println!(
            "{name}: χ = {}, Σ_int k/N = {}, B = {b}",
            rep.euler_characteristic,
            rep.interior_sum_k as f64 / 4.0
        );
        assert!(
            rep.poincare_hopf_defect().abs() < 1e-6,
            "{name}: {}",
            rep.poincare_hopf_defect()
        );
        // B is then necessarily a multiple of 1/N.
        assert!((4.0 * b - (4.0 * b).round()).abs() < 1e-6);
    }
}

#[test]
fn cylinder_field_follows_principal_directions() {
    let cyl = generate::cylinder(1.0, 3.0, 48, 24);
    for sym in SYMS {
        let res = compute_field(&cyl, &params(sym)).unwrap();
        assert!(res.indices.singularities.is_empty(), "N={}", sym.n());
        assert!(res.indices.poincare_hopf_defect().abs() < 1e-9);
        let mut worst: f64 = 0.0;
        for f in 0..cyl.n_faces() {
            let n = cyl.face_normal(f);
            let axis = (DVec3::Z - n * n.z).normalize();
            // N = 2: along the axis (min |κ|); N = 6: around the tube (max |κ|); N = 4: either.
            let reference = if sym == Symmetry::Six {
                n.cross(axis)
            } else {
                axis
            };
            worst = worst.max(angle_mod(res.field.frames[f][0], reference, n, sym).abs());
        }
        println!(
            "cylinder N={}: worst deviation {:.3}°",
            sym.n(),
            worst.to_degrees()
        );
        assert!(
            worst < 3f64.to_radians(),
            "N={}: {}°",
            sym.n(),
            worst.to_degrees()
        );
    }
}

/// Scan-like noise: smoothing the shape operators (`curvature_smoothing`) must bring the raw
/// curvature directions of a noisy cylinder closer to the true ones (the axis) than eq. 3.2 alone.
#[test]
fn curvature_smoothing_resists_noise() {
    let mut cyl = generate::cylinder(1.0, 3.0, 64, 32);
    // Deterministic radial noise of 1 % of the radius.
    let p: Vec<DVec3> = cyl
        .positions()
        .iter()
        .enumerate()
        .map(|(i, q)| {
            let t = ((i as f64 * 12.9898).sin() * 43758.5453).fract();
            let radial = DVec3::new(q.x, q.y, 0.0).normalize();
            *q + radial * 0.01 * (2.0 * t - 1.0)
        })
        .collect();
    cyl.set_positions(p);
    let mean_error = |passes: usize| {
        let res = compute_field(
            &cyl,
            &FieldParams {
                curvature_smoothing: passes,
                tau: 1e4,
                ..params(Symmetry::Four)
            },
        )
        .unwrap();
        let mut sum = 0.0;
        let mut n = 0;
        for f in 0..cyl.n_faces() {
            let c = cyl.face_centroid(f);
            if c.z < 0.5 || c.z > 2.5 {
                continue; // away from the open ends
            }
            let nrm = cyl.face_normal(f);
            let axis = (DVec3::Z - nrm * nrm.z).normalize();
            let (e1, e2) = cyl.face_basis(f);
            let d = e1 * res.curvature.dir1[f].cos() + e2 * res.curvature.dir1[f].sin();
            sum += angle_mod(d, axis, nrm, Symmetry::Four).abs();
            n += 1;
        }
        sum / n as f64
    };
    let (raw, smoothed) = (mean_error(0), mean_error(5));
    println!(
        "noisy cylinder: mean curvature-direction error {:.2}° raw, {:.2}° smoothed",
        raw.to_degrees(),
        smoothed.to_degrees()
    );
    assert!(
        smoothed < 0.5 * raw,
        "{}° vs {}°",
        smoothed.to_degrees(),
        raw.to_degrees()
    );
}

fn torus_worst_deviation(torus: &TriMesh, p: &FieldParams) -> (f64, usize) {
    let sym = p.symmetry;
    let res = compute_field(torus, p).unwrap();
    let mut worst: f64 = 0.0;
    for f in 0..torus.n_faces() {
        let n = torus.face_normal(f);
        let c = torus.face_centroid(f);
        let parallel = DVec3::Z.cross(c).normalize();
        let parallel = (parallel - n * n.dot(parallel)).normalize();
        // N = 6: max |κ| is around the tube (meridian); N = 2: min |κ| along the parallels.
        let reference = if sym == Symmetry::Six {
            n.cross(parallel)
        } else {
            parallel
        };
        worst = worst.max(angle_mod(res.field.frames[f][0], reference, n, sym).abs());
    }
    (worst, res.indices.singularities.len())
}

#[test]
fn torus_field_follows_principal_directions() {
    // Unbiased triangulation, default parameters (10 % of the candidate faces constrained).
    let torus = generate::torus_alternating(3.0, 1.0, 96, 32);
    for sym in SYMS {
        let (worst, sing) = torus_worst_deviation(&torus, &params(sym));
        println!(
            "alternating torus N={}: worst deviation {:.3}°, {sing} singularities",
            sym.n(),
            worst.to_degrees()
        );
        assert!(
            worst < 5f64.to_radians(),
            "N={}: {}°",
            sym.n(),
            worst.to_degrees()
        );
        assert_eq!(sing, 0);
    }
    // All diagonals in one direction: the unit-weight E_smooth of eq. (3.5) is anisotropic on this
    // mesh and twists the unconstrained part of the field (measured: up to 17° with 10 %
    // constraints); with every candidate constrained the field is aligned.
    let torus = generate::torus(3.0, 1.0, 96, 32);
    for sym in SYMS {
        let (biased, _) = torus_worst_deviation(&torus, &params(sym));
        let p = FieldParams {
            reliable_fraction: 1.0,
            ..params(sym)
        };
        let (worst, sing) = torus_worst_deviation(&torus, &p);
        println!(
            "generator torus N={}: worst deviation {:.3}° (10 %: {:.3}°), {sing} singularities",
            sym.n(),
            worst.to_degrees(),
            biased.to_degrees()
        );
        assert!(
            worst < 5f64.to_radians(),
            "N={}: {}°",
            sym.n(),
            worst.to_degrees()
        );
        assert_eq!(sing, 0);
    }
}

#[test]
fn smoothness_energy_decreases_with_tau_and_large_tau_keeps_curvature_directions() {
    let Some(mesh) = load("fertility.obj") else {
        return;
    };
    // Rounding the matchings is a heuristic, so between neighbouring τ (1e4 and 100 give nearly
    // the same field) E_smooth may wiggle by a rounding decision or two: 0.5 % is allowed there
    // (seen: 0.14 %, N = 6, where τ = 1e4 found the smoother rounding). The trend is asserted
    // over the whole range: the smoothest field (τ = 0) is at least 5 % smoother than the
    // curvature-bound one (seen: 18 % for N = 4, 7 % for N = 6).
    for sym in [Symmetry::Four, Symmetry::Six] {
        let mut last = f64::INFINITY;
        let mut first = None;
        for tau in [1e4, 100.0, 1.0, 0.01, 0.0] {
            let res = compute_field(&mesh, &FieldParams { tau, ..params(sym) }).unwrap();
            println!(
                "fertility N={} τ={tau}: E_smooth {:.4}, E_align {:.6}, {} singularities",
                sym.n(),
                res.e_smooth,
                res.e_align,
                res.indices.singularities.len()
            );
            assert!(
                res.e_smooth <= last * 1.005,
                "N={} τ={tau}: {} > {last}",
                sym.n(),
                res.e_smooth
            );
            last = res.e_smooth;
            let first = *first.get_or_insert(res.e_smooth);
            if tau == 0.0 {
                assert!(
                    res.e_smooth < 0.95 * first,
                    "N={}: τ = 0 gives {} against {first} for τ = 1e4",
                    sym.n(),
                    res.e_smooth
                );
            }
            if tau >= 1e4 {
                let step = TAU / sym.n() as f64;
                let mut worst: f64 = 0.0;
                let mut count = 0;
                for f in 0..mesh.n_faces() {
                    if res.omega[f] > 0.0 {
                        let d = (res.theta[f] - res.reference[f]).rem_euclid(step);
                        worst = worst.max(d.min(step - d));
                        count += 1;
                    }
                }
                println!(
                    "  {count} reliable faces, worst deviation {:.4}°",
                    worst.to_degrees()
                );
                assert!(count > 0);
                assert!(worst < 2f64.to_radians(), "{}°", worst.to_degrees());
            }
        }
    }
}

/// Independent check of the matching convention: unfold face i into face j's plane by rotating
/// about the shared edge (not using the crate's transport angles), apply M_r to (U_i; V_i) and
/// compare with (U_j; V_j). The stored r must be the closest of the N candidates.
fn check_matchings(mesh: &TriMesh, fld: &FrameField, label: &str) {
    let n = fld.symmetry.n() as i32;
    let mut checked = 0;
    for e in 0..mesh.n_edges() {
        let (h0, h1) = mesh.edge_halfedges(e);
        let Some(h1) = h1 else {
            assert_eq!(fld.matchings[e], 0);
            continue;
        };
        let (i, j) = (mesh.face_of(h0), mesh.face_of(h1));
        let r = fld.matchings[e];
        assert!((0..n).contains(&r));
        // Antisymmetry as seen from either side.
        assert_eq!(
            (fld.matching_from(mesh, e, i) + fld.matching_from(mesh, e, j)).rem_euclid(n),
            0
        );
        let (ni, nj) = (mesh.face_normal(i), mesh.face_normal(j));
        let d = mesh.vector(h0).normalize();
        let q = DQuat::from_axis_angle(d, ni.cross(nj).dot(d).atan2(ni.dot(nj)));
        let (ui, vi) = (q * fld.frames[i][0], q * fld.frames[i][1]);
        let (uj, vj) = (fld.frames[j][0], fld.frames[j][1]);
        let dist = |r: i32| {
            let m = field::matching_matrix(fld.symmetry, r);
            let (mu, mv) = (m[0][0] * ui + m[0][1] * vi, m[1][0] * ui + m[1][1] * vi);
            let a = |x: DVec3, y: DVec3| x.cross(y).length().atan2(x.dot(y));
            (a(mu, uj), a(mv, vj))
        };
        let (du, dv) = dist(r);
        assert!(
            du <= PI / n as f64 + 1e-9,
            "{label} edge {e}: {}°",
            du.to_degrees()
        );
        assert!((du - dv).abs() < 1e-6, "{label} edge {e}: V follows U");
        for other in 0..n {
            assert!(
                dist(other).0 >= du - 1e-9,
                "{label} edge {e}: r={r} is not the closest"
            );
        }
        checked += 1;
    }
    assert!(checked > 0);
}

#[test]
fn matchings_are_antisymmetric_and_closest() {
    if let Some(mesh) = load("kitten.obj") {
        for sym in SYMS {
            let res = compute_field(&mesh, &params(sym)).unwrap();
            check_matchings(&mesh, &res.field, "kitten");
            assert!(field::max_matching_residual(&mesh, &res.field) <= PI / sym.n() as f64 + 1e-9);
        }
        // Algorithm 5 (raw curvature field, eq. 3.3) also uses closest matchings.
        check_matchings(
            &mesh,
            &field::curvature_field(&mesh, Symmetry::Four),
            "kitten raw",
        );
    }
    let torus = generate::torus(3.0, 1.0, 40, 14);
    for sym in SYMS {
        check_matchings(
            &torus,
            &compute_field(&torus, &params(sym)).unwrap().field,
            "torus",
        );
    }
}

#[test]
fn complex_relaxation_beats_spanning_forest() {
    let Some(mesh) = load("kitten.obj") else {
        return;
    };
    let mut e = Vec::new();
    for relaxation in [Relaxation::Complex, Relaxation::SpanningForest] {
        let res = compute_field(
            &mesh,
            &FieldParams {
                relaxation,
                ..params(Symmetry::Four)
            },
        )
        .unwrap();
        assert_eq!(res.indices.interior_sum_k, 0);
        println!(
            "kitten {relaxation:?}: E_smooth {:.3}, E_align {:.4}, {} singularities, {} passes",
            res.e_smooth,
            res.e_align,
            res.indices.singularities.len(),
            res.passes
        );
        e.push((res.e_smooth, res.indices.singularities.len()));
    }
    assert!(e[0].0 < e[1].0 && e[0].1 <= e[1].1);
}

#[test]
fn density_scales_frames() {
    let grid = generate::grid(20, 20, 2.0, 1.0);
    for (sym, cell) in [(Symmetry::Four, 1.0), (Symmetry::Six, 3f64.sqrt() / 2.0)] {
        let res = compute_field(
            &grid,
            &FieldParams {
                density: Density::TargetVertices(200),
                ..params(sym)
            },
        )
        .unwrap();
        let h = (2.0 / (cell * 200.0)).sqrt();
        assert!((res.grid_size - h).abs() < 1e-12);
        for [u, v] in &res.field.frames {
            assert!((u.length() - 1.0 / h).abs() < 1e-9 && (v.length() - 1.0 / h).abs() < 1e-9);
            assert!(u.dot(*v).abs() < 1e-9);
        }
    }
    let ramp = compute_field(
        &grid,
        &FieldParams {
            density: Density::EdgeLength(0.1),
            scale: ScaleFunction::LinearRamp {
                axis: [1.0, 0.0, 0.0],
                from: 1.0,
                to: 3.0,
            },
            ..params(Symmetry::Four)
        },
    )
    .unwrap();
    let xs: Vec<f64> = (0..grid.n_faces())
        .map(|f| grid.face_centroid(f).x)
        .collect();
    let (lo, hi) = (
        xs.iter().cloned().fold(f64::INFINITY, f64::min),
        xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
    );
    for (f, x) in xs.iter().enumerate() {
        let expect = 1.0 + 2.0 * (x - lo) / (hi - lo);
        assert!(
            (ramp.field.frames[f][0].length() - expect / 0.1).abs() < 1e-6,
            "face {f}"
        );
    }
    let cyl = generate::cylinder(1.0, 3.0, 24, 8);
    let curv = compute_field(
        &cyl,
        &FieldParams {
            scale: ScaleFunction::Curvature {
                strength: 1.0,
                max_ratio: 4.0,
            },
            ..params(Symmetry::Four)
        },
    )
    .unwrap();
    assert!(curv.multipliers.iter().all(|m| (1.0..=4.0).contains(m)));
    for bad in [Density::EdgeLength(0.0), Density::TargetVertices(0)] {
        let p = FieldParams {
            density: bad,
            ..params(Symmetry::Four)
        };
        assert!(matches!(
            compute_field(&grid, &p),
            Err(FieldError::InvalidParameter(_))
        ));
    }
}

#[test]
fn json_round_trip_is_exact_and_import_is_validated() {
    let torus = generate::torus(3.0, 1.0, 30, 12);
    let res = compute_field(&torus, &params(Symmetry::Six)).unwrap();
    let text = io::to_json(&res.field).unwrap();
    let back = io::from_json(&text, &torus).unwrap();
    assert!(back == res.field, "bit-exact round trip");
    assert_eq!(io::to_json(&back).unwrap(), text);
    // A byte order mark before the JSON (some Windows editors) is skipped.
    let marked = io::from_json(&format!("\u{feff}{text}"), &torus).unwrap();
    assert!(marked == res.field);

    // Awkward doubles: subnormals, extremes, 17-digit values.
    let mut awkward = res.field.clone();
    let specials = [
        f64::MIN_POSITIVE,
        5e-324,
        f64::MAX,
        -f64::MAX,
        0.1 + 0.2,
        1.0 / 3.0,
        -0.0,
        123456789.12345678,
        2.225_073_858_507_201e-308,
        9007199254740993.0,
    ];
    let mut state = 0x9E3779B97F4A7C15u64;
    for (f, fr) in awkward.frames.iter_mut().enumerate() {
        for k in 0..3 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let random = f64::from_bits(state & !(0x7FFu64 << 52) | ((state % 2046 + 1) << 52));
            fr[0][k] = if f < specials.len() {
                specials[(f + k) % specials.len()]
            } else {
                random
            };
        }
    }
    let text = io::to_json(&awkward).unwrap();
    let back = io::from_json(&text, &torus).unwrap();
    for (f, (a, b)) in awkward.frames.iter().zip(&back.frames).enumerate() {
        for k in 0..3 {
            assert_eq!(
                a[0][k].to_bits(),
                b[0][k].to_bits(),
                "face {f} component {k}: {} vs {}",
                a[0][k],
                b[0][k]
            );
        }
    }

    // Validation errors.
    let other = generate::torus(3.0, 1.0, 31, 12);
    assert!(matches!(
        io::from_json(&text, &other),
        Err(FieldError::MeshMismatch(_))
    ));
    let bad = text.replacen("\"symmetry\":6", "\"symmetry\":5", 1);
    assert!(matches!(
        io::from_json(&bad, &torus),
        Err(FieldError::InvalidParameter(_))
    ));
    let bad = text.replacen("quadcover-frame-field", "something-else", 1);
    assert!(matches!(
        io::from_json(&bad, &torus),
        Err(FieldError::Format(_))
    ));
    let mut wrong = res.field.clone();
    wrong.matchings[0] = 7;
    let bad = io::to_json(&wrong).unwrap();
    assert!(matches!(
        io::from_json(&bad, &torus),
        Err(FieldError::Format(_))
    ));
    let mut short = res.field.clone();
    short.frames.pop();
    let bad = io::to_json(&short).unwrap().replacen(
        &format!("\"num_faces\":{}", torus.n_faces() - 1),
        &format!("\"num_faces\":{}", torus.n_faces()),
        1,
    );
    assert!(matches!(
        io::from_json(&bad, &torus),
        Err(FieldError::Format(_))
    ));
    assert!(matches!(
        io::from_json("{", &torus),
        Err(FieldError::Format(_))
    ));
    let cyl = generate::cylinder(1.0, 1.0, 8, 2);
    let mut f = compute_field(&cyl, &params(Symmetry::Four)).unwrap().field;
    let e = (0..cyl.n_edges())
        .find(|&e| cyl.is_boundary_edge(e))
        .unwrap();
    f.matchings[e] = 1;
    assert!(matches!(
        io::from_json(&io::to_json(&f).unwrap(), &cyl),
        Err(FieldError::Format(_))
    ));
}

/// Benchmark (release): `cargo test --release --test field bench -- --ignored --nocapture`.
#[test]
#[ignore]
fn bench_bunny_and_subdivided() {
    let Some(bunny) = load("bunny.obj") else {
        return;
    };
    let mut m = bunny;
    for level in 0..3 {
        let t = Instant::now();
        let stages = field::bench_field(&m);
        println!("{} faces (subdivision level {level}):", m.n_faces());
        for (name, s) in stages {
            println!("  {name:45} {s:8.3} s");
        }
        println!("  (wall {:.3} s)", t.elapsed().as_secs_f64());
        m = generate::subdivide(&m);
    }
}

/// Sec. 3.3: cancelling close opposite singularity pairs removes them, keeps the index theorem,
/// and leaves no pair of opposite signs closer than the radius. Exact opposites go in pairs; a
/// −2/4 beside a +1/4 leaves a −1/4, so the count may drop by an odd number.
#[test]
fn close_opposite_singularities_are_cancelled_in_pairs() {
    let Some(mesh) = load("max-planck.obj") else {
        return;
    };
    let run = |within: f64| {
        compute_field(
            &mesh,
            &FieldParams {
                cancel_pairs_within: within,
                ..params(Symmetry::Four)
            },
        )
        .unwrap()
    };
    let (plain, cancelled) = (run(0.0), run(1.0));
    let (a, b) = (
        plain.indices.singularities.len(),
        cancelled.indices.singularities.len(),
    );
    println!("max-planck N=4: {a} singularities, {b} after cancelling close pairs");
    assert!(b < a, "{a} -> {b}");
    // Every singularity of index ±2/4 next to an opposite one within the radius merged: the
    // count dropped by one per such merge and by two per exact pair.
    let doubles = |r: &quadcover::field::FieldResult| {
        r.indices
            .singularities
            .iter()
            .filter(|s| s.k.abs() >= 2)
            .count()
    };
    println!(
        "±2/4 singularities: {} -> {}",
        doubles(&plain),
        doubles(&cancelled)
    );
    assert_eq!(
        cancelled.indices.interior_sum_k,
        plain.indices.interior_sum_k
    );
    assert_eq!(
        cancelled.indices.interior_sum_k,
        4 * mesh.euler_characteristic()
    );
    let s = &cancelled.indices.singularities;
    for i in 0..s.len() {
        for j in i + 1..s.len() {
            // Opposite signs, and not a pole (±4/4) with a smaller index.
            let (ki, kj) = (s[i].k, s[j].k);
            let cancels = ki + kj == 0 || (ki * kj < 0 && ki.abs().max(kj.abs()) < 4);
            if cancels {
                let d = (mesh.position(s[i].vertex) - mesh.position(s[j].vertex)).length();
                assert!(d >= cancelled.grid_size, "pair {i}, {j} left {d} apart");
            }
        }
    }
    // A cancelled pair's curl stays behind as residual twist on the edges around where it was
    // (the local step of QuadCover removes it); elsewhere matchings stay the closest ones.
    let removed: Vec<glam::DVec3> = plain
        .indices
        .singularities
        .iter()
        .filter(|p| !s.iter().any(|q| q.vertex == p.vertex))
        .map(|p| mesh.position(p.vertex))
        .collect();
    let twisted = twisted_edges(&mesh, &cancelled.field);
    println!("{} edges twisted past 45 degrees", twisted.len());
    assert!(twisted.len() <= a - b, "{} twisted edges", twisted.len());
    for e in twisted {
        let p = mesh.position(mesh.edge_vertices(e)[0]);
        let near = removed
            .iter()
            .any(|q| (p - *q).length() < 2.0 * cancelled.grid_size);
        assert!(
            near,
            "edge {e} twisted far from every cancelled singularity"
        );
    }
    assert!(twisted_edges(&mesh, &plain.field).is_empty());
}

/// Edges where the stored matching is not the closest (frames differ by more than π/N).
fn twisted_edges(mesh: &TriMesh, fld: &FrameField) -> Vec<usize> {
    let n = fld.symmetry.n() as f64;
    (0..mesh.n_edges())
        .filter(|&e| {
            let (h0, h1) = mesh.edge_halfedges(e);
            let Some(h1) = h1 else { return false };
            let (i, j) = (mesh.face_of(h0), mesh.face_of(h1));
            let (ni, nj) = (mesh.face_normal(i), mesh.face_normal(j));
            let d = mesh.vector(h0).normalize();
            let q = DQuat::from_axis_angle(d, ni.cross(nj).dot(d).atan2(ni.dot(nj)));
            let (ui, vi) = (q * fld.frames[i][0], q * fld.frames[i][1]);
            let m = field::matching_matrix(fld.symmetry, fld.matchings[e]);
            let mu = m[0][0] * ui + m[0][1] * vi;
            let uj = fld.frames[j][0];
            mu.cross(uj).length().atan2(mu.dot(uj)) > PI / n + 1e-9
        })
        .collect()
}

/// Issue: adjacent or very close singularities of opposite index, integral ones included (+2/2
/// next to −2/2), must not survive the close-pair cancellation. At N = 2 every pair used to be
/// doubled instead of cancelled (the angle-based sign test cannot orient a half-turn move):
/// the bunny kept a +2/2, −2/2 pair, max-planck 2 + 3 and igea 7 + 7 integral singularities.
/// Now no opposite pair closer than the radius is left, and no integral singularity at all:
/// every shared mesh at N = 2, the bunny also at N = 4 and 6.
#[test]
fn no_close_opposite_pair_survives_the_cancellation() {
    let runs = meshes::EVERY_BUT_IGEA
        .into_iter()
        .chain(["igea.obj"])
        .map(|name| (name, Symmetry::Two))
        .chain([("bunny.obj", Symmetry::Four), ("bunny.obj", Symmetry::Six)]);
    let mut checked = 0;
    for (name, symmetry) in runs {
        let Some(mesh) = load(name) else {
            continue;
        };
        let t = Instant::now();
        let p = params(symmetry);
        let n = symmetry.n() as i32;
        let fld = compute_field(&mesh, &p).unwrap();
        let radius = p.cancel_pairs_within * fld.grid_size;
        let s = &fld.indices.singularities;
        let mut close = Vec::new();
        for i in 0..s.len() {
            for j in i + 1..s.len() {
                let d = (mesh.position(s[i].vertex) - mesh.position(s[j].vertex)).length();
                if s[i].k + s[j].k == 0 && d < radius {
                    close.push((s[i], s[j], d / fld.grid_size));
                }
            }
        }
        let integral: Vec<_> = s.iter().filter(|x| x.k % n == 0).collect();
        println!(
            "{name} N={n}: {} singularities, {} integral, {} close opposite pairs ({:.2} s)",
            s.len(),
            integral.len(),
            close.len(),
            t.elapsed().as_secs_f64()
        );
        assert!(
            close.is_empty(),
            "{name}, N = {n}: close opposite pairs {close:?}"
        );
        assert!(
            integral.is_empty(),
            "{name}, N = {n}: integral singularities {integral:?}"
        );
        let defect = fld.indices.poincare_hopf_defect();
        assert!(defect.abs() < 1e-6, "{name}: Poincaré–Hopf defect {defect}");
        checked += 1;
    }
    if checked == 0 {
        println!("skipping: no shared meshes");
    }
}

/// `renormalize_field` (MBO steps on the relaxed solve, `smoothing::RENORMALIZE_STEPS`): the
/// field's energy E_smooth + τ E_align is lower than the plain relaxed solve's rounding gives,
/// and so is the map's conformal distortion (measured 2026-12-03, N = 4, default settings:
/// spot 1.253 → 1.161, fertility 1.208 → 1.181 since the gaps are rounded to D₂; 1.242 →
/// 1.181 on 2Z²), with no fold after the repair.
#[test]
fn renormalizing_the_field_lowers_its_energy_and_the_distortion() {
    use quadcover::edit::Settings;
    for name in ["spot.obj", "fertility.obj"] {
        let Some(path) = meshes::shared(name) else {
            return;
        };
        let solve = |renormalize_field: bool| {
            let settings = Settings {
                renormalize_field,
                ..Settings::default()
            };
            let tau = settings.tau;
            let base = meshes::base_for(&path, settings);
            let f = base.field_of(base.initial());
            let energy = f.e_smooth + tau * f.e_align;
            let solved = base.solve(base.initial(), &quadcover::edit::never).unwrap();
            (energy, solved.param)
        };
        let (e0, p0) = solve(false);
        let (e1, p1) = solve(true);
        eprintln!(
            "{name}: field energy {e0:.3} → {e1:.3}, conformal distortion {:.4} → {:.4}, {} singularities → {}",
            p0.conformal_distortion.mean,
            p1.conformal_distortion.mean,
            p0.singularities.len(),
            p1.singularities.len()
        );
        assert!(e1 < e0, "{name}: energy {e0} → {e1}");
        assert!(
            p1.conformal_distortion.mean < 0.985 * p0.conformal_distortion.mean,
            "{name}: {:?} → {:?}",
            p0.conformal_distortion,
            p1.conformal_distortion
        );
        assert_eq!(p1.flipped_faces, 0, "{name}");
    }
}

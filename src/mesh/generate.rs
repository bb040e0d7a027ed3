//! Generated meshes with known geometry and topology, for tests and benchmarks.

use std::collections::HashMap;
use std::f64::consts::TAU;

use glam::DVec3;

use super::TriMesh;

fn build(positions: Vec<DVec3>, faces: Vec<[u32; 3]>) -> TriMesh {
    TriMesh::from_triangles(positions, faces).expect("generated meshes are valid")
}

/// Splits each quad `(a, b, c, d)` (counter-clockwise) into two triangles along alternating diagonals.
fn quad(faces: &mut Vec<[u32; 3]>, a: u32, b: u32, c: u32, d: u32, flip: bool) {
    if flip {
        faces.push([a, b, d]);
        faces.push([b, c, d]);
    } else {
        faces.push([a, b, c]);
        faces.push([a, c, d]);
    }
}

/// A flat `nx × ny` grid on [0, sx] × [0, sy] in the plane z = 0 (a disc topologically).
pub fn grid(nx: usize, ny: usize, sx: f64, sy: f64) -> TriMesh {
    let mut p = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            p.push(DVec3::new(
                sx * i as f64 / nx as f64,
                sy * j as f64 / ny as f64,
                0.0,
            ));
        }
    }
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    let mut f = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            quad(
                &mut f,
                id(i, j),
                id(i + 1, j),
                id(i + 1, j + 1),
                id(i, j + 1),
                (i + j) % 2 == 1,
            );
        }
    }
    build(p, f)
}

/// A flat disc of radius `r`: an `n × n` grid on [-1, 1]² mapped onto the disc by the
/// elliptical grid mapping (x√(1 − y²/2), y√(1 − x²/2)), which keeps triangles well shaped.
pub fn disc(r: f64, n: usize) -> TriMesh {
    let square = grid(n, n, 2.0, 2.0);
    let p = square
        .positions()
        .iter()
        .map(|q| {
            let (x, y) = (q.x - 1.0, q.y - 1.0);
            DVec3::new(
                x * (1.0 - y * y / 2.0).sqrt(),
                y * (1.0 - x * x / 2.0).sqrt(),
                0.0,
            ) * r
        })
        .collect();
    let mut m = square;
    m.set_positions(p);
    m
}

/// A flat disc of radius `r` made of concentric rings, ring i (1..=rings) with 6i vertices
/// around one centre vertex: a round rim without the grid mapping's four corners ([`disc`] has
/// fans of flat triangles where the square's corners were).
pub fn round_disc(r: f64, rings: usize) -> TriMesh {
    let mut p = vec![DVec3::ZERO];
    let mut start = vec![0usize];
    for i in 1..=rings {
        start.push(p.len());
        let n = 6 * i;
        // Odd rings turned by half a step, so that consecutive rings interleave.
        let offset = if i % 2 == 1 { 0.5 } else { 0.0 };
        for k in 0..n {
            let a = std::f64::consts::TAU * (k as f64 + offset) / n as f64;
            p.push(DVec3::new(a.cos(), a.sin(), 0.0) * (r * i as f64 / rings as f64));
        }
    }
    let mut f = Vec::new();
    for i in 1..=rings {
        let (inner, outer) = (6 * (i - 1), 6 * i);
        let angle = |ring: usize, k: usize| {
            let n = 6 * ring;
            let offset = if ring % 2 == 1 { 0.5 } else { 0.0 };
            (k as f64 + offset) / n.max(1) as f64
        };
        let at = |ring: usize, k: usize| {
            let n = (6 * ring).max(1);
            (start[ring] + k % n) as u32
        };
        // Zip the two rings together by angle (counter-clockwise triangles).
        let (mut a, mut b) = (0usize, 0usize);
        while a < inner.max(1) && inner > 0 || b < outer {
            let next_inner = if inner == 0 {
                f64::INFINITY
            } else {
                angle(i - 1, a + 1)
            };
            let next_outer = angle(i, b + 1);
            if b < outer && (a >= inner || next_outer <= next_inner) {
                f.push([at(i - 1, a), at(i, b), at(i, b + 1)]);
                b += 1;
            } else {
                f.push([at(i - 1, a), at(i, b), at(i - 1, a + 1)]);
                a += 1;
            }
        }
    }
    build(p, f)
}

/// An open cylinder of radius `r` and height `h` around the z axis (`nu` around, `nv` up).
pub fn cylinder(r: f64, h: f64, nu: usize, nv: usize) -> TriMesh {
    let mut p = Vec::new();
    for j in 0..=nv {
        for i in 0..nu {
            let a = TAU * i as f64 / nu as f64;
            p.push(DVec3::new(
                r * a.cos(),
                r * a.sin(),
                h * j as f64 / nv as f64,
            ));
        }
    }
    let id = |i: usize, j: usize| (j * nu + i % nu) as u32;
    let mut f = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            quad(
                &mut f,
                id(i, j),
                id(i + 1, j),
                id(i + 1, j + 1),
                id(i, j + 1),
                false,
            );
        }
    }
    build(p, f)
}

/// A closed cylinder: [`cylinder`]'s side with each end capped by `rings` polar rings around
/// a centre vertex (a CAD part's round faces; with features its rims are closed curves).
pub fn capped_cylinder(r: f64, h: f64, nu: usize, nv: usize, rings: usize) -> TriMesh {
    let mut p = Vec::new();
    let ring = |p: &mut Vec<DVec3>, rr: f64, z: f64| -> u32 {
        let first = p.len() as u32;
        for i in 0..nu {
            let a = TAU * i as f64 / nu as f64;
            p.push(DVec3::new(rr * a.cos(), rr * a.sin(), z));
        }
        first
    };
    let side: Vec<u32> = (0..=nv)
        .map(|j| ring(&mut p, r, h * j as f64 / nv as f64))
        .collect();
    let at = |first: u32, i: usize| first + (i % nu) as u32;
    let mut f = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            let (a, b) = (at(side[j], i), at(side[j], i + 1));
            let (c, d) = (at(side[j + 1], i + 1), at(side[j + 1], i));
            quad(&mut f, a, b, c, d, false);
        }
    }
    for (rim, z, up) in [(side[0], 0.0, false), (side[nv], h, true)] {
        // Rings from the rim inwards, then the centre; the bottom cap faces down.
        let mut outer = rim;
        for k in (1..rings).rev() {
            let inner = ring(&mut p, r * k as f64 / rings as f64, z);
            for i in 0..nu {
                let (a, b) = (at(outer, i), at(outer, i + 1));
                let (c, d) = (at(inner, i + 1), at(inner, i));
                if up {
                    quad(&mut f, a, b, c, d, false);
                } else {
                    f.push([a, c, b]);
                    f.push([a, d, c]);
                }
            }
            outer = inner;
        }
        let centre = p.len() as u32;
        p.push(DVec3::new(0.0, 0.0, z));
        for i in 0..nu {
            let (a, b) = (at(outer, i), at(outer, i + 1));
            f.push(if up { [a, b, centre] } else { [b, a, centre] });
        }
    }
    build(p, f)
}

/// A closed cylinder as a CAD exporter tessellates it (an STL): the side one row of `nu` long
/// quads split into two triangles each, each cap a fan from its first rim vertex. Every triangle
/// is a needle and the caps have no interior vertex (`mesh::isotropic`).
pub fn raw_cylinder(r: f64, h: f64, nu: usize) -> TriMesh {
    let mut p = Vec::new();
    for z in [0.0, h] {
        for i in 0..nu {
            let a = TAU * i as f64 / nu as f64;
            p.push(DVec3::new(r * a.cos(), r * a.sin(), z));
        }
    }
    let (bottom, top) = (0u32, nu as u32);
    let at = |first: u32, i: usize| first + (i % nu) as u32;
    let mut f = Vec::new();
    for i in 0..nu {
        let (a, b) = (at(bottom, i), at(bottom, i + 1));
        let (c, d) = (at(top, i + 1), at(top, i));
        quad(&mut f, a, b, c, d, false);
    }
    for i in 1..nu - 1 {
        f.push([at(bottom, 0), at(bottom, i + 1), at(bottom, i)]);
        f.push([at(top, 0), at(top, i), at(top, i + 1)]);
    }
    build(p, f)
}

/// A closed cone as a CAD exporter tessellates it: apex at height `h` over a base circle of
/// radius `r` with `nu` rim vertices, the side a fan from the apex, the base a fan from its
/// centre.
pub fn raw_cone(r: f64, h: f64, nu: usize) -> TriMesh {
    let mut p = vec![DVec3::new(0.0, 0.0, h), DVec3::ZERO];
    p.extend((0..nu).map(|i| {
        let a = TAU * i as f64 / nu as f64;
        DVec3::new(r * a.cos(), r * a.sin(), 0.0)
    }));
    let rim = |i: usize| (2 + i % nu) as u32;
    let f = (0..nu)
        .flat_map(|i| [[0, rim(i), rim(i + 1)], [1, rim(i + 1), rim(i)]])
        .collect();
    build(p, f)
}

/// A torus of revolution around z: major radius `big_r`, minor `r`, `nu` × `nv` quads.
/// Vertex (i, j) sits at angles u = 2πi/nu (around z) and v = 2πj/nv (around the tube).
pub fn torus(big_r: f64, r: f64, nu: usize, nv: usize) -> TriMesh {
    torus_mesh(big_r, r, nu, nv, false)
}

/// Like [`torus`], with quad diagonals alternating in a checkerboard (no preferred diagonal
/// direction, like an unstructured mesh).
pub fn torus_alternating(big_r: f64, r: f64, nu: usize, nv: usize) -> TriMesh {
    torus_mesh(big_r, r, nu, nv, true)
}

fn torus_mesh(big_r: f64, r: f64, nu: usize, nv: usize, alternate: bool) -> TriMesh {
    let mut p = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            let (u, v) = (TAU * i as f64 / nu as f64, TAU * j as f64 / nv as f64);
            let rho = big_r + r * v.cos();
            p.push(DVec3::new(rho * u.cos(), rho * u.sin(), r * v.sin()));
        }
    }
    let id = |i: usize, j: usize| ((j % nv) * nu + i % nu) as u32;
    let mut f = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            let flip = alternate && (i + j) % 2 == 1;
            quad(
                &mut f,
                id(i, j),
                id(i + 1, j),
                id(i + 1, j + 1),
                id(i, j + 1),
                flip,
            );
        }
    }
    build(p, f)
}

/// A unit UV sphere: `rings` latitude bands, `segments` meridians, one vertex at each pole
/// (vertex 0 north, the last one south) with a fan of `segments` triangles; the bands' quads
/// are split along alternating diagonals.
pub fn uv_sphere(rings: usize, segments: usize) -> TriMesh {
    let (rings, segments) = (rings.max(2), segments.max(3));
    let mut p = vec![DVec3::Z];
    for i in 1..rings {
        let theta = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = std::f64::consts::TAU * j as f64 / segments as f64;
            p.push(DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ));
        }
    }
    p.push(-DVec3::Z);
    let south = (p.len() - 1) as u32;
    let at = |i: usize, j: usize| (1 + (i - 1) * segments + j % segments) as u32;
    let mut f = Vec::new();
    for j in 0..segments {
        f.push([0, at(1, j), at(1, j + 1)]);
        f.push([south, at(rings - 1, j + 1), at(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            if (i + j) % 2 == 0 {
                f.extend([[a, b, c], [a, c, d]]);
            } else {
                f.extend([[a, b, d], [b, c, d]]);
            }
        }
    }
    build(p, f)
}

/// A unit icosphere: the icosahedron subdivided `levels` times and projected to the sphere.
pub fn icosphere(levels: usize) -> TriMesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let p: Vec<DVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut m = build(p, f);
    for _ in 0..levels {
        m = subdivide(&m);
        let p = m.positions().iter().map(|x| x.normalize()).collect();
        m.set_positions(p);
    }
    m
}

/// The unit cube's corners: corner `i` at (bit 0, bit 1, bit 2) of `i`.
pub fn cube_corners() -> Vec<DVec3> {
    (0..8)
        .map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
        .collect()
}

/// The unit cube's faces over [`cube_corners`], counter-clockwise seen from outside: z = 0,
/// z = 1, y = 0, y = 1, x = 0, x = 1.
pub const CUBE_QUADS: [[u32; 4]; 6] = [
    [0, 2, 3, 1],
    [4, 5, 7, 6],
    [0, 1, 5, 4],
    [2, 6, 7, 3],
    [0, 4, 6, 2],
    [1, 3, 7, 5],
];

/// The unit cube [0, 1]³ as 12 triangles (outward normals), subdivided `levels` times.
pub fn cube(levels: usize) -> TriMesh {
    let t: Vec<[u32; 3]> = CUBE_QUADS
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    let mut m = TriMesh::from_triangles(cube_corners(), t).expect("a closed cube");
    for _ in 0..levels {
        m = subdivide(&m);
    }
    m
}

/// 1:4 midpoint subdivision (positions of old vertices unchanged; topology preserved).
pub fn subdivide(mesh: &TriMesh) -> TriMesh {
    let mut p = mesh.positions().to_vec();
    let mut mid: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.n_edges());
    let mut midpoint = |a: u32, b: u32, p: &mut Vec<DVec3>| {
        *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
            p.push(0.5 * (p[a as usize] + p[b as usize]));
            (p.len() - 1) as u32
        })
    };
    let mut f = Vec::with_capacity(mesh.n_faces() * 4);
    for &[a, b, c] in mesh.faces() {
        let ab = midpoint(a, b, &mut p);
        let bc = midpoint(b, c, &mut p);
        let ca = midpoint(c, a, &mut p);
        f.extend_from_slice(&[[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
    build(p, f)
}

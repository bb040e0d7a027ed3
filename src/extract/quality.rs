//! Quality measures of a remesh (thesis sec. 5.2, tables 5.1 / 5.2).

use std::collections::{BTreeMap, HashMap};

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::{ExtractError, ExtractOptions, Remesh, extract};
use crate::mesh::TriMesh;

/// Quality of an extracted mesh.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RemeshQuality {
    pub vertices: usize,
    pub faces: usize,
    /// Number of faces by number of sides.
    pub faces_by_sides: BTreeMap<usize, usize>,
    /// Regular interior valence used (4 for quad meshes, 6 for triangle meshes, 3 for hexagons).
    pub regular_valence: usize,
    /// Interior vertices whose valence differs from `regular_valence`.
    pub irregular_vertices: usize,
    pub boundary_vertices: usize,
    /// Relative standard deviation (std / mean) of the edge lengths.
    pub rsd_edge: f64,
    /// Root mean square deviation of the corner angles from the ideal angle (90° quads, 60°
    /// triangles, 120° hexagons), relative to the ideal angle.
    pub rsd_angle: f64,
    pub min_angle_deg: f64,
    pub max_angle_deg: f64,
    /// Distance of sampled output points (vertices, edge midpoints) to the input surface,
    /// relative to the input's bounding-box diagonal.
    pub max_distance: f64,
    pub mean_distance: f64,
    pub polylines: usize,
    pub patched_places: usize,
    /// Directed edges used twice or undirected edges in more than two faces.
    pub non_manifold_edges: usize,
}

impl std::fmt::Display for RemeshQuality {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "vertices        {}", self.vertices)?;
        writeln!(
            f,
            "faces           {} {:?}",
            self.faces, self.faces_by_sides
        )?;
        writeln!(
            f,
            "irregular       {} (interior valence != {})",
            self.irregular_vertices, self.regular_valence
        )?;
        writeln!(f, "RSD edge        {:.2} %", 100.0 * self.rsd_edge)?;
        writeln!(f, "RSD angle       {:.2} %", 100.0 * self.rsd_angle)?;
        writeln!(
            f,
            "angles          {:.1}° .. {:.1}°",
            self.min_angle_deg, self.max_angle_deg
        )?;
        writeln!(
            f,
            "distance        max {:.2e}, mean {:.2e} (of bbox diagonal)",
            self.max_distance, self.mean_distance
        )?;
        if self.polylines > 0 {
            writeln!(f, "polylines       {}", self.polylines)?;
        }
        writeln!(f, "non-manifold    {}", self.non_manifold_edges)?;
        write!(f, "patched places  {}", self.patched_places)
    }
}

/// Quality measures of `remesh` against the input surface `input`.
pub fn quality(remesh: &Remesh, input: &TriMesh) -> RemeshQuality {
    let mut q = RemeshQuality {
        vertices: remesh.positions.len(),
        faces: remesh.faces.len(),
        polylines: remesh.polylines.len(),
        patched_places: remesh.patched_places,
        ..Default::default()
    };
    for f in &remesh.faces {
        *q.faces_by_sides.entry(f.len()).or_default() += 1;
    }
    let dominant = q
        .faces_by_sides
        .iter()
        .max_by_key(|x| *x.1)
        .map(|x| *x.0)
        .unwrap_or(4);
    let (regular, ideal) = match dominant {
        3 => (6, 60f64),
        6 => (3, 120f64),
        _ => (4, 90f64),
    };
    q.regular_valence = regular;
    let p = &remesh.positions;
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    let mut undirected: HashMap<(u32, u32), usize> = HashMap::new();
    let mut angles = Vec::new();
    for f in &remesh.faces {
        let n = f.len();
        for k in 0..n {
            let (a, b) = (f[k], f[(k + 1) % n]);
            *directed.entry((a, b)).or_default() += 1;
            *undirected.entry((a.min(b), a.max(b))).or_default() += 1;
            let c = f[(k + n - 1) % n];
            let (u, v) = (p[c as usize] - p[a as usize], p[b as usize] - p[a as usize]);
            let ang = u.angle_between(v).to_degrees();
            if ang.is_finite() {
                angles.push(ang);
            }
        }
    }
    q.non_manifold_edges = directed.values().filter(|&&c| c > 1).count()
        + undirected.values().filter(|&&c| c > 2).count();
    let mut valence = vec![0usize; p.len()];
    let mut boundary = vec![false; p.len()];
    let mut lengths = Vec::new();
    for (&(a, b), &c) in &undirected {
        valence[a as usize] += 1;
        valence[b as usize] += 1;
        if c == 1 {
            boundary[a as usize] = true;
            boundary[b as usize] = true;
        }
        lengths.push((p[a as usize] - p[b as usize]).length());
    }
    for pl in &remesh.polylines {
        for w in pl.windows(2) {
            lengths.push((p[w[0] as usize] - p[w[1] as usize]).length());
        }
    }
    q.boundary_vertices = boundary.iter().filter(|&&b| b).count();
    if !remesh.faces.is_empty() {
        q.irregular_vertices = (0..p.len())
            .filter(|&v| !boundary[v] && valence[v] > 0 && valence[v] != regular)
            .count();
    }
    if !lengths.is_empty() {
        let mean = lengths.iter().sum::<f64>() / lengths.len() as f64;
        let var = lengths.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / lengths.len() as f64;
        q.rsd_edge = if mean > 0.0 { var.sqrt() / mean } else { 0.0 };
    }
    if !angles.is_empty() {
        let ms = angles.iter().map(|a| (a - ideal).powi(2)).sum::<f64>() / angles.len() as f64;
        q.rsd_angle = ms.sqrt() / ideal;
        q.min_angle_deg = angles.iter().copied().fold(f64::INFINITY, f64::min);
        q.max_angle_deg = angles.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    }
    // Distances.
    let mut samples: Vec<DVec3> = p.clone();
    samples.extend(
        undirected
            .keys()
            .map(|&(a, b)| 0.5 * (p[a as usize] + p[b as usize])),
    );
    let (lo, hi) = input.bounding_box();
    let diag = (hi - lo).length().max(1e-300);
    let locator = Locator::new(input);
    let d: Vec<f64> = samples
        .par_iter()
        .map(|&s| locator.distance(s) / diag)
        .collect();
    if !d.is_empty() {
        q.max_distance = d.iter().copied().fold(0.0, f64::max);
        q.mean_distance = d.iter().sum::<f64>() / d.len() as f64;
    }
    q
}

/// Every corner angle of every face, in degrees (what the editor's histogram shows).
pub fn corner_angles_deg(remesh: &Remesh) -> Vec<f64> {
    let p = &remesh.positions;
    let mut out = Vec::new();
    for f in &remesh.faces {
        let n = f.len();
        for k in 0..n {
            let (a, b, c) = (f[k], f[(k + 1) % n], f[(k + n - 1) % n]);
            let ang = (p[c as usize] - p[a as usize])
                .angle_between(p[b as usize] - p[a as usize])
                .to_degrees();
            if ang.is_finite() {
                out.push(ang);
            }
        }
    }
    out
}

/// The length of every undirected edge of the faces and polylines.
pub fn edge_lengths(remesh: &Remesh) -> Vec<f64> {
    let p = &remesh.positions;
    let mut seen = std::collections::HashSet::new();
    let mut out = Vec::new();
    let mut add = |a: u32, b: u32| {
        if seen.insert((a.min(b), a.max(b))) {
            out.push((p[a as usize] - p[b as usize]).length());
        }
    };
    for f in &remesh.faces {
        for k in 0..f.len() {
            add(f[k], f[(k + 1) % f.len()]);
        }
    }
    for pl in &remesh.polylines {
        for w in pl.windows(2) {
            add(w[0], w[1]);
        }
    }
    out
}

/// Interior vertices whose valence differs from the regular one of the dominant face type
/// (4 for quads, 6 for triangles, 3 for hexagons), in increasing order.
pub fn irregular_vertices(remesh: &Remesh) -> Vec<u32> {
    let mut by_sides: BTreeMap<usize, usize> = BTreeMap::new();
    for f in &remesh.faces {
        *by_sides.entry(f.len()).or_default() += 1;
    }
    let regular = match by_sides.iter().max_by_key(|x| *x.1).map(|x| *x.0) {
        Some(3) => 6,
        Some(6) => 3,
        _ => 4,
    };
    let mut undirected: HashMap<(u32, u32), usize> = HashMap::new();
    for f in &remesh.faces {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            *undirected.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let n = remesh.positions.len();
    let (mut valence, mut boundary) = (vec![0usize; n], vec![false; n]);
    for (&(a, b), &c) in &undirected {
        valence[a as usize] += 1;
        valence[b as usize] += 1;
        if c == 1 {
            boundary[a as usize] = true;
            boundary[b as usize] = true;
        }
    }
    (0..n as u32)
        .filter(|&v| {
            let v = v as usize;
            !boundary[v] && valence[v] > 0 && valence[v] != regular
        })
        .collect()
}

/// Extracts and measures in one call (what `solve --remesh` and `extract` use).
pub fn remesh_report(
    mesh: &TriMesh,
    uv: &[[f64; 2]],
    symmetry: u8,
    opts: &ExtractOptions,
) -> Result<(Remesh, RemeshQuality), ExtractError> {
    let r = extract(mesh, uv, symmetry, opts)?;
    let q = quality(&r, mesh);
    Ok((r, q))
}

/// Nearest-point queries over a uniform grid of triangle bounding boxes.
struct Locator<'a> {
    mesh: &'a TriMesh,
    lo: DVec3,
    cell: f64,
    dims: [usize; 3],
    cells: HashMap<[usize; 3], Vec<u32>>,
}

impl<'a> Locator<'a> {
    fn new(mesh: &'a TriMesh) -> Self {
        let (lo, hi) = mesh.bounding_box();
        let ext = (hi - lo).max(DVec3::splat(1e-12));
        // Cells about the size of a triangle, so that a query looks at a few dozen triangles;
        // grown while triangles much larger than the mean would be entered in too many cells.
        let ne = mesh.n_edges().max(1);
        let mean_edge = (0..mesh.n_edges())
            .map(|e| mesh.vector(mesh.edge_halfedges(e).0).length())
            .sum::<f64>()
            / ne as f64;
        let boxes: Vec<(DVec3, DVec3)> = (0..mesh.n_faces())
            .map(|f| {
                let [a, b, c] = mesh.face(f).map(|v| mesh.position(v));
                (a.min(b).min(c), a.max(b).max(c))
            })
            .collect();
        let mut cell = (1.5 * mean_edge).max(ext.max_element() / 2000.0).max(1e-12);
        let budget = 32 * mesh.n_faces() + 100_000;
        loop {
            let entries: usize = boxes
                .iter()
                .map(|(a, b)| {
                    let n = ((*b - lo) / cell).floor() - ((*a - lo) / cell).floor() + DVec3::ONE;
                    (n.x * n.y * n.z) as usize
                })
                .sum();
            if entries <= budget {
                break;
            }
            cell *= 1.5;
        }
        let dims = [
            (ext.x / cell).ceil() as usize + 1,
            (ext.y / cell).ceil() as usize + 1,
            (ext.z / cell).ceil() as usize + 1,
        ];
        let mut cells: HashMap<[usize; 3], Vec<u32>> = HashMap::new();
        let idx = |p: DVec3, dims: [usize; 3]| {
            let r = (p - lo) / cell;
            [
                (r.x.max(0.0) as usize).min(dims[0] - 1),
                (r.y.max(0.0) as usize).min(dims[1] - 1),
                (r.z.max(0.0) as usize).min(dims[2] - 1),
            ]
        };
        for (f, (a, b)) in boxes.iter().enumerate() {
            let (i0, i1) = (idx(*a, dims), idx(*b, dims));
            for x in i0[0]..=i1[0] {
                for y in i0[1]..=i1[1] {
                    for z in i0[2]..=i1[2] {
                        cells.entry([x, y, z]).or_default().push(f as u32);
                    }
                }
            }
        }
        Locator {
            mesh,
            lo,
            cell,
            dims,
            cells,
        }
    }

    fn distance(&self, p: DVec3) -> f64 {
        let r = (p - self.lo) / self.cell;
        let c = [r.x.floor() as i64, r.y.floor() as i64, r.z.floor() as i64];
        // p's offset within its cell, in cells.
        let frac = [r.x - c[0] as f64, r.y - c[1] as f64, r.z - c[2] as f64];
        let mut best = f64::INFINITY;
        let maxr = self.dims.iter().copied().max().unwrap_or(1) as i64 + 1;
        for ring in 0..=maxr {
            if ring > 0 {
                // Everything not yet visited lies outside the block of cells within ring − 1
                // of c, at least as far as that block's nearest face.
                let k = (ring - 1) as f64;
                let reach = (0..3)
                    .map(|i| (frac[i] + k).min(1.0 - frac[i] + k))
                    .fold(f64::INFINITY, f64::min)
                    * self.cell;
                if best <= reach {
                    break;
                }
            }
            for x in c[0] - ring..=c[0] + ring {
                for y in c[1] - ring..=c[1] + ring {
                    for z in c[2] - ring..=c[2] + ring {
                        let on_shell = (x - c[0]).abs() == ring
                            || (y - c[1]).abs() == ring
                            || (z - c[2]).abs() == ring;
                        if !on_shell || x < 0 || y < 0 || z < 0 {
                            continue;
                        }
                        let key = [x as usize, y as usize, z as usize];
                        if let Some(fs) = self.cells.get(&key) {
                            for &f in fs {
                                let [a, b, cc] =
                                    self.mesh.face(f as usize).map(|v| self.mesh.position(v));
                                best = best.min((closest_on_triangle(p, a, b, cc) - p).length());
                            }
                        }
                    }
                }
            }
        }
        best
    }
}

/// Closest point on triangle (a, b, c) to p (Ericson, Real-Time Collision Detection 5.1.5).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    a + ab * v + ac * w
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    fn brute_force(mesh: &TriMesh, p: DVec3) -> f64 {
        (0..mesh.n_faces())
            .map(|f| {
                let [a, b, c] = mesh.face(f).map(|v| mesh.position(v));
                (closest_on_triangle(p, a, b, c) - p).length()
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The grid search returns the exact nearest distance: near the surface, far from it, and on
    /// a mesh whose triangles differ in size by a factor of a thousand.
    #[test]
    fn locator_matches_brute_force() {
        let sphere = generate::icosphere(3);
        let mut uneven = generate::grid(40, 40, 1.0, 1.0);
        let mut p = uneven.positions().to_vec();
        for q in &mut p {
            q.x = q.x.powi(6) * 1000.0;
        }
        uneven = TriMesh::from_triangles(p, uneven.faces().to_vec()).unwrap();
        for mesh in [&sphere, &uneven] {
            let locator = Locator::new(mesh);
            let (lo, hi) = mesh.bounding_box();
            let mut seed = 7u64;
            let mut rnd = || {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (seed >> 11) as f64 / (1u64 << 53) as f64
            };
            for k in 0..400 {
                let t = DVec3::new(rnd(), rnd(), rnd()) * 1.4 - DVec3::splat(0.2);
                let mut q = lo + (hi - lo) * t;
                if k % 2 == 0 {
                    // near the surface: a vertex nudged
                    let v = (rnd() * mesh.n_vertices() as f64) as usize % mesh.n_vertices();
                    q = mesh.position(v) + (q - mesh.position(v)) * 1e-3;
                }
                let (a, b) = (locator.distance(q), brute_force(mesh, q));
                assert!(
                    (a - b).abs() <= 1e-12 * (1.0 + b),
                    "{q:?}: grid {a}, exact {b}"
                );
            }
        }
    }
}

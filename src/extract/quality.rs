//! Quality measures of a remesh (thesis sec. 5.2, tables 5.1 / 5.2).

use std::collections::{BTreeMap, HashMap};

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::surface::Surface;
use super::{ExtractError, ExtractOptions, Remesh};
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
    /// Two-sided Hausdorff distance between the remesh and the input, relative to the input's
    /// bounding-box diagonal: the larger of `max_distance` and the distance of the farthest
    /// (referenced) input vertex to the remesh surface (its polygons fanned around their
    /// centroids). Polylines only (stripes): `max_distance`.
    pub hausdorff: f64,
    pub polylines: usize,
    pub patched_places: usize,
    /// Directed edges used twice or undirected edges in more than two faces.
    pub non_manifold_edges: usize,
    /// Vertices whose faces form more than one fan (two boundary loops touching at a point).
    pub non_manifold_vertices: usize,
    /// What made the output pure (faces extraction left impure, snaps, collapses, midpoints,
    /// chords).
    pub purified: super::PurifyStats,
    /// What relaxation did (`null`: not run).
    pub relaxed: Option<super::relax::RelaxStats>,
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
        writeln!(
            f,
            "Hausdorff       {:.2e} (of bbox diagonal)",
            self.hausdorff
        )?;
        if self.polylines > 0 {
            writeln!(f, "polylines       {}", self.polylines)?;
        }
        writeln!(
            f,
            "non-manifold    {} edges, {} vertices",
            self.non_manifold_edges, self.non_manifold_vertices
        )?;
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
        purified: remesh.purified,
        relaxed: remesh.relaxed,
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
    for f in &remesh.faces {
        let n = f.len();
        for k in 0..n {
            let (a, b) = (f[k], f[(k + 1) % n]);
            *directed.entry((a, b)).or_default() += 1;
            *undirected.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    q.non_manifold_edges = directed.values().filter(|&&c| c > 1).count()
        + undirected.values().filter(|&&c| c > 2).count();
    q.non_manifold_vertices = super::pinch::pinched_vertices(remesh);
    let mut boundary = vec![false; p.len()];
    for (&(a, b), &c) in &undirected {
        if c == 1 {
            boundary[a as usize] = true;
            boundary[b as usize] = true;
        }
    }
    q.boundary_vertices = boundary.iter().filter(|&&b| b).count();
    if !remesh.faces.is_empty() {
        q.irregular_vertices = irregular_vertices(remesh).len();
    }
    let lengths = edge_lengths(remesh);
    if !lengths.is_empty() {
        let mean = lengths.iter().sum::<f64>() / lengths.len() as f64;
        let var = lengths.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / lengths.len() as f64;
        q.rsd_edge = if mean > 0.0 { var.sqrt() / mean } else { 0.0 };
    }
    let angles = corner_angles_deg(remesh);
    if !angles.is_empty() {
        let ms = angles.iter().map(|a| (a - ideal).powi(2)).sum::<f64>() / angles.len() as f64;
        q.rsd_angle = ms.sqrt() / ideal;
        q.min_angle_deg = angles.iter().copied().fold(f64::INFINITY, f64::min);
        q.max_angle_deg = angles.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    }
    // Distances: remesh samples (vertices, edge midpoints; sorted edges, so that the mean is
    // summed in a fixed order) to the input ...
    let mut edges: Vec<(u32, u32)> = undirected.keys().copied().collect();
    edges.sort_unstable();
    let mut samples: Vec<DVec3> = p.clone();
    samples.extend(
        edges
            .iter()
            .map(|&(a, b)| 0.5 * (p[a as usize] + p[b as usize])),
    );
    let (lo, hi) = input.bounding_box();
    let diag = (hi - lo).length().max(1e-300);
    let surface = Surface::new(input);
    let d: Vec<f64> = samples
        .par_iter()
        .map(|&s| surface.distance(s) / diag)
        .collect();
    if !d.is_empty() {
        q.max_distance = d.iter().copied().fold(0.0, f64::max);
        q.mean_distance = d.iter().sum::<f64>() / d.len() as f64;
    }
    // ... and input vertices to the remesh surface.
    q.hausdorff = q.max_distance;
    if !remesh.faces.is_empty() {
        let remesh_surface = Surface::from_polygons(&remesh.positions, &remesh.faces);
        let mut used = vec![false; input.n_vertices()];
        for t in input.faces() {
            for &v in t {
                used[v as usize] = true;
            }
        }
        let back = (0..input.n_vertices())
            .into_par_iter()
            .filter(|&v| used[v])
            .map(|v| remesh_surface.distance(input.position(v)) / diag)
            .reduce(|| 0.0, f64::max);
        q.hausdorff = q.hausdorff.max(back);
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

/// Undirected edge (low, high) -> how many faces use it.
pub(super) type EdgeUse = HashMap<(u32, u32), usize>;

/// The faces' undirected edges with how many faces use each, and per vertex its valence and
/// whether it lies on the boundary (an edge used once).
pub(super) fn edge_incidence(remesh: &Remesh) -> (EdgeUse, Vec<usize>, Vec<bool>) {
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
    (undirected, valence, boundary)
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
    let (_, valence, boundary) = edge_incidence(remesh);
    (0..remesh.positions.len() as u32)
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
    remesh_report_until(mesh, uv, symmetry, opts, &|| false)
}

/// [`remesh_report`] with a cancel check (see [`super::extract_until`]).
pub fn remesh_report_until(
    mesh: &TriMesh,
    uv: &[[f64; 2]],
    symmetry: u8,
    opts: &ExtractOptions,
    cancel: &(dyn Fn() -> bool + Sync),
) -> Result<(Remesh, RemeshQuality), ExtractError> {
    let r = super::extract_until(mesh, uv, symmetry, opts, cancel)?;
    if cancel() {
        return Err(ExtractError::Cancelled);
    }
    let q = quality(&r, mesh);
    Ok((r, q))
}

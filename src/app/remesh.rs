//! The remesh of the parameterization shown: after every solve it is extracted in the
//! background ([`crate::extract::remesh_report`]) together with everything the editor shows of
//! it — the quality numbers, the corner-angle and edge-length histograms, the overlay of its
//! edges (stripes: polylines) and irregular vertices, and its fan-triangulated polygons
//! ([`RemeshView`]) — so a frame never does more than hand out `Arc`s.
//!
//! A job carries the mesh generation and the parameterization revision it extracts
//! ([`super::document::Document::param_revision`]); results for another are dropped
//! ([`super::document::Document::take_remesh`]), a failed extraction keeps the last good remesh
//! on screen and puts its error in the status line. At most one extraction runs: one whose map
//! was replaced is flagged cancelled (the core cannot stop it midway), its result is dropped
//! when it ends, and the newest map is extracted then.

use std::collections::HashSet;
use std::sync::Arc;
use std::time::Instant;

use super::document::Document;
use super::editor::EditorApp;
use super::jobs::{Job, JobOutput};
use super::scene::{Glyph, LineSegment, Overlay, SceneData};
use super::settings::RemeshDisplay;
use super::tools::next_overlay_revision;
use crate::extract::{self, ExtractOptions, Remesh, RemeshQuality};
use crate::mesh::TriMesh;

/// Linear RGBA of the remesh's edges and stripes (a deep blue apart from the pattern's ink).
pub const EDGE_COLOR: [f32; 4] = [0.02, 0.04, 0.55, 1.0];
/// Linear RGBA of irregular vertices with fewer edges than the regular valence (magenta: they
/// sit on positive singularities, whose glyphs are yellow).
pub const FEWER_COLOR: [f32; 4] = [0.9, 0.0, 0.8, 1.0];
/// Linear RGBA of irregular vertices with more edges than the regular valence (green, on the
/// negative singularities' blue).
pub const MORE_COLOR: [f32; 4] = [0.0, 0.85, 0.3, 1.0];

/// Counts of values in equal bins from `start`; values outside go to the first or last bin.
#[derive(Clone, Debug, PartialEq)]
pub struct Histogram {
    pub start: f64,
    pub bin_width: f64,
    pub counts: Vec<usize>,
}

impl Histogram {
    pub fn new(values: &[f64], start: f64, bin_width: f64, bins: usize) -> Histogram {
        let mut counts = vec![0; bins.max(1)];
        let last = counts.len() - 1;
        for &v in values.iter().filter(|v| v.is_finite()) {
            let i = ((v - start) / bin_width).floor().max(0.0) as usize;
            counts[i.min(last)] += 1;
        }
        Histogram {
            start,
            bin_width,
            counts,
        }
    }

    /// The centre of bin `i`.
    pub fn center(&self, i: usize) -> f64 {
        self.start + (i as f64 + 0.5) * self.bin_width
    }

    pub fn total(&self) -> usize {
        self.counts.iter().sum()
    }
}

/// A remesh with all the editor shows of it, built in the background.
#[derive(Debug)]
pub struct RemeshView {
    /// Unique per extraction (the GPU uploads the surface once per id).
    pub id: u64,
    pub remesh: Remesh,
    pub quality: RemeshQuality,
    /// The ideal corner angle of the dominant face type (90° quads, 60° triangles, 120°
    /// hexagons).
    pub ideal_angle: f64,
    /// Corner angles in degrees, 5° bins over [0°, 180°].
    pub angles: Histogram,
    /// Edge lengths divided by their mean, bins of 0.05 over [0, 2.5] (longer ones in the last).
    pub lengths: Histogram,
    pub mean_edge: f64,
    /// Interior vertices of irregular valence ([`crate::extract::irregular_vertices`]).
    pub irregular: Vec<u32>,
    /// How many of them have fewer edges than the regular valence (the rest have more).
    pub fewer: usize,
    /// Edges and polylines as fine lines, irregular vertices as dots.
    pub overlay: Arc<Overlay>,
    /// The polygons fan-triangulated (`None` for stripes, which have none).
    pub surface: Option<Arc<SceneData>>,
    /// Extraction time, seconds.
    pub seconds: f64,
}

/// `3..=6` sides by name, others as n-gons.
pub fn sides_name(sides: usize, count: usize) -> String {
    let name = match sides {
        3 => "triangle",
        4 => "quad",
        5 => "pentagon",
        6 => "hexagon",
        _ => return format!("{count} {sides}-gon{}", if count == 1 { "" } else { "s" }),
    };
    format!("{count} {name}{}", if count == 1 { "" } else { "s" })
}

impl RemeshView {
    /// Measures and prepares a remesh for display (runs off the UI thread).
    pub fn new(remesh: Remesh, quality: RemeshQuality, seconds: f64) -> RemeshView {
        let ideal_angle = match quality.regular_valence {
            6 => 60.0,
            3 => 120.0,
            _ => 90.0,
        };
        let angles = Histogram::new(&extract::corner_angles_deg(&remesh), 0.0, 5.0, 36);
        let lengths = extract::edge_lengths(&remesh);
        let mean_edge = if lengths.is_empty() {
            0.0
        } else {
            lengths.iter().sum::<f64>() / lengths.len() as f64
        };
        let relative: Vec<f64> = lengths
            .iter()
            .map(|l| l / mean_edge.max(f64::MIN_POSITIVE))
            .collect();
        let lengths = Histogram::new(&relative, 0.0, 0.05, 50);
        let irregular = extract::irregular_vertices(&remesh);

        // Each edge once: lines, and the valence of every vertex.
        let p = |v: u32| remesh.positions[v as usize].as_vec3().to_array();
        let mut seen = HashSet::new();
        let mut valence = vec![0usize; remesh.positions.len()];
        let mut overlay = Overlay {
            revision: next_overlay_revision(),
            ..Overlay::default()
        };
        let edges = remesh
            .faces
            .iter()
            .flat_map(|f| (0..f.len()).map(|k| (f[k], f[(k + 1) % f.len()])))
            .chain(
                remesh
                    .polylines
                    .iter()
                    .flat_map(|l| l.windows(2).map(|w| (w[0], w[1]))),
            );
        for (a, b) in edges {
            if a == b || !seen.insert((a.min(b), a.max(b))) {
                continue;
            }
            valence[a as usize] += 1;
            valence[b as usize] += 1;
            overlay.fine_lines.push(LineSegment {
                a: p(a),
                b: p(b),
                color: EDGE_COLOR,
            });
        }
        let regular = quality.regular_valence;
        let mut fewer = 0;
        for &v in &irregular {
            let few = valence[v as usize] < regular;
            fewer += few as usize;
            overlay.dots.push(Glyph {
                position: p(v),
                color: if few { FEWER_COLOR } else { MORE_COLOR },
            });
        }
        let surface = (!remesh.faces.is_empty()).then(|| {
            let triangles: Vec<[u32; 3]> = remesh
                .faces
                .iter()
                .flat_map(|f| (1..f.len().saturating_sub(1)).map(|k| [f[0], f[k], f[k + 1]]))
                .collect();
            Arc::new(SceneData::from_triangles(&remesh.positions, &triangles))
        });
        RemeshView {
            id: next_overlay_revision(),
            remesh,
            quality,
            ideal_angle,
            angles,
            lengths,
            mean_edge,
            irregular,
            fewer,
            overlay: Arc::new(overlay),
            surface,
            seconds,
        }
    }

    /// The side panel's line: "6512 faces (6480 quads), 24 irregular vertices".
    pub fn summary(&self) -> String {
        let q = &self.quality;
        if q.faces == 0 {
            return format!("{} stripes, {} vertices", q.polylines, q.vertices);
        }
        let dominant = q
            .faces_by_sides
            .iter()
            .max_by_key(|x| *x.1)
            .map(|(&s, &c)| sides_name(s, c))
            .unwrap_or_default();
        format!(
            "{} faces ({dominant}), {} irregular vertices",
            q.faces, q.irregular_vertices
        )
    }
}

/// The work of one extraction, tagged with what it extracts.
pub struct RemeshRequest {
    pub mesh: Arc<TriMesh>,
    /// Per-corner UVs, `uv[3 * f + k]`.
    pub uv: Vec<[f64; 2]>,
    /// The map's treated poles (their star faces are bilinear quads).
    pub poles: Vec<crate::param::Pole>,
    pub symmetry: u8,
    /// The constraint curves' edges (empty without curves): relaxation keeps vertices on them.
    pub curve_edges: Vec<bool>,
    pub generation: u64,
    pub param_revision: u64,
}

/// What an extraction job sends back.
pub struct RemeshResult {
    pub generation: u64,
    pub param_revision: u64,
    pub outcome: Result<RemeshView, String>,
}

impl RemeshRequest {
    /// The extraction of the document's parameterization (`None` without one).
    pub fn for_document(doc: &Document) -> Option<RemeshRequest> {
        let (mesh, p) = (doc.mesh.clone()?, doc.parameterization.as_ref()?);
        let curve_edges = doc
            .curves()
            .map(|c| crate::constraint::curve_edges(&mesh, c.values()))
            .unwrap_or_default();
        Some(RemeshRequest {
            mesh,
            uv: p.uv.clone(),
            poles: p.poles.clone(),
            symmetry: p.symmetry as u8,
            curve_edges,
            generation: doc.generation(),
            param_revision: doc.param_revision(),
        })
    }

    /// Extracts, measures and prepares the remesh (in a background job); gives up when
    /// `cancel` turns true (a newer map made this one stale).
    pub fn run(self, cancel: &(dyn Fn() -> bool + Sync)) -> RemeshResult {
        let start = Instant::now();
        let outcome = extract::remesh_report_until(
            &self.mesh,
            &self.uv,
            self.symmetry,
            &ExtractOptions {
                constrained_edges: self.curve_edges,
                poles: self.poles,
                ..Default::default()
            },
            cancel,
        )
        .map(|(remesh, quality)| RemeshView::new(remesh, quality, start.elapsed().as_secs_f64()))
        .map_err(|e| e.to_string());
        RemeshResult {
            generation: self.generation,
            param_revision: self.param_revision,
            outcome,
        }
    }
}

/// The editor's remesh state besides the document's: what was last asked for, and whether
/// the quality window is open.
#[derive(Debug, Default)]
pub struct RemeshUi {
    /// The parameterization revision the last extraction was started for.
    requested: Option<u64>,
    /// The *Remesh quality* window ([`super::quality_panel`]).
    pub show_quality: bool,
}

impl EditorApp {
    /// Starts the extraction of the parameterization shown when it has none yet; flags a
    /// running one for another map cancelled (it is replaced once it ends). Called every frame
    /// after the jobs are polled.
    pub(super) fn sync_remesh(&mut self) {
        let doc = &self.document;
        let want = (!doc.remesh_current()).then(|| doc.param_revision());
        let mut running = false;
        for job in &self.jobs {
            if let Some(r) = job.param_revision {
                if r != doc.param_revision() {
                    job.cancel();
                }
                running = true;
            }
        }
        let Some(want) = want else {
            self.remesh.requested = None;
            return;
        };
        if running || self.remesh.requested == Some(want) {
            return;
        }
        let Some(request) = RemeshRequest::for_document(doc) else {
            return;
        };
        self.remesh.requested = Some(want);
        let generation = request.generation;
        self.jobs.push(
            Job::spawn("Extracting the remesh", self.ctx.clone(), move |progress| {
                progress.set_stage("remesh and quality");
                Ok(JobOutput::Remeshed(Box::new(
                    request.run(&|| progress.cancelled()),
                )))
            })
            .for_generation(generation)
            .for_param(want),
        );
    }

    /// Whether the parameterization shown waits for its remesh (an extraction runs or is about
    /// to start).
    pub fn remesh_pending(&self) -> bool {
        !self.document.remesh_current()
    }

    /// Takes an extraction's result: stale ones are dropped; a failure keeps the last good
    /// remesh and says why in the status line.
    pub(super) fn take_remesh(&mut self, result: RemeshResult) {
        let failed = result.outcome.as_ref().err().cloned();
        if !self.document.take_remesh(result) {
            return;
        }
        if let Some(e) = failed {
            let kept = if self.document.remesh.is_some() {
                " (the last good remesh is shown)"
            } else {
                ""
            };
            self.status = format!("Remesh extraction failed{kept}: {e}");
        }
    }

    /// The remesh overlay (edges, stripes, irregular vertices) while the display shows it.
    pub fn remesh_overlay(&self) -> Option<Arc<Overlay>> {
        if self.document.display.remesh == RemeshDisplay::Off {
            return None;
        }
        self.document.remesh.as_ref().map(|r| r.overlay.clone())
    }

    /// The remesh's polygons and their key while the display shows them instead of the surface.
    pub fn remesh_surface(&self) -> Option<(u64, Arc<SceneData>)> {
        if self.document.display.remesh != RemeshDisplay::Only {
            return None;
        }
        let r = self.document.remesh.as_ref()?;
        Some((r.id, r.surface.clone()?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn histograms_clamp_into_their_end_bins() {
        let h = Histogram::new(&[-1.0, 0.0, 4.9, 5.0, 179.0, 500.0, f64::NAN], 0.0, 5.0, 36);
        assert_eq!(h.counts.len(), 36);
        assert_eq!(h.counts[0], 3);
        assert_eq!(h.counts[1], 1);
        assert_eq!(h.counts[35], 2);
        assert_eq!(h.total(), 6);
        assert_eq!(h.center(0), 2.5);
    }

    /// A 3 × 3 grid of quads: 24 edges once each, the centre quad's corners regular, the
    /// fan triangulation two triangles a quad, the angles all 90°, the lengths all the mean.
    #[test]
    fn a_quad_grid_view_has_each_edge_once_and_fans() {
        let positions: Vec<DVec3> = (0..16)
            .map(|i| DVec3::new((i % 4) as f64, (i / 4) as f64, 0.0))
            .collect();
        let faces: Vec<Vec<u32>> = (0..9u32)
            .map(|q| {
                let (x, y) = (q % 3, q / 3);
                let v = y * 4 + x;
                vec![v, v + 1, v + 5, v + 4]
            })
            .collect();
        let remesh = Remesh {
            origins: vec![extract::Origin::Unknown; positions.len()],
            positions,
            faces,
            ..Remesh::default()
        };
        let mesh = TriMesh::from_triangles(
            vec![
                DVec3::ZERO,
                DVec3::new(3.0, 0.0, 0.0),
                DVec3::new(0.0, 3.0, 0.0),
                DVec3::new(3.0, 3.0, 0.0),
            ],
            vec![[0, 1, 2], [1, 3, 2]],
        )
        .unwrap();
        let quality = extract::quality(&remesh, &mesh);
        let view = RemeshView::new(remesh, quality, 0.0);
        assert_eq!(view.overlay.fine_lines.len(), 24);
        assert!(view.overlay.lines.is_empty());
        assert!(view.overlay.dots.is_empty(), "no interior irregular vertex");
        assert!(
            view.overlay
                .fine_lines
                .iter()
                .all(|l| l.color == EDGE_COLOR)
        );
        assert_eq!(view.surface.as_ref().unwrap().n_faces(), 18);
        assert_eq!(view.ideal_angle, 90.0);
        assert_eq!(view.angles.total(), 36);
        let at_90 = view.angles.counts[17] + view.angles.counts[18];
        assert_eq!(at_90, 36, "every corner at 90°");
        assert_eq!(view.lengths.counts[20], 24, "every edge at the mean");
        assert_eq!(view.summary(), "9 faces (9 quads), 0 irregular vertices");
        assert_eq!(sides_name(7, 1), "1 7-gon");
    }
}

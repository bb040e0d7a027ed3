//! [`Base`]: what depends on the mesh and the settings only, and the pure functions from edit
//! lists to states and from states to fields and parameterizations.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::time::Instant;

use super::moves::{MergeRules, PlannedMove, plan_move, released_faces, turn_index};
use super::{Cancel, Curve, Edit, EditError, Settings};
use crate::field::cancel::{PathSearch, apply};
use crate::field::index::indices_from_angles;
use crate::field::smoothing::energies;
use crate::field::transport::{EdgeTransport, FaceBases};
use crate::field::{
    FieldResult, FrameField, IndexReport, Singularity, compute_field, frames_from_angles,
    reduce_matchings,
};
use crate::mesh::TriMesh;
use crate::param::{
    Collapse, ConstraintCurve, ParamAnalysis, ParamError, Parameterization, QuadCover,
};

/// Around the apex of an acute corner between two curves, the radius (in cancellation radii)
/// within which opposite singularities on curves cancel. The design makes the apex a
/// singularity (the corner's faces are turned by the corner's frame, so its cone angle is the
/// wedge's 2π/N plus the rest's 2π) and puts the compensating one of the other sign on a curve
/// a cell or two away, beside the branch points already there: rounded onto the lattice, that
/// cluster folds. Fandisk at 30°, 35°, 40°, 50°, 60° with 1: 9, 20, 10, 8, 6 folds; with 1.5 or
/// 2: 0, 0, 0, 7, 1; with 3: 0, 0, 0, 2, 0 (the corner's frame off: 2, 2, 2, 9, 4).
const APEX_CLUSTER: f64 = 3.0;

/// How far from the apex of an acute corner the field is held to the corner's turning frame,
/// in grid cells (`constraint::acute_corners`).
const CORNER_REACH: f64 = 1.0;

/// How far from the curves, in grid cells, [`Base::off_curves_in_wedges`] moves a singularity
/// when its region has room for it. Prisms over triangles with an acute corner of 18°, 22° and
/// 26° (N = 4, features at 40°, the default density), moved to the nearest vertex off the
/// curves: 4 folded faces each after the repair (the 18° one as triangulated by trimesh; the
/// one of `tests/constraints.rs` none) and 81, 89 and 71 patched places in the remesh; with a
/// cell of room no fold and no patched place (the 18° one's smallest remesh corner 6° → 18°);
/// 1.5 cells gave the same.
const WEDGE_ROOM: f64 = 1.0;

/// How much farther (in units of 2π/N) from a junction's cone a singularity of the other sign
/// may take the junction's index and still move onto it ([`Base::onto_junctions`]): ties
/// only. A concave prism corner (defect −90°, N = 6: −1.5) with −1/3 on it and a +1/6 beside
/// it is a tie (0.5 either way); moved, the L-shaped prism with features at 40° has 29
/// singularities instead of 30, the plate with a square hole 30 instead of 34, a thick L 0
/// mis-wound vertices instead of 2 (none folds either way).
const JUNCTION_TIE: f64 = 0.1;

/// The smallest angle defect (in units of 2π/N) of a junction that singularities beside it
/// move onto ([`Base::onto_junctions`]): a corner holding at least half a singularity's
/// curvature. Where curves cross on a smooth surface (drawn curves, creases on a scan) the
/// singularity has no reason to sit on the crossing: 36 random curve projects on the shared
/// meshes (N = 2, 4, 6) had 4 solves change with every junction, 2 better and 2 worse (kitten,
/// N = 4: 39 → 48 folded faces); kitten with features at 40°, N = 4, 8 → 5 folded faces but
/// a conformal p99 of 3.08 → 5.35. With ½ these are as before, and every prism's corner
/// (±1.5 for N = 6, ±1 for N = 4) and fandisk's (1.3–1.5) is above it.
const JUNCTION_CONE: f64 = 0.5;

/// The combinatorial state after some edits: integer turns and released faces. The
/// singularities follow from the turns alone ([`turn_index`]).
#[derive(Clone, Debug, PartialEq)]
pub struct EditState {
    /// Unreduced turns per edge (first face to second; 0 on boundary edges).
    pub turns: Vec<i64>,
    /// Faces whose alignment weight edits released, sorted, without repeats.
    pub released: Vec<usize>,
    /// Interior vertices (mesh indices) with non-zero index k/N, by vertex.
    pub singularities: BTreeMap<usize, i32>,
    /// Constraint curves (mesh vertex indices), by id.
    pub curves: BTreeMap<u32, Curve>,
    /// The field designed with the geometric curves' alignment (`None`: the base field, as
    /// without geometric curves).
    pub design: Option<Design>,
    /// The singularity edits applied since the field was last designed, in order: a curve edit
    /// that changes the geometric curves designs the field again and re-applies them where they
    /// still apply.
    pub history: Vec<Edit>,
}

/// A field designed for a set of geometric curves (the faces along them aligned to them).
#[derive(Clone, Debug)]
pub struct Design {
    pub field: Arc<FieldResult>,
    /// The alignment it was designed with (face, angle).
    pub aligned: Arc<Vec<(u32, f64)>>,
    /// The faces along round rims it was designed with (N = 6, `FieldParams::rim_aligned`).
    pub rims: Arc<Vec<u32>>,
}

impl PartialEq for Design {
    fn eq(&self, other: &Design) -> bool {
        Arc::ptr_eq(&self.field, &other.field)
            || (self.aligned == other.aligned
                && self.rims == other.rims
                && self.field.turns == other.field.turns
                && self.field.theta == other.field.theta)
    }
}

impl EditState {
    /// Singularities as (mesh vertex, k), by vertex.
    pub fn singularity_list(&self) -> Vec<Singularity> {
        self.singularities
            .iter()
            .map(|(&vertex, &k)| Singularity { vertex, k })
            .collect()
    }
}

/// An edit that replay skipped, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Skipped {
    /// 1-based position in the edit list.
    pub position: usize,
    pub edit: Edit,
    pub reason: String,
}

/// The states after each edit of a list (`states[0]` before any; a skipped edit repeats the
/// state before it) and the edits skipped.
#[derive(Clone, Debug)]
pub struct Replay {
    pub states: Vec<EditState>,
    pub skipped: Vec<Skipped>,
}

impl Replay {
    pub fn last(&self) -> &EditState {
        self.states.last().expect("a replay has its initial state")
    }
}

/// The field and parameterization of a state.
#[derive(Clone, Debug)]
pub struct Solved {
    pub field: FrameField,
    /// Angle of U per face in the face basis.
    pub theta: Vec<f64>,
    /// Indices from the solved angles (equal to the state's when the field is smooth).
    pub indices: IndexReport,
    pub param: Parameterization,
    pub e_smooth: f64,
    pub e_align: f64,
    /// (stage, seconds).
    pub timings: Vec<(String, f64)>,
    /// How QuadCover's systems were had.
    pub reuse: Reuse,
}

/// How a solve had QuadCover's two systems (local step, global step).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reuse {
    /// The base's own (the initial state's matchings).
    Base,
    /// Updated from the base's factors: per system the rows that changed (`None`: too many,
    /// factored afresh; `Some(0)`: the matrix was the base's).
    Updated {
        local: Option<usize>,
        global: Option<usize>,
    },
}

/// What a move from `from` to `to` would do (for the editor's live preview).
#[derive(Clone, Debug, PartialEq)]
pub struct MovePreview {
    /// Mesh vertices of the edge path (empty when there is none).
    pub path: Vec<usize>,
    /// The index numerator k at `to` afterwards (`None`: the singularity leaves through the
    /// boundary), or why the move is refused.
    pub result: Result<Option<i32>, String>,
}

/// A state's QuadCover solver: the base's, or an update of it.
enum Solver {
    Base(Arc<QuadCover>),
    Updated(Box<QuadCover>),
}

impl std::ops::Deref for Solver {
    type Target = QuadCover;
    fn deref(&self) -> &QuadCover {
        match self {
            Solver::Base(q) => q,
            Solver::Updated(q) => q,
        }
    }
}

/// Everything that depends on (mesh, settings) only.
pub struct Base {
    mesh: Arc<TriMesh>,
    settings: Settings,
    to_file: Vec<u32>,
    from_file: Vec<u32>,
    field: Arc<FieldResult>,
    bases: Arc<FaceBases>,
    tr: Arc<EdgeTransport>,
    defects: Arc<Vec<f64>>,
    analysis: Arc<ParamAnalysis>,
    initial: EditState,
    /// QuadCover for the initial state's matchings, kept for updates: every state's solver is
    /// this one updated (`QuadCover::updated`), so it is the same whether a state was reached
    /// by editing or by replaying a project. Made by the first solve.
    quadcover: std::sync::OnceLock<Result<Arc<QuadCover>, String>>,
    /// Whether the last solve took the crowded tries (0: no solve yet, 1: no, 2: yes): the
    /// next one starts them beside its first map only if so (`QuadCover::solve_speculating`).
    /// A hint only: the map is the same either way.
    last_took_tries: std::sync::atomic::AtomicU8,
}

impl std::fmt::Debug for Base {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Base")
            .field("faces", &self.mesh.n_faces())
            .field("settings", &self.settings)
            .finish()
    }
}

const UNMAPPED: u32 = u32::MAX;

/// Interior vertices of non-zero index k/N for the turns, by vertex.
fn singularities_of(
    mesh: &TriMesh,
    tr: &EdgeTransport,
    defects: &[f64],
    n: u32,
    turns: &[i64],
) -> BTreeMap<usize, i32> {
    (0..mesh.n_vertices())
        .filter_map(|v| {
            turn_index(mesh, tr, defects[v], v, n, turns)
                .filter(|&k| k != 0)
                .map(|k| (v, k))
        })
        .collect()
}

impl Base {
    /// Computes the field (keeping its fixed-matching system) and QuadCover's analyses, side by
    /// side. `to_file[v]` is mesh vertex v's index in the file (`RepairReport::original_vertex`;
    /// the identity for generated meshes), `file_vertices` the file's vertex count.
    pub fn new(
        mesh: Arc<TriMesh>,
        to_file: Vec<u32>,
        file_vertices: usize,
        settings: Settings,
        cancel: Cancel,
    ) -> Result<Base, EditError> {
        settings.validate().map_err(EditError::Invalid)?;
        if to_file.len() != mesh.n_vertices()
            || to_file.iter().any(|&v| v as usize >= file_vertices)
        {
            return Err(EditError::Invalid(
                "the vertex map does not fit the mesh".into(),
            ));
        }
        let mut from_file = vec![UNMAPPED; file_vertices];
        for (v, &f) in to_file.iter().enumerate() {
            from_file[f as usize] = v as u32;
        }
        let params = crate::field::FieldParams {
            keep_system: true,
            ..settings.field_params()
        };
        let (field, analysis) = std::thread::scope(|scope| {
            let analysis = scope.spawn(|| ParamAnalysis::new(&mesh));
            let field = compute_field(&mesh, &params);
            let analysis = analysis
                .join()
                .map_err(|_| EditError::Param("the analysis thread panicked".into()))?;
            Ok::<_, EditError>((
                field.map_err(|e| EditError::Field(e.to_string()))?,
                analysis.map_err(|e| EditError::Param(e.to_string()))?,
            ))
        })?;
        if cancel() {
            return Err(EditError::Cancelled);
        }
        let bases = FaceBases::new(&mesh);
        let tr = EdgeTransport::new(&mesh, &bases);
        let defects = mesh.angle_defects();
        let singularities = singularities_of(&mesh, &tr, &defects, settings.symmetry, &field.turns);
        let initial = EditState {
            turns: field.turns.clone(),
            released: Vec::new(),
            singularities,
            curves: BTreeMap::new(),
            design: None,
            history: Vec::new(),
        };
        Ok(Base {
            mesh,
            settings,
            to_file,
            from_file,
            field: Arc::new(field),
            bases: Arc::new(bases),
            tr: Arc::new(tr),
            defects: Arc::new(defects),
            analysis: Arc::new(analysis),
            initial,
            quadcover: Default::default(),
            last_took_tries: Default::default(),
        })
    }

    /// A base for other settings sharing this one's field and analyses, when the field does not
    /// depend on what changed (merge rules, relax radius, pure quad, rounding); `None` when it
    /// does (then [`Base::new`] computes it again).
    pub fn with_settings(&self, settings: Settings) -> Result<Option<Base>, EditError> {
        settings.validate().map_err(EditError::Invalid)?;
        if settings.field_params() != self.settings.field_params() {
            return Ok(None);
        }
        Ok(Some(Base {
            mesh: self.mesh.clone(),
            settings,
            to_file: self.to_file.clone(),
            from_file: self.from_file.clone(),
            field: self.field.clone(),
            bases: self.bases.clone(),
            tr: self.tr.clone(),
            defects: self.defects.clone(),
            analysis: self.analysis.clone(),
            initial: self.initial.clone(),
            quadcover: Default::default(),
            last_took_tries: Default::default(),
        }))
    }

    /// [`Base::new`] for a mesh whose vertices are the file's (generated meshes, tests).
    pub fn for_mesh(mesh: Arc<TriMesh>, settings: Settings) -> Result<Base, EditError> {
        let nv = mesh.n_vertices();
        Base::new(mesh, (0..nv as u32).collect(), nv, settings, &super::never)
    }

    pub fn mesh(&self) -> &Arc<TriMesh> {
        &self.mesh
    }
    pub fn settings(&self) -> &Settings {
        &self.settings
    }
    /// The computed field before any edit.
    pub fn field(&self) -> &FieldResult {
        &self.field
    }
    pub fn grid_size(&self) -> f64 {
        self.field.grid_size
    }
    pub(crate) fn transport(&self) -> &EdgeTransport {
        &self.tr
    }
    pub fn analysis(&self) -> &Arc<ParamAnalysis> {
        &self.analysis
    }
    /// The state before any edit.
    pub fn initial(&self) -> &EditState {
        &self.initial
    }
    /// The file's index of mesh vertex v.
    pub fn file_vertex(&self, v: usize) -> usize {
        self.to_file[v] as usize
    }
    /// The mesh vertex of file vertex i (`None` for vertices the mesh dropped or out of range).
    pub fn mesh_vertex(&self, i: usize) -> Option<usize> {
        self.from_file
            .get(i)
            .filter(|&&v| v != UNMAPPED)
            .map(|&v| v as usize)
    }
    pub(crate) fn rules(&self) -> MergeRules {
        MergeRules {
            n: self.settings.symmetry,
            no_half_merges: self.settings.no_half_merges,
            no_pole_merges: self.settings.no_pole_merges,
        }
    }

    fn file_to_mesh(&self, i: usize, name: &str) -> Result<usize, String> {
        if i >= self.from_file.len() {
            return Err(format!(
                "{name} = {i} is out of range (the mesh file has {} vertices)",
                self.from_file.len()
            ));
        }
        self.mesh_vertex(i)
            .ok_or_else(|| format!("{name} = {i} is not on the mesh (no face uses it)"))
    }

    /// Plans a move between mesh vertices on a state.
    pub(crate) fn plan(
        &self,
        state: &EditState,
        search: &mut PathSearch,
        p: usize,
        q: usize,
    ) -> Result<PlannedMove, String> {
        let fp = self.file_vertex(p);
        if self.mesh.is_boundary_vertex(p) {
            return Err(format!(
                "vertex {fp} is on the boundary, where vertices carry no index"
            ));
        }
        let Some(&k_p) = state.singularities.get(&p) else {
            return Err(format!("vertex {fp} is not a singularity"));
        };
        let k_q = state.singularities.get(&q).copied().unwrap_or(0);
        plan_move(
            &self.mesh,
            &self.tr,
            &self.defects,
            &state.turns,
            search,
            p,
            q,
            k_p,
            k_q,
            self.rules(),
        )
        .map_err(|why| {
            format!(
                "moving the singularity at {fp} to {} is refused: {why}",
                self.file_vertex(q)
            )
        })
    }

    /// The state after a planned move: turns changed along the path, its faces released, the
    /// indices of p and q updated (and checked against the turns).
    pub(crate) fn commit(&self, state: &EditState, mv: &PlannedMove) -> EditState {
        let mut next = state.clone();
        let p = self.mesh.from(mv.path[0]);
        let q = self.mesh.to(*mv.path.last().expect("a path has an edge"));
        let k_p = next.singularities.remove(&p).unwrap_or(0);
        apply(&self.mesh, &mut next.turns, &mv.path, k_p, mv.sign);
        match mv.at_q {
            Some(0) => {
                next.singularities.remove(&q);
            }
            Some(k) => {
                next.singularities.insert(q, k);
            }
            None => {}
        }
        next.released.extend(released_faces(&self.mesh, &mv.path));
        next.released.sort_unstable();
        next.released.dedup();
        debug_assert_eq!(
            turn_index(
                &self.mesh,
                &self.tr,
                self.defects[q],
                q,
                self.settings.symmetry,
                &next.turns
            ),
            mv.at_q
        );
        next
    }

    /// What moving the singularity at mesh vertex `p` to mesh vertex `q` would do.
    pub fn preview_move(&self, state: &EditState, p: usize, q: usize) -> MovePreview {
        let mut search = PathSearch::new(self.mesh.n_vertices());
        match self.plan(state, &mut search, p, q) {
            Ok(mv) => {
                let mut path: Vec<usize> = mv.path.iter().map(|&h| self.mesh.from(h)).collect();
                path.push(q);
                MovePreview {
                    path,
                    result: Ok(mv.at_q),
                }
            }
            Err(why) => MovePreview {
                path: search
                    .shortest_interior_path(&self.mesh, p, q, f64::INFINITY)
                    .map(|hs| {
                        let mut v: Vec<usize> = hs.iter().map(|&h| self.mesh.from(h)).collect();
                        v.push(q);
                        v
                    })
                    .unwrap_or_default(),
                result: Err(why),
            },
        }
    }

    /// The state after one edit, or why the edit does not apply (a refusal is
    /// [`EditError::Invalid`]).
    pub fn apply(
        &self,
        state: &EditState,
        edit: &Edit,
        cancel: Cancel,
    ) -> Result<EditState, EditError> {
        if let Some(next) = self.apply_curve_edit(state, edit) {
            return self.redesign(next?, cancel);
        }
        let mut next = self.apply_singularity_edit(state, edit, cancel)?;
        next.history.push(edit.clone());
        Ok(next)
    }

    /// The field of a state: its design's, or the base field.
    pub fn field_of<'a>(&'a self, state: &'a EditState) -> &'a FieldResult {
        state.design.as_ref().map_or(&self.field, |d| &d.field)
    }

    /// After a curve edit: when the geometric curves ask for another alignment, the field is
    /// designed again with it (matchings and singularities anew, as for a fresh solve) and the
    /// singularity edits since the last design are re-applied where they still apply.
    fn redesign(&self, state: EditState, cancel: Cancel) -> Result<EditState, EditError> {
        let stripes = self.stripes(&state);
        let acute = match &stripes {
            Some((across, _)) => crate::constraint::stripe_corners(
                &self.mesh,
                state.curves.values(),
                across,
                self.grid_size() * CORNER_REACH,
            ),
            None => crate::constraint::acute_corners(
                &self.mesh,
                state.curves.values(),
                self.settings.symmetry,
                self.grid_size() * CORNER_REACH,
            ),
        };
        let aligned = self.design_alignment(&state, &acute.alignments, stripes.map(|s| s.1));
        // (Only a hexagonal field is designed differently beside round rims.)
        let rims = if self.settings.symmetry == 6 {
            crate::constraint::rim_faces(&self.mesh, state.curves.values())
        } else {
            Vec::new()
        };
        let current = state
            .design
            .as_ref()
            .map_or((&[][..], &[][..]), |d| (&d.aligned[..], &d.rims[..]));
        if (aligned.as_slice(), rims.as_slice()) == current {
            return Ok(state);
        }
        if cancel() {
            return Err(EditError::Cancelled);
        }
        let mut state = if aligned.is_empty() {
            self.with_design(state, None, &acute)
        } else {
            let aligned = Arc::new(aligned);
            let rims = Arc::new(rims);
            // The faces along boundary edges of geometric curves (`field::boundary_yield`).
            let on_curve = self.geometric_curve_edges(&state);
            let along_boundary: Vec<u32> = on_curve
                .iter()
                .enumerate()
                .filter(|&(e, &on)| on && self.tr.faces[e][1] == crate::field::transport::NO_FACE)
                .map(|(e, _)| self.tr.faces[e][0])
                .collect();
            let params = crate::field::FieldParams {
                keep_system: true,
                aligned: Some(aligned.clone()),
                boundary_aligned: Some(Arc::new(along_boundary)),
                rim_aligned: Some(rims.clone()),
                kept_singular: Some(Arc::new(acute.apexes.clone())),
                fixed_rotations: Some(Arc::new(acute.rotations.clone())),
                ..self.settings.field_params()
            };
            let designed = |params: &crate::field::FieldParams, state: EditState| {
                let field = compute_field(&self.mesh, params)
                    .map_err(|e| EditError::Field(e.to_string()))?;
                let design = Design {
                    field: Arc::new(field),
                    aligned: aligned.clone(),
                    rims: rims.clone(),
                };
                Ok::<_, EditError>(self.with_design(state, Some(design), &acute))
            };
            let first = designed(&params, state.clone())?;
            // N = 6: a design that changes line family along sharp creases is made again from
            // the unsmoothed shape operators, and that one kept if it changes family at no more
            // than half as many places, or has no more than a third of the curl (sec. 3.3: how
            // far the frames are from a map's gradient), or both fewer places and no more than
            // half the curl. Measured (docs/untangling.md): by the places alone two boxes kept
            // 16 folded faces (4 → 3 places, curl 436 → 113) and a T prism 35 (2 → 5, curl
            // 1064 → 238); by half the curl alone a thin plate kept 13 (8 → 0 places, curl
            // 163 → 178) and an L plate got 6 (3 → 4 places, curl 379 → 176); taking any
            // fewer places, a U plate got 2 (11 → 6 places, curl 366 → 257).
            let changes = |state: &EditState| {
                self.angles(state).ok().map(|theta| {
                    super::families::crease_family_changes(
                        &self.mesh,
                        &self.bases,
                        &self.tr,
                        &theta,
                        &state.turns,
                        6,
                        state.curves.values(),
                    )
                })
            };
            let hexagonal = self.settings.symmetry == 6 && params.curvature_smoothing > 0;
            let before = if hexagonal {
                changes(&first).unwrap_or(0)
            } else {
                0
            };
            if before == 0 {
                first
            } else {
                if cancel() {
                    return Err(EditError::Cancelled);
                }
                let raw = crate::field::FieldParams {
                    raw_guidance: true,
                    ..params
                };
                // (A count, a curl or a second design that cannot be had decides for the
                // first design.)
                match designed(&raw, state) {
                    Ok(second) => {
                        let after = changes(&second).unwrap_or(before);
                        // The second design's curl as a share of the first's.
                        let curl_share = || {
                            let curl = |state: &EditState| self.curl(state).ok();
                            curl(&second)
                                .zip(curl(&first))
                                .map_or(f64::INFINITY, |(second, first)| second / first)
                        };
                        let halved = 2 * after <= before || {
                            let share = curl_share();
                            share <= 1.0 / 3.0 || (after < before && share <= 0.5)
                        };
                        if halved { second } else { first }
                    }
                    Err(_) => first,
                }
            }
        };
        for edit in std::mem::take(&mut state.history) {
            match self.apply(&state, &edit, cancel) {
                Ok(next) => state = next,
                Err(EditError::Invalid(_)) => {}
                Err(e) => return Err(e),
            }
        }
        Ok(state)
    }

    /// `state` with `design` (none: the base field): its field's turns and singularities, and
    /// those the design leaves beside the curves moved onto them ([`Self::snap_to_curves`]).
    fn with_design(
        &self,
        mut state: EditState,
        design: Option<Design>,
        acute: &crate::constraint::AcuteCorners,
    ) -> EditState {
        state.design = design;
        let field = self.field_of(&state);
        let turns = field.turns.clone();
        state.singularities = singularities_of(
            &self.mesh,
            &self.tr,
            &self.defects,
            self.settings.symmetry,
            &turns,
        );
        state.turns = turns;
        state.released.clear();
        self.snap_to_curves(state, acute)
    }

    /// Singularities the design leaves one edge off a geometric curve move onto it (to the
    /// nearest curve vertex beside them that is neither singular nor on the boundary). One
    /// edge is a fraction of a grid cell: rounded, such a branch point lands either on the
    /// curve's line, which collapses the faces between them, or a whole lattice step away from
    /// it, which stretches them by the cell's size; on the curve it is a corner of the line
    /// (eq. 4.9) and neither happens. Then opposite singularities on curves closer than the
    /// cancellation radius cancel; near the apex of an acute corner between two curves
    /// (`constraint::acute_corners`) within [`APEX_CLUSTER`] radii, the apex itself kept.
    /// Not with N = 2: a ±1/2 on a curve turns its line by 90°, a corner the curve does not
    /// have (features at 40°: the box 65 → 74 folds with it, a cube 4 → 100).
    /// Vertices in order, so replay stays bit-identical.
    fn snap_to_curves(
        &self,
        mut state: EditState,
        acute: &crate::constraint::AcuteCorners,
    ) -> EditState {
        let nv = self.mesh.n_vertices();
        let mut on_curve = vec![false; nv];
        for c in state.curves.values() {
            if c.kind == crate::constraint::CurveKind::Geometric {
                for &v in &c.vertices {
                    on_curve[v] = true;
                }
            }
        }
        let mut search = PathSearch::new(nv);
        let singular: Vec<usize> = if self.settings.symmetry == 2 {
            Vec::new()
        } else {
            state.singularities.keys().copied().collect()
        };
        for p in singular {
            if on_curve[p] || !state.singularities.contains_key(&p) {
                continue;
            }
            let dist = |q: usize| (self.mesh.position(q) - self.mesh.position(p)).length();
            let target = self
                .mesh
                .outgoing(p)
                .map(|h| self.mesh.to(h))
                .filter(|&q| {
                    on_curve[q]
                        && !self.mesh.is_boundary_vertex(q)
                        && !state.singularities.contains_key(&q)
                })
                .min_by(|&a, &b| dist(a).total_cmp(&dist(b)).then(a.cmp(&b)));
            let Some(q) = target else { continue };
            if let Ok(mv) = self.plan(&state, &mut search, p, q) {
                state = self.commit(&state, &mv);
            }
        }
        // Opposite ones on curves closer than the cancellation radius cancel, as the field's
        // pairs do (sec. 3.3): on one line a fraction of a cell apart they fold the faces
        // between them.
        let radius = self.settings.cancel_pairs_within * self.grid_size();
        let apexes = &acute.apexes;
        let near_apex = |q: usize| {
            apexes.iter().any(|&a| {
                (self.mesh.position(q) - self.mesh.position(a)).length() < APEX_CLUSTER * radius
            })
        };
        let singular: Vec<usize> = state.singularities.keys().copied().collect();
        for p in singular {
            let Some(&k) = state.singularities.get(&p) else {
                continue;
            };
            if !on_curve[p] || apexes.contains(&p) {
                continue;
            }
            let dist = |q: usize| (self.mesh.position(q) - self.mesh.position(p)).length();
            let reach = if near_apex(p) {
                APEX_CLUSTER * radius
            } else {
                radius
            };
            let partner = state
                .singularities
                .iter()
                .filter(|&(&q, &kq)| {
                    q != p && kq == -k && on_curve[q] && dist(q) < reach && !apexes.contains(&q)
                })
                .map(|(&q, _)| q)
                .min_by(|&a, &b| dist(a).total_cmp(&dist(b)).then(a.cmp(&b)));
            let Some(q) = partner else { continue };
            if let Ok(mv) = self.plan(&state, &mut search, p, q) {
                state = self.commit(&state, &mv);
            }
        }
        let state = self.onto_junctions(state, &acute.apexes);
        self.off_curves_in_wedges(state, acute, radius)
    }

    /// Singularities the design leaves on a curve one edge from a junction (an interior
    /// vertex where three or more curve edges meet: a prism's corner, where two creases and
    /// the cap's edge meet) move onto the junction. The junction is a lattice point (lines of
    /// two families cross there), and on a part with flat faces it is where the surface's
    /// curvature is: a 90° corner's 270° cone is the +1/4 (N = 4) the apex carries. With
    /// N = 6 no lattice corner is 90°; the design put the +1/6 or −1/6 the corner asks for
    /// beside the apex instead, on one of its creases, whose line then turns where the part is
    /// flat (an L-shaped prism with features at 40°: each of its 12 corners with a singularity
    /// one edge off, 39 folded faces after the repair and 164 patched places in the remesh;
    /// moved onto the corners: none). A singularity moves unless it would carry the junction's
    /// index away from the corner's cone, its angle defect in units of 2π/N: one of the
    /// defect's sign always moves (a 90° corner with +1/3 and a +1/6 beside it becomes a +1/2,
    /// three lattice corners of 60°), one of the other sign only if the junction's index then
    /// lies no farther from the defect, ties within [`JUNCTION_TIE`] (on fandisk a +1/6 beside
    /// a corner with −1/6 whose defect is −1.33 stays: moved, the corner's index 0, 11 faces
    /// there folded). Never beyond N less the junction's number of sectors: each sector
    /// opens to a lattice corner of at least 2π/N, and a move past that collapses one (a
    /// tetrahedron's corner, N = 4, three sectors of 60°, has a defect of two quarter turns and
    /// would take a second +1/4; it can carry one). Only at corners with an angle defect of
    /// [`JUNCTION_CONE`] or more. Acute apexes are left to [`Self::off_curves_in_wedges`]:
    /// their wedge's singularity belongs inside it. Not with N = 2 (see
    /// [`Self::snap_to_curves`]).
    fn onto_junctions(&self, mut state: EditState, acute_apexes: &[usize]) -> EditState {
        if self.settings.symmetry == 2 {
            return state;
        }
        let curve_edge = self.geometric_curve_edges(&state);
        let curve_degree = self.curve_degrees(&curve_edge);
        let n = self.settings.symmetry as f64;
        let mut search = PathSearch::new(self.mesh.n_vertices());
        for j in 0..self.mesh.n_vertices() {
            if curve_degree[j] < 3
                || self.mesh.is_boundary_vertex(j)
                || acute_apexes.binary_search(&j).is_ok()
            {
                continue;
            }
            let cone = self.defects[j] / std::f64::consts::TAU * n;
            if cone.abs() < JUNCTION_CONE {
                continue;
            }
            let beside: Vec<usize> = self
                .mesh
                .outgoing(j)
                .filter(|&h| curve_edge[self.mesh.edge(h)])
                .map(|h| self.mesh.to(h))
                .filter(|&p| curve_degree[p] == 2 && !self.mesh.is_boundary_vertex(p))
                .collect();
            for p in beside {
                let Some(&k) = state.singularities.get(&p) else {
                    continue;
                };
                let at_j = state.singularities.get(&j).copied().unwrap_or(0);
                let same_sign = k as f64 * cone > 0.0;
                let no_farther = (f64::from(at_j + k) - cone).abs()
                    <= (f64::from(at_j) - cone).abs() + JUNCTION_TIE;
                // Each of the junction's sectors opens to a lattice corner of one step or
                // more, so its index is at most N less one per sector.
                let most = i64::from(self.settings.symmetry) - i64::from(curve_degree[j]);
                if (!same_sign && !no_farther) || i64::from(at_j + k) > most {
                    continue;
                }
                if let Ok(mv) = self.plan(&state, &mut search, p, j) {
                    state = self.commit(&state, &mv);
                }
            }
        }
        state
    }

    /// How many of the `curve_edge` edges meet at each vertex: 0 off the curves, 2 inside one.
    fn curve_degrees(&self, curve_edge: &[bool]) -> Vec<u32> {
        let mut degree = vec![0u32; self.mesh.n_vertices()];
        for (e, _) in curve_edge.iter().enumerate().filter(|(_, on)| **on) {
            for v in self.mesh.edge_vertices(e) {
                degree[v] += 1;
            }
        }
        degree
    }

    /// Singularities the design puts on a curve beside the apex of an acute corner move off the
    /// curves, into the region the corner's wedge opens into. Making the corner a lattice
    /// corner of 2π/N asks for a singularity inside that region (a flat triangle whose corners
    /// all become 90° needs a +1/4 inside); the design puts it near the apex, where a narrow
    /// wedge has no vertex off the curves, so it lands on one of them. On a curve it is a
    /// corner of that curve's line (eq. 4.9), the line turns there instead of at the corners
    /// the geometry has, and the region's other corners collapse (a prism on a 20°–70°–90°
    /// triangle with its features aligned: 160 folded faces, 61 after the repair). Each
    /// singularity on a curve (not at a curve's end or where curves meet, nor on the
    /// boundary) within [`APEX_CLUSTER`] radii of an apex, at a vertex of the region the
    /// wedge's faces reach without crossing a curve, moves to the nearest vertex of that region
    /// off the curves (the region widened up to eight reaches until it has one), if its index
    /// has the apex's sign (positive at an apex on the boundary, which carries none).
    fn off_curves_in_wedges(
        &self,
        mut state: EditState,
        acute: &crate::constraint::AcuteCorners,
        radius: f64,
    ) -> EditState {
        if acute.wedges.is_empty() {
            return state;
        }
        let curve_edge = self.geometric_curve_edges(&state);
        let curve_degree = self.curve_degrees(&curve_edge);
        let reach = APEX_CLUSTER * radius;
        let mut search = PathSearch::new(self.mesh.n_vertices());
        for (apex, wedge) in &acute.wedges {
            let apex_at = self.mesh.position(*apex);
            let near = |v: usize| (self.mesh.position(v) - apex_at).length() < reach;
            // The region: faces reached from the wedge without crossing a curve edge, within
            // `limit` of the apex.
            let region = |limit: f64| {
                let beyond = crate::constraint::faces_reached(
                    &self.mesh,
                    |e| curve_edge[e],
                    wedge,
                    |g| {
                        self.mesh
                            .face(g)
                            .iter()
                            .any(|&v| (self.mesh.position(v) - apex_at).length() < limit)
                            .then_some(())
                    },
                );
                let mut vertices: Vec<usize> = wedge
                    .iter()
                    .copied()
                    .chain(beyond.into_iter().map(|(f, _)| f))
                    .flat_map(|f| self.mesh.face(f))
                    .collect();
                vertices.sort_unstable();
                vertices.dedup();
                vertices
            };
            let vertices = region(2.0 * reach);
            // The apex's own index: a corner where three curves meet (a prism's) is a
            // singularity of the sign the region's one has; where a crease turns back on a
            // smooth surface (fandisk) the apex's is of the other sign, and the singularity
            // beside it cancels with the branch points on the curves instead (above).
            let apex_k = state.singularities.get(apex).copied();
            let boundary_apex = self.mesh.is_boundary_vertex(*apex);
            let movable: Vec<usize> = vertices
                .iter()
                .copied()
                .filter(|&p| {
                    let Some(&k) = state.singularities.get(&p) else {
                        return false;
                    };
                    let sign_ok = match apex_k {
                        Some(a) => a.signum() == k.signum(),
                        None => boundary_apex && k > 0,
                    };
                    sign_ok
                        && p != *apex
                        && curve_degree[p] == 2
                        && !self.mesh.is_boundary_vertex(p)
                        && near(p)
                })
                .collect();
            if movable.is_empty() {
                continue;
            }
            // Where they go: the region's vertices off the curves, within twice the reach or,
            // where a narrow wedge has none there, within up to eight times (a 20° corner of a
            // prism meshed at 3000 vertices: every vertex within twice the reach, 0.27 model
            // units or about five edges, lies on one of its curves).
            let free = |q: &usize| {
                curve_degree[*q] == 0
                    && !self.mesh.is_boundary_vertex(*q)
                    && !state.singularities.contains_key(q)
            };
            let mut targets: Vec<usize> = vertices.iter().copied().filter(free).collect();
            for f in [4.0, 8.0] {
                if targets.is_empty() {
                    targets = region(f * reach).into_iter().filter(free).collect();
                }
            }
            // Where the region has them, vertices [`WEDGE_ROOM`] from its curves: one beside a
            // curve in the narrow part of the wedge is rounded onto a lattice point a cell or two
            // from the curve's line and folds the faces between.
            let wide = region(8.0 * reach);
            let on_curves: Vec<glam::DVec3> = (wide.iter())
                .filter(|&&q| curve_degree[q] > 0)
                .map(|&q| self.mesh.position(q))
                .collect();
            let room = WEDGE_ROOM * self.grid_size();
            let roomy: Vec<usize> = (wide.iter().copied())
                .filter(free)
                .filter(|&q| {
                    let x = self.mesh.position(q);
                    on_curves.iter().all(|&c| (c - x).length() >= room)
                })
                .collect();
            if !roomy.is_empty() {
                targets = roomy;
            }
            for p in movable {
                let at = self.mesh.position(p);
                let target = targets
                    .iter()
                    .copied()
                    .filter(|q| !state.singularities.contains_key(q))
                    .min_by(|&a, &b| {
                        let d = |q: usize| (self.mesh.position(q) - at).length();
                        d(a).total_cmp(&d(b)).then(a.cmp(&b))
                    });
                let Some(q) = target else { continue };
                if let Ok(mv) = self.plan(&state, &mut search, p, q) {
                    state = self.commit(&state, &mv);
                }
            }
        }
        state
    }

    /// Per mesh edge whether a geometric curve runs along it (empty without curves).
    fn geometric_curve_edges(&self, state: &EditState) -> Vec<bool> {
        crate::constraint::curve_edges(
            &self.mesh,
            state
                .curves
                .values()
                .filter(|c| c.kind == crate::constraint::CurveKind::Geometric),
        )
    }

    /// Per face along a geometric curve the direction the design holds it to: the curve edges'
    /// directions there combined modulo 2π/N (the mean of e^{iNα}); faces inside an acute
    /// corner take the corner's turning frame (`turning`, `AcuteCorners::alignments`) instead.
    fn design_alignment(
        &self,
        state: &EditState,
        turning: &[crate::constraint::CurveAlignment],
        curve_aligned: Option<Vec<crate::constraint::CurveAlignment>>,
    ) -> Vec<(u32, f64)> {
        let n = self.settings.symmetry as f64;
        // Per face the sum of e^{iNα} over its alignments.
        let combined = |alignments: &[crate::constraint::CurveAlignment]| {
            let mut sum: BTreeMap<usize, (f64, f64)> = BTreeMap::new();
            for a in alignments {
                let alpha = self.bases.angle_of(a.face, a.direction);
                let e = sum.entry(a.face).or_insert((0.0, 0.0));
                e.0 += (n * alpha).cos();
                e.1 += (n * alpha).sin();
            }
            sum
        };
        let along = curve_aligned.unwrap_or_else(|| {
            crate::constraint::alignment(&self.mesh, state.curves.values(), self.grid_size() / 2.0)
        });
        let mut sum = combined(&along);
        // Faces inside an acute corner between two curves take the corner's turning frame
        // instead (combined over the corners they lie in): their curves' mean would put both
        // curves on one line.
        sum.extend(combined(turning));
        sum.into_iter()
            .filter(|(_, (c, s))| c.hypot(*s) > 1e-9)
            .map(|(f, (c, s))| (f as u32, s.atan2(c) / n))
            .collect()
    }

    /// N = 2: the geometric curves the field is held across (`constraint::stripe_across`;
    /// each component of curves meeting at corners the way the unconstrained field agrees with
    /// most along it) and the curves' alignments, those held across turned by 90° in their
    /// faces (in curve order, as `constraint::alignment` gives them). None for other
    /// symmetries.
    fn stripes(
        &self,
        state: &EditState,
    ) -> Option<(BTreeSet<u32>, Vec<crate::constraint::CurveAlignment>)> {
        if self.settings.symmetry != 2 {
            return None;
        }
        let scale = self.grid_size() / 2.0;
        let per_curve: BTreeMap<u32, Vec<crate::constraint::CurveAlignment>> = state
            .curves
            .values()
            .map(|c| (c.id, crate::constraint::alignment(&self.mesh, [c], scale)))
            .collect();
        let theta = &self.field.theta;
        let agreement = |c: &crate::constraint::Curve| {
            per_curve[&c.id]
                .iter()
                .map(|a| (2.0 * (self.bases.angle_of(a.face, a.direction) - theta[a.face])).cos())
                .sum::<f64>()
        };
        let across = crate::constraint::stripe_across(&self.mesh, state.curves.values(), agreement);
        let mut aligned = Vec::new();
        for c in state.curves.values() {
            let turn = across.contains(&c.id);
            aligned.extend(
                per_curve[&c.id]
                    .iter()
                    .map(|&a| crate::constraint::CurveAlignment {
                        direction: if turn {
                            self.mesh.face_normal(a.face).cross(a.direction)
                        } else {
                            a.direction
                        },
                        ..a
                    }),
            );
        }
        Some((across, aligned))
    }

    fn apply_singularity_edit(
        &self,
        state: &EditState,
        edit: &Edit,
        cancel: Cancel,
    ) -> Result<EditState, EditError> {
        match *edit {
            Edit::MoveSingularity { from, to } => {
                let p = self
                    .file_to_mesh(from, "from")
                    .map_err(EditError::Invalid)?;
                let q = self.file_to_mesh(to, "to").map_err(EditError::Invalid)?;
                let mut search = PathSearch::new(self.mesh.n_vertices());
                let mv = self
                    .plan(state, &mut search, p, q)
                    .map_err(EditError::Invalid)?;
                Ok(self.commit(state, &mv))
            }
            Edit::Relax => super::relax::relax(self, state, cancel).map(|r| r.state),
            _ => unreachable!("curve edits are applied above"),
        }
    }

    /// Replays an edit list from the initial state; edits that no longer apply are skipped
    /// (listed with the reason) and the rest kept.
    pub fn replay(&self, edits: &[Edit], cancel: Cancel) -> Result<Replay, EditError> {
        self.replay_from(self.initial.clone(), 0, edits, cancel)
    }

    /// [`Base::replay`] of the edits after position `first` of a list, from the state there (a
    /// cached one: the editor's undo history); skipped edits are numbered in the whole list.
    pub fn replay_from(
        &self,
        start: EditState,
        first: usize,
        edits: &[Edit],
        cancel: Cancel,
    ) -> Result<Replay, EditError> {
        let mut states = vec![start];
        let mut skipped = Vec::new();
        for (i, edit) in edits.iter().enumerate() {
            if cancel() {
                return Err(EditError::Cancelled);
            }
            let before = states.last().expect("initial state");
            let next = match self.apply(before, edit, cancel) {
                Ok(next) => next,
                Err(EditError::Invalid(reason)) => {
                    skipped.push(Skipped {
                        position: first + i + 1,
                        edit: edit.clone(),
                        reason,
                    });
                    before.clone()
                }
                Err(e) => return Err(e),
            };
            states.push(next);
        }
        Ok(Replay { states, skipped })
    }

    /// The field angles of a state: its field's fixed-matching system re-solved for its turns
    /// and released faces (the field's own angles when nothing changed).
    pub fn angles(&self, state: &EditState) -> Result<Vec<f64>, EditError> {
        let field = self.field_of(state);
        if state.turns == field.turns && state.released.is_empty() {
            return Ok(field.theta.clone());
        }
        let system = field
            .system
            .as_ref()
            .ok_or_else(|| EditError::Field("the field kept no system".into()))?;
        system
            .solve(&self.tr, &state.turns, &state.released)
            .map_err(|e| EditError::Field(e.to_string()))
    }

    /// The state's curves as QuadCover takes them.
    fn constraint_curves<'a>(&self, state: &'a EditState) -> Vec<ConstraintCurve<'a>> {
        state
            .curves
            .values()
            .map(|c| ConstraintCurve {
                id: c.id,
                vertices: &c.vertices,
                closed: c.closed,
                geometric: c.kind == crate::constraint::CurveKind::Geometric,
            })
            .collect()
    }

    /// Frames (U, V) per face for angles: isotropic, scaled by the field's density.
    pub fn frames(&self, theta: &[f64]) -> Vec<[glam::DVec3; 2]> {
        let (m, h) = (&self.field.multipliers, self.field.grid_size);
        frames_from_angles(&self.bases, theta, |f| m[f] / h)
    }

    /// The curl of a state's field ([`Parameterization::curl`]), without the global step.
    pub fn curl(&self, state: &EditState) -> Result<f64, EditError> {
        self.curl_free(state).map(|(curl, _)| curl)
    }

    /// [`Base::curl`] with the local step's curl*-free frames (`param::curl_free`).
    pub fn curl_free(&self, state: &EditState) -> Result<(f64, Vec<[glam::DVec3; 2]>), EditError> {
        let theta = self.angles(state)?;
        let matchings = reduce_matchings(&self.tr, &state.turns, self.settings.symmetry);
        crate::param::curl_free(
            &self.mesh,
            self.settings.symmetry as usize,
            &matchings,
            &self.frames(&theta),
            Some(&self.analysis),
        )
        .map_err(|e| EditError::Param(e.to_string()))
    }

    /// E_smooth and E_align of a state's angles.
    fn energies_of(&self, state: &EditState, theta: &[f64]) -> (f64, f64) {
        let step = std::f64::consts::TAU / self.settings.symmetry as f64;
        let base_field = self.field_of(state);
        let mut omega = base_field.omega.clone();
        let released_by_cancellation = base_field
            .system
            .as_ref()
            .map(|s| s.released_by_cancellation())
            .unwrap_or(&[]);
        for &f in released_by_cancellation.iter().chain(&state.released) {
            omega[f] = 0.0;
        }
        let target = base_field
            .system
            .as_ref()
            .map(|s| s.target().to_vec())
            .unwrap_or_else(|| theta.to_vec());
        energies(&self.tr, step, theta, &state.turns, &omega, &target)
    }

    /// QuadCover for a state's matchings: the initial state's solver (made by the first call,
    /// kept for updates), or that one updated for the state's matchings
    /// ([`QuadCover::updated`]). Every state's solver comes from the same base, so a state
    /// reached by editing and the same state replayed from a project solve alike.
    fn quadcover_for(&self, state: &EditState, matchings: &[i32]) -> Result<Solver, EditError> {
        let n = self.settings.symmetry;
        let base = self
            .quadcover
            .get_or_init(|| {
                QuadCover::updatable(
                    &self.mesh,
                    n as usize,
                    &reduce_matchings(&self.tr, &self.initial.turns, n),
                    self.settings.param_options(),
                    Some(&self.analysis),
                )
                .map(Arc::new)
                .map_err(|e| e.to_string())
            })
            .clone()
            .map_err(EditError::Param)?;
        if state.turns == self.initial.turns {
            return Ok(Solver::Base(base));
        }
        base.updated(&self.mesh, matchings)
            .map(|q| Solver::Updated(Box::new(q)))
            .map_err(|e| EditError::Param(e.to_string()))
    }

    /// Whether a state's quads may be solved on Z² instead of 2Z² ([`Base::on_z2`]): under
    /// geometric curves, with `pure_quad` and the repair on.
    fn z2_allowed(&self, state: &EditState) -> bool {
        let opts = self.settings.param_options();
        opts.pure_quad
            && !opts.no_untangle
            && state
                .curves
                .values()
                .any(|c| c.kind == crate::constraint::CurveKind::Geometric)
    }

    /// Quads under geometric curves on Z² instead of 2Z², by a fresh solver (without the edit
    /// model's factor reuse: it is made only for the maps below). On 2Z² every corner where
    /// curves meet is a singularity on an even lattice point, so parallel creases between
    /// corners are 0 or at least 2 cells apart: where they are closer in space than about two
    /// cells (a comb's slots, a gear's teeth at coarse grids) the rounding puts some on one
    /// line and the faces between them fold (a comb with 7 slots at 1500 target vertices: 265
    /// folded faces; on Z² none). The remesh of a Z² map is all quads all the same (its
    /// singularities between grid points are purified), with more irregular vertices.
    fn on_z2(
        &self,
        state: &EditState,
        matchings: &[i32],
        frames: &[[glam::DVec3; 2]],
        cancel: Cancel,
    ) -> Result<Parameterization, ParamError> {
        let z2 = crate::param::ParamOptions {
            pure_quad: false,
            ..self.settings.param_options()
        };
        QuadCover::with_analysis(
            &self.mesh,
            self.settings.symmetry as usize,
            matchings,
            z2,
            Some(&self.analysis),
        )?
        .solve_speculating(
            &self.mesh,
            frames,
            &self.constraint_curves(state),
            cancel,
            &crate::param::no_preview,
            false,
            Collapse::Tries,
        )
    }

    /// Of a map on 2Z² and one on Z² (or its failure), the one with fewer folded faces, then
    /// wrongly wound vertices; the 2Z² map on a tie or when the other failed.
    fn fewer_folds(
        on_2z2: Parameterization,
        on_z2: Result<Parameterization, ParamError>,
    ) -> Result<Parameterization, EditError> {
        match on_z2 {
            Ok(mut other)
                if (other.flipped_faces, other.miswound.len())
                    < (on_2z2.flipped_faces, on_2z2.miswound.len()) =>
            {
                // The first map's repair is part of what the kept one cost, and its rounding
                // says why it was made.
                other.timings.repair_ms += on_2z2.timings.repair_ms;
                other.collapsed_strips = on_2z2.collapsed_strips;
                Ok(other)
            }
            Err(ParamError::Cancelled) => Err(EditError::Cancelled),
            _ => Ok(on_2z2),
        }
    }

    /// A 2Z² map under curves that keeps folds after its repair and its crowded tries (none
    /// when its rounding collapsed strips between curves, [`Collapse::ToZ2`]), solved again
    /// on Z² ([`Base::on_z2`]) and the better kept ([`Base::fewer_folds`]). Also whether the
    /// try was made.
    fn on_z2_if_folded(
        &self,
        state: &EditState,
        matchings: &[i32],
        frames: &[[glam::DVec3; 2]],
        param: Parameterization,
        cancel: Cancel,
    ) -> Result<(Parameterization, bool), EditError> {
        if param.flipped_faces == 0 || !self.z2_allowed(state) {
            return Ok((param, false));
        }
        let z2 = self.on_z2(state, matchings, frames, cancel);
        Ok((Self::fewer_folds(param, z2)?, true))
    }

    /// The field and the parameterization of a state (a pure function of it).
    pub fn solve(&self, state: &EditState, cancel: Cancel) -> Result<Solved, EditError> {
        self.solve_previewing(state, cancel, &crate::param::no_preview)
    }

    /// [`Base::solve`] that hands the global step's map to `preview` as soon as it is known,
    /// when the injectivity repair is about to change it (`QuadCover::solve_previewing`): the
    /// editor shows the new tiling while the folds are repaired.
    pub fn solve_previewing(
        &self,
        state: &EditState,
        cancel: Cancel,
        preview: crate::param::PreviewSink<'_>,
    ) -> Result<Solved, EditError> {
        let mut timings = Vec::new();
        let mut clock = Instant::now();
        let mut lap = |name: &str, timings: &mut Vec<(String, f64)>| {
            timings.push((name.to_string(), clock.elapsed().as_secs_f64()));
            clock = Instant::now();
        };
        let n = self.settings.symmetry;
        let matchings = reduce_matchings(&self.tr, &state.turns, n);
        // QuadCover depends on the matchings only: its systems are updated (or the base's are
        // made) on one core while the field is re-solved on the other.
        let (field_part, qc_part) = rayon::join(
            || {
                let clock = Instant::now();
                let theta = self.angles(state)?;
                let resolve = clock.elapsed().as_secs_f64();
                let field = FrameField {
                    symmetry: self.settings.symmetry(),
                    frames: self.frames(&theta),
                    matchings: matchings.clone(),
                };
                Ok::<_, EditError>((theta, field, resolve))
            },
            || {
                let clock = Instant::now();
                let qc = self.quadcover_for(state, &matchings)?;
                Ok::<_, EditError>((qc, clock.elapsed().as_secs_f64()))
            },
        );
        let (theta, field, resolve) = field_part?;
        let (qc, qc_seconds) = qc_part?;
        let reuse = match &qc {
            Solver::Base(_) => Reuse::Base,
            Solver::Updated(q) => {
                let (local, global) = q.updated_rows();
                Reuse::Updated { local, global }
            }
        };
        timings.push(("field re-solve".to_string(), resolve));
        timings.push(("QuadCover factorizations (beside)".to_string(), qc_seconds));
        timings.push((
            "  of which the cut graph".to_string(),
            qc.timings.cut_ms / 1e3,
        ));
        lap("field and QuadCover, side by side", &mut timings);
        if cancel() {
            return Err(EditError::Cancelled);
        }
        use std::sync::atomic::Ordering;
        // Tries beside the first map on a large mesh, unless the last solve did without them:
        // an edit seldom changes that, and where the first map needs none they only take the
        // second core from its repair (1.1 M faces: 0.4–1 s).
        let speculate = crate::param::speculates(&self.mesh)
            && self.last_took_tries.load(Ordering::Relaxed) != 1;
        // Quads under curves whose 2Z² rounding collapsed a strip between parallel curves
        // take no crowded tries on 2Z² when the map keeps folds: the solve on Z² comes next
        // instead (a gear's teeth at 1000 target vertices: 24 s of tries, none kept).
        let collapse = if self.z2_allowed(state) {
            Collapse::ToZ2
        } else {
            Collapse::Tries
        };
        let param = qc
            .solve_speculating(
                &self.mesh,
                &field.frames,
                &self.constraint_curves(state),
                cancel,
                preview,
                speculate,
                collapse,
            )
            .map_err(edit_error)?;
        self.last_took_tries.store(
            if param.took_crowded_tries() { 2 } else { 1 },
            Ordering::Relaxed,
        );
        lap("QuadCover solve", &mut timings);
        let (param, retried) =
            self.on_z2_if_folded(state, &matchings, &field.frames, param, cancel)?;
        if retried {
            lap(
                "QuadCover on Z² (the 2Z² map folded under curves)",
                &mut timings,
            );
        }
        // The report's indices and energies come last: nothing on screen waits for them (and
        // the cores are busy until the global step's map is there).
        let indices = indices_from_angles(&self.mesh, &self.tr, &theta, &field.matchings, n);
        let (e_smooth, e_align) = self.energies_of(state, &theta);
        lap("indices and energies", &mut timings);
        Ok(Solved {
            field,
            theta,
            indices,
            param,
            e_smooth,
            e_align,
            timings,
            reuse,
        })
    }
}

/// A solve's failure as the edit model reports it: contradicting curves name their ids.
fn edit_error(e: ParamError) -> EditError {
    match e {
        ParamError::Contradiction { curves, message } => {
            EditError::Contradiction { curves, message }
        }
        ParamError::Cancelled => EditError::Cancelled,
        e => EditError::Param(e.to_string()),
    }
}

//! Moving a singularity along an edge path (thesis sec. 3.3, "Singularity Movement"): for a
//! singularity p of index k/N and a path γ from p to q, the matching of every edge on γ changes
//! by k (from the face right of γ to the face left of it, r_ij → r_ij − k); the branch point
//! moves from p to q and no other vertex's index changes, because every inner vertex of γ sees
//! one changed edge entering and one leaving. q may be singular (the indices add: a merge) or on
//! the boundary (the singularity leaves the surface).

use crate::field::cancel::{PathSearch, apply};
use crate::field::transport::EdgeTransport;
use crate::mesh::TriMesh;

/// The full index numerator k (index k/N) of interior vertex v from the integer turns alone:
/// around v's fan the face angles telescope, so ind(v) = (K_v − Σ (κ + (2π/N) r)) / 2π over
/// the crossings (counter-clockwise), without wrapping any residual. Equals the angle-based
/// index of `field::index` whenever the field's residual angles are below π. `None` on the
/// boundary or an isolated vertex.
pub(crate) fn turn_index(
    mesh: &TriMesh,
    tr: &EdgeTransport,
    defect: f64,
    v: usize,
    n: u32,
    turns: &[i64],
) -> Option<i32> {
    crate::field::index::turn_index_k_at(mesh, tr, defect, v, n, |e| turns[e])
}

/// A move planned on a state: the path and what it does.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PlannedMove {
    /// Halfedges of γ from p to q.
    pub path: Vec<usize>,
    /// Sign of the change on γ (see `field::cancel::apply`).
    pub sign: i64,
    /// Index numerator at q after the move (`None`: q is on the boundary, the singularity left).
    pub at_q: Option<i32>,
}

/// Why a move cannot be made; the message is shown to the user as it is.
pub(crate) type Refusal = String;

/// Rules for the index a merge may create.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MergeRules {
    pub n: u32,
    pub no_half_merges: bool,
    /// Refuse merges that would create a pole (positive integral index, e.g. +4/4). Allowed
    /// by default: QuadCover treats poles by alg. 6 (sec. 4.3; bilinear quads on the star).
    pub no_pole_merges: bool,
}

impl MergeRules {
    /// Whether a singularity of index k/N may exist after a merge.
    pub fn check(&self, k: i32) -> Result<(), Refusal> {
        let n = self.n as i32;
        if self.no_pole_merges && k > 0 && k % n == 0 {
            return Err(format!(
                "it would create a singularity of index +{k}/{n} (a pole, positive integral \
                 index), and no_pole_merges is on"
            ));
        }
        if self.no_half_merges && n == 4 && k.abs() == 2 {
            return Err(format!(
                "it would create a singularity of index {}2/4 (a hanging node), and no_half_merges is on",
                if k > 0 { "+" } else { "-" }
            ));
        }
        Ok(())
    }
}

/// Plans moving the singularity of index k_p/N at mesh vertex p to mesh vertex q on the turns
/// `turns`; `k_at(v)` gives the current index numerator of interior vertices.
#[allow(clippy::too_many_arguments)]
pub(crate) fn plan_move(
    mesh: &TriMesh,
    tr: &EdgeTransport,
    defects: &[f64],
    turns: &[i64],
    search: &mut PathSearch,
    p: usize,
    q: usize,
    k_p: i32,
    k_q: i32,
    rules: MergeRules,
) -> Result<PlannedMove, Refusal> {
    if p == q {
        return Err("it moves the singularity onto itself".into());
    }
    let boundary_q = mesh.is_boundary_vertex(q);
    if !boundary_q {
        rules.check(k_p + k_q)?;
    }
    let path = search
        .shortest_interior_path(mesh, p, q, f64::INFINITY)
        .ok_or_else(|| {
            "there is no edge path through interior vertices between them".to_string()
        })?;
    // The sign that leaves p regular (a sign error would double its index instead).
    let mut r = turns.to_vec();
    let n = rules.n;
    let mut sign = 0;
    for s in [1, -1] {
        apply(mesh, &mut r, &path, k_p, s);
        let ok = turn_index(mesh, tr, defects[p], p, n, &r) == Some(0);
        apply(mesh, &mut r, &path, k_p, -s);
        if ok {
            sign = s;
            break;
        }
    }
    if sign == 0 {
        return Err("the path does not move this index (inconsistent turns)".into());
    }
    let at_q = (!boundary_q).then_some(k_p + k_q);
    Ok(PlannedMove { path, sign, at_q })
}

/// Faces whose alignment a move along `path` releases: the stars of the path's vertices (the
/// field must turn smoothly where the matchings changed, sec. 3.3).
pub(crate) fn released_faces(mesh: &TriMesh, path: &[usize]) -> Vec<usize> {
    let mut faces = Vec::new();
    for &h in path {
        for v in [mesh.from(h), mesh.to(h)] {
            faces.extend(mesh.outgoing(v).map(|g| mesh.face_of(g)));
        }
    }
    faces.sort_unstable();
    faces.dedup();
    faces
}

#[cfg(test)]
mod tests {
    use super::MergeRules;

    #[test]
    fn merges_refuse_poles_and_hanging_nodes_when_asked() {
        let rules = |n, no_half_merges, no_pole_merges| MergeRules {
            n,
            no_half_merges,
            no_pole_merges,
        };
        // Poles (positive integral index) are allowed by default (alg. 6 treats them).
        for (n, k) in [(2, 2), (4, 4), (4, 8), (6, 6)] {
            assert!(rules(n, false, false).check(k).is_ok(), "{k}/{n}");
            assert!(rules(n, true, false).check(k).is_ok(), "{k}/{n}");
        }
        // no_pole_merges refuses them for every N, naming the index and the setting; saddles
        // (negative integral index) and fractional indices stay allowed.
        let e = rules(4, false, true).check(4).unwrap_err();
        assert!(
            e.contains("+4/4") && e.contains("pole") && e.contains("no_pole_merges"),
            "{e}"
        );
        assert!(rules(2, false, true).check(2).unwrap_err().contains("+2/2"));
        assert!(rules(4, false, true).check(8).is_err());
        assert!(rules(6, false, true).check(6).is_err());
        assert!(rules(2, false, true).check(-2).is_ok());
        assert!(rules(4, false, true).check(-4).is_ok());
        assert!(rules(4, false, true).check(3).is_ok());
        assert!(rules(6, false, true).check(3).is_ok());
        assert!(rules(4, false, true).check(2).is_ok());
        // ±2/4 only with no_half_merges, and only for N = 4.
        assert!(rules(4, false, false).check(2).is_ok());
        assert!(
            rules(4, true, false)
                .check(2)
                .unwrap_err()
                .contains("no_half_merges")
        );
        assert!(rules(4, true, false).check(-2).is_err());
        assert!(rules(4, true, false).check(-3).is_ok());
        assert!(rules(6, true, false).check(2).is_ok());
        assert!(rules(4, true, false).check(0).is_ok());
    }
}

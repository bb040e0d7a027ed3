//! The *Folds* overlay: the faces of the map shown whose texture triangle is folded
//! (non-positive signed area, [`crate::param::folded_faces`]) and the fans of mis-wound
//! vertices (`Parameterization::miswound`: not locally injective although unfolded), outlined
//! and hatched over the surface. The list is found once per result ([`super::document::Folds`]); the overlay is
//! built once per list.

use std::sync::Arc;

use super::document::Folds;
use super::editor::EditorApp;
use super::scene::{LineSegment, Overlay};
use super::tools::next_overlay_revision;
use crate::mesh::TriMesh;

/// Linear RGBA of the fold overlay (a crimson apart from the cut graph's orange-red).
pub const FOLD_COLOR: [f32; 4] = [1.0, 0.0, 0.25, 1.0];

/// The overlay of folded faces: each face's edges as thick lines and its medians as lines, so a
/// face small on screen becomes a solid spot and a large one a hatched triangle; drawn over
/// the singularity glyphs.
pub fn folds_overlay(mesh: &TriMesh, faces: &[usize]) -> Overlay {
    // Folds sit at singular vertices more often than not: drawn over their glyphs.
    let mut o = Overlay {
        revision: next_overlay_revision(),
        over_glyphs: true,
        ..Default::default()
    };
    let seg = |a: glam::Vec3, b: glam::Vec3| LineSegment {
        a: a.to_array(),
        b: b.to_array(),
        color: FOLD_COLOR,
    };
    for &f in faces.iter().filter(|&&f| f < mesh.n_faces()) {
        let p = mesh.faces()[f].map(|v| mesh.position(v as usize).as_vec3());
        for k in 0..3 {
            let (a, b, c) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
            o.thick_lines.push(seg(a, b));
            o.lines.push(seg(c, 0.5 * (a + b)));
        }
    }
    o
}

/// The overlay and the fold list it was built for.
#[derive(Debug, Default)]
pub struct FoldsUi {
    cached: Option<(Arc<Folds>, Option<Arc<Overlay>>)>,
}

impl EditorApp {
    /// The folded faces of the map shown, while *Folds* is on (`None` when there are none).
    pub fn folds_overlay(&mut self) -> Option<Arc<Overlay>> {
        let doc = &self.document;
        if !doc.display.show_folds {
            return None;
        }
        let (mesh, folds) = (doc.mesh.as_ref()?, doc.folds.as_ref()?);
        let ui = &mut self.folds;
        if !ui
            .cached
            .as_ref()
            .is_some_and(|(f, _)| Arc::ptr_eq(f, folds))
        {
            let faces = folds.shown_faces(mesh);
            let overlay = (!faces.is_empty()).then(|| Arc::new(folds_overlay(mesh, &faces)));
            ui.cached = Some((folds.clone(), overlay));
        }
        ui.cached.as_ref().and_then(|(_, o)| o.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::document::FoldRepair;
    use glam::DVec3;

    #[test]
    fn folded_faces_are_outlined_and_counted() {
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0)];
        let mesh = TriMesh::from_triangles(p.to_vec(), vec![[0, 1, 2], [1, 3, 2]]).unwrap();
        // face 1's texture triangle is mirrored
        let uv = [
            [0.0, 0.0],
            [1.0, 0.0],
            [0.0, 1.0],
            [1.0, 0.0],
            [0.0, 1.0],
            [1.0, 1.0],
        ];
        let folds = Folds::new(&uv, FoldRepair::Ran { before: 4, ms: 1.0 });
        assert_eq!(folds.faces, vec![1]);
        assert_eq!(folds.summary(), "1 folded face (4 before repair)");
        let o = folds_overlay(&mesh, &folds.faces);
        assert_eq!(o.thick_lines.len(), 3);
        assert_eq!(o.lines.len(), 3);
        assert!(o.thick_lines.iter().all(|l| l.color == FOLD_COLOR));
        assert!(o.over_glyphs);
        let none = Folds::new(&uv[..3], FoldRepair::Ran { before: 0, ms: 0.0 });
        assert_eq!(none.summary(), "No folded faces");
        assert_eq!(
            Folds::new(&uv, FoldRepair::Off).summary(),
            "1 folded face (untangling off)"
        );
        // A mis-wound vertex: counted in the line, its fan marked with the folded faces.
        let mut wound = Folds::new(&uv[..3], FoldRepair::Ran { before: 2, ms: 1.0 });
        wound.miswound = vec![3];
        assert_eq!(
            wound.summary(),
            "No folded faces (2 before repair); 1 mis-wound vertex"
        );
        assert_eq!(wound.shown_faces(&mesh), vec![1]);
        wound.miswound = vec![0, 1];
        assert_eq!(wound.shown_faces(&mesh), vec![0, 1]);
        // Curves beside the folds are named, a long list cut short.
        let mut beside = Folds::new(&uv, FoldRepair::Ran { before: 4, ms: 1.0 });
        beside.beside_curves = vec![3];
        assert_eq!(
            beside.summary(),
            "1 folded face (4 before repair), beside curve 3"
        );
        beside.beside_curves = (0..11).collect();
        assert_eq!(
            beside.summary(),
            "1 folded face (4 before repair), beside curves 0, 1, 2, 3, 4, 5, 6, 7 and 3 more"
        );
    }
}

//! Display settings of the viewport (part of the document).

/// Surface shading.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Shading {
    #[default]
    Smooth,
    Flat,
}

/// Texture pattern drawn from the per-corner UVs. The discriminant is the
/// pattern id used by `shaders/mesh.wgsl`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Pattern {
    #[default]
    None = 0,
    QuadGrid = 1,
    Checkerboard = 2,
    Triangles = 3,
    Hexagons = 4,
    Stripes = 5,
    OctagonSquare = 6,
    Image = 7,
}

impl Pattern {
    pub const ALL: [Pattern; 8] = [
        Pattern::None,
        Pattern::QuadGrid,
        Pattern::Checkerboard,
        Pattern::Triangles,
        Pattern::Hexagons,
        Pattern::Stripes,
        Pattern::OctagonSquare,
        Pattern::Image,
    ];

    pub fn label(self) -> &'static str {
        match self {
            Pattern::None => "None",
            Pattern::QuadGrid => "Quad grid",
            Pattern::Checkerboard => "Checkerboard",
            Pattern::Triangles => "Triangles (G6)",
            Pattern::Hexagons => "Hexagons (G6)",
            Pattern::Stripes => "Stripes",
            Pattern::OctagonSquare => "Octagon-square (4.8.8)",
            Pattern::Image => "Image texture",
        }
    }

    /// Whether the pattern is invariant under the transitions of an N-symmetric
    /// parameterization — rotation by 2π/N and a translation in its lattice (Z² for N = 2 and 4,
    /// G6 for N = 6) — so that its seams are invisible.
    pub fn fits_symmetry(self, n: u32) -> bool {
        match self {
            Pattern::None | Pattern::Image => true,
            Pattern::QuadGrid | Pattern::Checkerboard | Pattern::OctagonSquare => {
                n == 1 || n == 2 || n == 4
            }
            // Periodic on G6, not on Z²: seams of an N = 2 or 4 map (Z² translations) would show.
            Pattern::Triangles | Pattern::Hexagons => matches!(n, 3 | 6),
            Pattern::Stripes => n == 1 || n == 2,
        }
    }
}

/// How the surface is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum DisplayMode {
    /// Shaded surface only.
    #[default]
    Shaded,
    /// Shaded surface with the texture pattern of the parameterization.
    Pattern,
    /// Shaded surface with a LIC of the field.
    Field,
}

impl DisplayMode {
    pub const ALL: [DisplayMode; 3] = [
        DisplayMode::Shaded,
        DisplayMode::Pattern,
        DisplayMode::Field,
    ];

    pub fn label(self) -> &'static str {
        match self {
            DisplayMode::Shaded => "Shaded",
            DisplayMode::Pattern => "Texture pattern",
            DisplayMode::Field => "Field (LIC)",
        }
    }
}

/// How the remesh of the shown parameterization ([`super::remesh`]) is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum RemeshDisplay {
    /// Not drawn.
    #[default]
    Off,
    /// Its edges (stripes: its polylines) and irregular vertices over the surface.
    Edges,
    /// Its polygons shaded instead of the surface, with its edges and irregular vertices.
    Only,
}

impl RemeshDisplay {
    pub const ALL: [RemeshDisplay; 3] = [
        RemeshDisplay::Off,
        RemeshDisplay::Edges,
        RemeshDisplay::Only,
    ];

    pub fn label(self) -> &'static str {
        match self {
            RemeshDisplay::Off => "Off",
            RemeshDisplay::Edges => "Edges over surface",
            RemeshDisplay::Only => "Remesh only",
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct DisplaySettings {
    pub mode: DisplayMode,
    pub shading: Shading,
    pub wireframe: bool,
    pub pattern: Pattern,
    /// Pattern cells per parameter unit.
    pub pattern_scale: f32,
    /// Twisted stripes (thesis sec. 4.2): the stripe texture is drawn at (n u − k v, k u + n v),
    /// still invariant under Z² translations and the 180° turn, so seams stay invisible.
    /// (1, 0) is plain stripes; (1, 1) turns them by 45°.
    pub stripe_twist: [u32; 2],
    /// Line width of patterns and wireframe, pixels.
    pub line_width: f32,
    /// Size of a LIC noise cell on screen, pixels.
    pub lic_cell_px: f32,
    /// Streamline half-length (each way from the pixel) in noise cells; capped at 32 px.
    pub lic_length: f32,
    /// 0..1 blend of the LIC over the shading.
    pub lic_strength: f32,
    pub show_singularities: bool,
    pub show_lines: bool,
    /// Draw the constraint curves.
    pub show_curves: bool,
    /// Highlight the folded faces of the map ([`super::folds`]).
    pub show_folds: bool,
    /// The remesh overlay ([`super::remesh`]).
    pub remesh: RemeshDisplay,
    pub glyph_size_px: f32,
    pub overlay_line_width_px: f32,
    /// Linear RGB.
    pub base_color: [f32; 3],
    /// sRGB background.
    pub background: [u8; 3],
}

impl Default for DisplaySettings {
    fn default() -> Self {
        DisplaySettings {
            mode: DisplayMode::Shaded,
            shading: Shading::Smooth,
            wireframe: false,
            pattern: Pattern::QuadGrid,
            pattern_scale: 1.0,
            stripe_twist: [1, 0],
            line_width: 1.2,
            lic_cell_px: 2.5,
            lic_length: 8.0,
            lic_strength: 0.9,
            show_singularities: true,
            show_lines: true,
            show_curves: true,
            show_folds: false,
            remesh: RemeshDisplay::Off,
            glyph_size_px: 14.0,
            overlay_line_width_px: 2.5,
            base_color: [0.62, 0.66, 0.72],
            background: [38, 40, 46],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Pattern;

    #[test]
    fn patterns_fit_the_lattice_and_rotation_of_their_symmetry() {
        use Pattern::*;
        for (n, fitting) in [
            (2, vec![QuadGrid, Checkerboard, OctagonSquare, Stripes]),
            (4, vec![QuadGrid, Checkerboard, OctagonSquare]),
            (6, vec![Triangles, Hexagons]),
        ] {
            for p in [
                QuadGrid,
                Checkerboard,
                OctagonSquare,
                Stripes,
                Triangles,
                Hexagons,
            ] {
                assert_eq!(
                    p.fits_symmetry(n),
                    fitting.contains(&p),
                    "{p:?} for N = {n}"
                );
            }
        }
    }
}

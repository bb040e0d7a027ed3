//! Tangential relaxation of a remesh on the input surface (filled in by the relaxation work).

//! quadcover: field-guided global parameterization and tiling of triangle meshes.
//!
//! The core (everything but [`app`]) is plain data in and out: [`mesh`] (connectivity, geometry,
//! topology, validation), [`io`] (file formats), [`sparse`] (the one solver wrapper over faer),
//! [`field`] (frame fields), [`param`] (QuadCover), and the headless [`cli`].
pub mod app;
pub mod cli;
pub mod constraint;
pub mod edit;
pub mod export;
pub mod extract;
pub mod field;
pub mod io;
pub mod load;
pub mod mesh;
pub mod param;
pub mod sparse;

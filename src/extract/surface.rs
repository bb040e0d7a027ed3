//! Closest-point queries on the input surface (filled in by the relaxation work).

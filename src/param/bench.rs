//! Stage timings for `quadcover bench`.

use std::time::Instant;

use glam::DVec3;

use crate::mesh::TriMesh;

use super::{ParamError, ParamOptions, QuadCover, Rounding};

/// Times each stage for the given frames and matchings: cut graph, local factor + solve, global
/// factor, direct rounding + global solve, a global re-solve reusing the factorization (new
/// right-hand side), a full re-solve for changed frames, and greedy rounding. Milliseconds.
pub fn bench_param(
    mesh: &TriMesh,
    symmetry: usize,
    frames: &[[DVec3; 2]],
    matchings: &[i32],
) -> Result<Vec<(String, f64)>, ParamError> {
    let ms = |t: Instant| t.elapsed().as_secs_f64() * 1e3;
    let t0 = Instant::now();
    let qc = QuadCover::new(mesh, symmetry, matchings, ParamOptions::default())?;
    let prep = ms(t0);
    let mut out = vec![
        ("param.cut".to_string(), qc.timings.cut_ms),
        ("param.local.factor".to_string(), qc.timings.local_ms),
        ("param.global.factor".to_string(), qc.timings.global_ms),
    ];
    let t = Instant::now();
    let local = qc.local_step(mesh, frames)?;
    out.push(("param.local.solve+integrate".into(), ms(t)));
    let t = Instant::now();
    let gaps = qc.round_gaps(mesh, &local)?;
    let _uv = qc.global_uv(mesh, &local, &gaps)?;
    out.push(("param.global.direct".into(), ms(t)));
    let t = Instant::now();
    let shifted: Vec<[f64; 2]> = gaps.iter().map(|g| [g[0] + 1.0, g[1]]).collect();
    let _uv = qc.global_uv(mesh, &local, &shifted)?;
    out.push(("param.global.resolve".into(), ms(t)));
    let t = Instant::now();
    let scaled: Vec<[DVec3; 2]> = frames.iter().map(|x| [x[0] * 1.1, x[1] * 1.1]).collect();
    let _p = qc.solve(mesh, &scaled)?;
    out.push(("param.resolve.new_frames".into(), ms(t)));
    let t = Instant::now();
    let greedy = QuadCover {
        opts: ParamOptions {
            rounding: Rounding::Greedy,
            pure_quad: false,
            no_untangle: false,
            no_poles: false,
            no_crowded_refinement: false,
        },
        ..qc
    };
    let _g = greedy.round_gaps(mesh, &local)?;
    out.push(("param.global.greedy_rounding".into(), ms(t)));
    out.push(("param.total_first_solve".into(), prep + out[3].1 + out[4].1));
    Ok(out)
}

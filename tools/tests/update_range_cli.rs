//! fp16 smoother updates (`--update-storage f16`, the default) on a solution beyond fp16's range
//! (issue 13): at eta 3.5 (q_gain = 4 / (1 - F_dr) ~ 167) a constant environment puts phi at
//! ~1.8e5 in the exposure's units, and the coarsest level's first Chebyshev steps stored updates
//! over 65504: the solve went non-finite and the render failed (measured before the fix:
//! `SolverError::GpuDiverged`, rc 1, at 768 coarsest nodes). The solve now runs in units scaled by
//! a power of two from q_gain (`solver::gpu::multigrid::solution_scale`), so it converges and
//! agrees with the f32 updates.

mod common;

use common::{json_of, scratch, translucent};

fn render(dir: &std::path::Path, updates: &str) -> serde_json::Value {
    let out = dir.join(format!("eta35-{updates}.exr"));
    let run = translucent(
        &[
            "render",
            "--shape",
            "sphere",
            "--size-mm",
            "20",
            "--material",
            "marble",
            "--eta",
            "3.5",
            "--env-constant",
            "1,1,1",
            "--light",
            "dir:0,-1,0:0,0,0",
            "--out",
            out.to_str().expect("path"),
            "--width",
            "32",
            "--height",
            "32",
            "--resolution",
            "16",
            "--supersample",
            "1",
            "--single-scattering",
            "off",
            "--schedule",
            "multigrid",
            "--update-storage",
            updates,
            "--json",
        ],
        dir,
    );
    assert!(
        run.status.success(),
        "--update-storage {updates}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(out.exists());
    json_of(&run)
}

fn exitance(json: &serde_json::Value) -> [f64; 3] {
    let e = &json["energy"]["exitance"];
    std::array::from_fn(|c| e[c].as_f64().expect("exitance"))
}

#[test]
fn fp16_updates_converge_on_a_solution_beyond_fp16() {
    let dir = scratch("update-range");
    let half = render(&dir, "f16");
    let full = render(&dir, "f32");
    for json in [&half, &full] {
        let mg = &json["frames"][0]["multigrid"];
        assert_eq!(mg["state"], "Converged", "{mg}");
        let residual = mg["residual"].as_f64().expect("residual");
        assert!(residual.is_finite() && residual < 1e-4, "{mg}");
    }
    let (a, b) = (exitance(&half), exitance(&full));
    for c in 0..3 {
        assert!(a[c].is_finite() && a[c] > 0.0, "{a:?}");
        // Both solves stop at the relative residual 1e-4.
        assert!(
            (a[c] - b[c]).abs() <= 1e-3 * b[c],
            "channel {c}: f16 updates {a:?}, f32 {b:?}"
        );
    }
}

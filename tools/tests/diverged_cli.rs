//! `translucent render` on a GPU multigrid solve that ends Diverged (issue 13): the command fails
//! with the typed `SolverError::GpuDiverged` message (the residual, the cycles, the levels and a
//! hint), writes no image and exits non-zero. The divergence is forced cheaply: a damped Jacobi
//! smoother at omega 1.99 without CG amplifies the high modes (omega above 2 / lambda_max of
//! D^-1 K) until the residual is non-finite within two cycles (measured: 12k nodes, 2 levels).

mod common;

use common::{scratch, translucent};

/// A cycle that diverges: damped Jacobi past the stable omega (validate accepts (0, 2)), no CG.
const DIVERGING_CYCLE: &str = "jacobi=1.99,krylov=0";

fn render(out: &std::path::Path, cycle: &str) -> std::process::Output {
    let dir = out.parent().expect("scratch dir");
    translucent(
        &[
            "render",
            "--shape",
            "sphere",
            "--out",
            out.to_str().expect("path"),
            "--width",
            "32",
            "--height",
            "32",
            "--resolution",
            "12",
            "--levels",
            "2",
            "--supersample",
            "1",
            "--single-scattering",
            "off",
            "--schedule",
            "multigrid",
            "--multigrid-cycle",
            cycle,
        ],
        dir,
    )
}

#[test]
fn a_diverged_gpu_solve_fails_the_render_and_writes_no_image() {
    let dir = scratch("diverged");
    let out = dir.join("diverged.exr");
    let _ = std::fs::remove_file(&out);
    let failed = render(&out, DIVERGING_CYCLE);
    let stderr = String::from_utf8_lossy(&failed.stderr);
    assert!(
        !failed.status.success(),
        "rc 0 on a diverged solve: {stderr}"
    );
    assert!(stderr.contains("GPU multigrid diverged"), "{stderr}");
    assert!(stderr.contains("non-finite"), "{stderr}");
    assert!(stderr.contains("--schedule cascade"), "the hint: {stderr}");
    assert!(!out.exists(), "an image was written for a diverged solve");

    // The same scene with a stable omega renders: the failure is the divergence's.
    let ok = render(&out, "jacobi=0.8,krylov=0");
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    assert!(out.exists());
}

//! Ping-pong Jacobi on two RGBA16F storage images (the first compute pipeline end to end), on a
//! problem with a known solution, with synchronization validation on and no message allowed.
//!
//! Problem: 2D Laplace on a 17x17 grid, Dirichlet border values of linear functions (R and G), a
//! constant (B) and 1 (A); interior starts at 0. A linear function is the mean of its four
//! neighbours, so it is the exact discrete solution.
//!
//! Tolerances, derived from fp16 (all values lie in [0.5, 1), where an fp16 ulp is 2^-11):
//! - Against a CPU emulation of the same fp16 iteration (f32 sums in the shader's order, then the
//!   fp16 store rounding, which Vulkan leaves to the implementation: round to nearest even or
//!   toward zero; lavapipe truncates): at most 2 ulps from one of the two (lavapipe: 0).
//! - Against the exact solution: once the iteration is stationary, each interior value equals the
//!   fp16 rounding of its neighbours' mean, so the error e satisfies e = M e + r with
//!   |r| <= ulp + 2^-22 (truncation; ulp/2 when rounding to nearest; 2^-22 for the f32 sum),
//!   and border errors <= ulp/2 (the upload rounds to nearest). By the discrete maximum
//!   principle |e| <= ulp/2 + max(w) |r|, where w = M w + 1
//!   (w = 0 on the border) is computed here in f64. This is the stall the DESIGN warns about
//!   (section 4): fp16 Jacobi stops moving before it converges.

use half::f16;
use translucent::render::LaplaceJacobiPass;
use translucent_tests::GpuTest;

const N: usize = 17;
const ITERATIONS: u32 = 1200;
const ULP: f64 = 1.0 / 2048.0;

fn exact(x: usize, y: usize) -> [f32; 4] {
    let (u, v) = (x as f32 / (N - 1) as f32, y as f32 / (N - 1) as f32);
    [
        0.5 + 0.25 * u + 0.125 * v,
        0.9 - 0.25 * u + 0.05 * v,
        0.75,
        1.0,
    ]
}

fn is_border(x: usize, y: usize) -> bool {
    x == 0 || y == 0 || x == N - 1 || y == N - 1
}

/// fp16 rounding toward zero.
fn f16_truncated(v: f32) -> f16 {
    let h = f16::from_f32(v);
    if h.to_f32().abs() > v.abs() {
        f16::from_bits(h.to_bits() - 1)
    } else {
        h
    }
}

/// The GPU's algorithm on the CPU: f32 sums in the shader's order, then `round` to fp16.
fn fp16_step(src: &[[f16; 4]], round: fn(f32) -> f16) -> Vec<[f16; 4]> {
    let mut dst = src.to_vec();
    for y in 1..N - 1 {
        for x in 1..N - 1 {
            let at = |x: usize, y: usize, c: usize| src[y * N + x][c].to_f32();
            dst[y * N + x] = std::array::from_fn(|c| {
                round(
                    0.25 * (at(x + 1, y, c) + at(x - 1, y, c) + at(x, y + 1, c) + at(x, y - 1, c)),
                )
            });
        }
    }
    dst
}

/// max w for w = M w + 1 inside, w = 0 on the border (expected exit time of the random walk).
fn max_exit_time() -> f64 {
    let mut w = vec![0.0f64; N * N];
    loop {
        let mut next = w.clone();
        let mut change = 0.0f64;
        for y in 1..N - 1 {
            for x in 1..N - 1 {
                let v = 1.0
                    + 0.25
                        * (w[y * N + x + 1]
                            + w[y * N + x - 1]
                            + w[(y + 1) * N + x]
                            + w[(y - 1) * N + x]);
                change = change.max((v - w[y * N + x]).abs());
                next[y * N + x] = v;
            }
        }
        w = next;
        if change < 1e-9 {
            return w.iter().cloned().fold(0.0, f64::max);
        }
    }
}

#[test]
fn jacobi_ping_pong_reaches_the_linear_solution_within_the_fp16_bound() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let initial: Vec<[f32; 4]> = (0..N * N)
        .map(|i| {
            if is_border(i % N, i / N) {
                exact(i % N, i / N)
            } else {
                [0.0; 4]
            }
        })
        .collect();
    let mut pass = LaplaceJacobiPass::new(ctx, N as u32, N as u32).expect("pass");
    pass.upload(ctx, &initial).expect("upload");
    let result = pass.run(ctx, ITERATIONS).expect("run");

    let emulate = |round: fn(f32) -> f16| {
        let mut u: Vec<[f16; 4]> = initial.iter().map(|p| p.map(f16::from_f32)).collect();
        for _ in 0..ITERATIONS {
            u = fp16_step(&u, round);
        }
        assert_eq!(
            fp16_step(&u, round),
            u,
            "the fp16 iteration is not stationary after {ITERATIONS} sweeps"
        );
        u
    };
    let (nearest, truncated) = (emulate(f16::from_f32), emulate(f16_truncated));
    let distance = |emulated: &[[f16; 4]]| {
        let mut worst = 0.0f64;
        for (i, e) in emulated.iter().enumerate() {
            let got = result.pixel((i % N) as u32, (i / N) as u32);
            for c in 0..4 {
                worst = worst.max((f64::from(got[c]) - f64::from(e[c].to_f32())).abs());
            }
        }
        worst
    };
    let worst_emulated = distance(&nearest).min(distance(&truncated));

    let r = ULP + 2f64.powi(-22);
    let bound = ULP / 2.0 + max_exit_time() * r;
    let mut worst_exact = 0.0f64;
    for y in 0..N {
        for x in 0..N {
            let got = result.pixel(x as u32, y as u32);
            for (g, e) in got.iter().zip(exact(x, y)) {
                assert!(g.is_finite(), "NaN/Inf at ({x}, {y})");
                worst_exact = worst_exact.max((f64::from(*g) - f64::from(e)).abs());
            }
        }
    }
    println!("max |gpu - fp16 emulation| = {worst_emulated:e}, max |gpu - exact| = {worst_exact:e}, bound {bound:e}");
    assert!(
        worst_emulated <= 2.0 * ULP,
        "GPU differs from the fp16 emulation by {worst_emulated}"
    );
    assert!(
        worst_exact <= bound,
        "GPU differs from the exact solution by {worst_exact} > {bound}"
    );
    drop(pass);
    gpu.finish();
}

#[test]
fn a_grid_without_interior_or_wrong_sized_input_is_a_typed_error() {
    let gpu = GpuTest::new();
    assert!(LaplaceJacobiPass::new(&gpu.ctx, 2, 5).is_err());
    let mut pass = LaplaceJacobiPass::new(&gpu.ctx, 4, 4).expect("pass");
    assert!(pass.upload(&gpu.ctx, &[[0.0; 4]; 15]).is_err());
    assert!(pass.upload(&gpu.ctx, &[[f32::NAN; 4]; 16]).is_err());
    assert!(pass.upload(&gpu.ctx, &[[1e6; 4]; 16]).is_err());
    drop(pass);
    gpu.finish();
}

//! Lattice noise for procedural materials: value noise, gradient noise and turbulence.
//!
//! Written with plain arithmetic on `u32` and `f64` (no tables, no traits) so that it ports line by
//! line to GLSL (`uint` hashing, `fract`, `floor`, `mix`). Deterministic for a given seed.
//!
//! ```
//! use translucent::material::noise;
//! let v = noise::gradient(glam::DVec3::new(0.3, 1.7, -2.2), 7);
//! assert!(v.abs() <= 1.0);
//! assert_eq!(noise::gradient(glam::DVec3::new(1.0, 2.0, 3.0), 7), 0.0); // zero at lattice points
//! ```

use glam::DVec3;

/// A 32-bit integer hash (the "lowbias32" mixer of Chris Wellons): cheap, well mixed, GLSL-friendly.
pub fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Hash of a lattice point and a seed.
pub fn hash3(i: [i32; 3], seed: u32) -> u32 {
    let mut h = hash_u32(seed ^ 0x9e37_79b9);
    for v in i {
        h = hash_u32(h ^ (v as u32));
    }
    h
}

fn fade(t: f64) -> f64 {
    // Quintic fade: C2 continuity, so the noise has no visible creases.
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lattice(p: DVec3) -> ([i32; 3], DVec3) {
    let f = p.floor();
    ([f.x as i32, f.y as i32, f.z as i32], p - f)
}

/// Value noise in [0, 1]: random values at lattice points, smoothly interpolated.
pub fn value(p: DVec3, seed: u32) -> f64 {
    let (i, f) = lattice(p);
    let u = DVec3::new(fade(f.x), fade(f.y), fade(f.z));
    let v = |dx: i32, dy: i32, dz: i32| {
        hash3([i[0] + dx, i[1] + dy, i[2] + dz], seed) as f64 / u32::MAX as f64
    };
    let x00 = v(0, 0, 0) + (v(1, 0, 0) - v(0, 0, 0)) * u.x;
    let x10 = v(0, 1, 0) + (v(1, 1, 0) - v(0, 1, 0)) * u.x;
    let x01 = v(0, 0, 1) + (v(1, 0, 1) - v(0, 0, 1)) * u.x;
    let x11 = v(0, 1, 1) + (v(1, 1, 1) - v(0, 1, 1)) * u.x;
    let y0 = x00 + (x10 - x00) * u.y;
    let y1 = x01 + (x11 - x01) * u.y;
    y0 + (y1 - y0) * u.z
}

/// Gradient (Perlin) noise, roughly in [-1, 1], zero at lattice points.
pub fn gradient(p: DVec3, seed: u32) -> f64 {
    let (i, f) = lattice(p);
    let u = DVec3::new(fade(f.x), fade(f.y), fade(f.z));
    // One of the 12 cube-edge directions per lattice point (Perlin 2002).
    let g = |dx: i32, dy: i32, dz: i32| {
        let h = hash3([i[0] + dx, i[1] + dy, i[2] + dz], seed) % 12;
        let d = f - DVec3::new(dx as f64, dy as f64, dz as f64);
        let (a, b) = match h / 4 {
            0 => (d.x, d.y),
            1 => (d.x, d.z),
            _ => (d.y, d.z),
        };
        let sa = if h & 1 == 0 { a } else { -a };
        let sb = if h & 2 == 0 { b } else { -b };
        sa + sb
    };
    let x00 = g(0, 0, 0) + (g(1, 0, 0) - g(0, 0, 0)) * u.x;
    let x10 = g(0, 1, 0) + (g(1, 1, 0) - g(0, 1, 0)) * u.x;
    let x01 = g(0, 0, 1) + (g(1, 0, 1) - g(0, 0, 1)) * u.x;
    let x11 = g(0, 1, 1) + (g(1, 1, 1) - g(0, 1, 1)) * u.x;
    let y0 = x00 + (x10 - x00) * u.y;
    let y1 = x01 + (x11 - x01) * u.y;
    (y0 + (y1 - y0) * u.z).clamp(-1.0, 1.0)
}

/// Turbulence (Perlin 1985): sum of |gradient noise| over `octaves` doubling frequencies, weights
/// halving, normalized to about [0, 1].
pub fn turbulence(p: DVec3, octaves: u32, seed: u32) -> f64 {
    let (mut sum, mut norm, mut freq, mut amp) = (0.0, 0.0, 1.0, 1.0);
    for o in 0..octaves.max(1) {
        sum += amp * gradient(p * freq, seed.wrapping_add(o)).abs();
        norm += amp;
        freq *= 2.0;
        amp *= 0.5;
    }
    sum / norm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounded_continuous_deterministic() {
        let mut prev = gradient(DVec3::new(0.0, 0.5, 0.5), 3);
        for k in 1..2000 {
            let p = DVec3::new(k as f64 * 0.001, 0.5, 0.5);
            let g = gradient(p, 3);
            let v = value(p * 3.1, 3);
            let t = turbulence(p * 1.7, 5, 3);
            assert!(g.abs() <= 1.0 && (0.0..=1.0).contains(&v) && (0.0..=1.0).contains(&t));
            assert!((g - prev).abs() < 0.01, "gradient noise jumps at {p}");
            prev = g;
            assert_eq!(g, gradient(p, 3));
        }
        assert_ne!(
            gradient(DVec3::splat(0.37), 1),
            gradient(DVec3::splat(0.37), 2)
        );
    }
}

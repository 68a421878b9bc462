//! `render --backdrop`: a studio backdrop behind the object in a PNG, a grey gradient that is
//! lighter towards the floor, so a new user's first image is not an object floating in black.
//!
//! The capture is box-resolved with a black background, so a pixel is `coverage * radiance` and
//! its alpha the coverage: the backdrop is added where the object does not cover,
//! `c + (1 - alpha) * B(y)`, leaving the object's own pixels as they were (silhouettes blend).
//!
//! ```
//! use translucent::vk::LinearImage;
//! let mut image = LinearImage { width: 2, height: 2, pixels: vec![[0.0; 4]; 4] };
//! translucent_tools::backdrop::composite(&mut image, 1.0);
//! assert!(image.pixel(0, 1)[0] > image.pixel(0, 0)[0], "lighter towards the floor");
//! ```

use translucent::vk::LinearImage;

/// The backdrop's linear radiance at the top and the bottom of the image (before exposure),
/// about 18% and 38% grey after the tone map and sRGB: dark enough that a dim object still reads.
pub const TOP: [f32; 3] = [0.026, 0.028, 0.032];
pub const BOTTOM: [f32; 3] = [0.12, 0.12, 0.125];

/// Adds the backdrop where `image` is not covered; the radiance is divided by `exposure` so the
/// backdrop looks the same at any `--exposure` (nothing is added at exposure 0).
pub fn composite(image: &mut LinearImage, exposure: f32) {
    if !(exposure.is_finite() && exposure > 0.0) {
        return;
    }
    let width = image.width as usize;
    let rows = image.height.max(2) as f32 - 1.0;
    for (i, p) in image.pixels.iter_mut().enumerate() {
        let t = (i / width.max(1)) as f32 / rows;
        // Eased so the floor's brightening starts below the middle, like a cyclorama.
        let t = t * t;
        let uncovered = (1.0 - p[3]).clamp(0.0, 1.0);
        for c in 0..3 {
            let b = TOP[c] + (BOTTOM[c] - TOP[c]) * t;
            p[c] += uncovered * b / exposure;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn covered_pixels_keep_their_radiance_and_edges_blend() {
        let mut image = LinearImage {
            width: 1,
            height: 3,
            pixels: vec![[0.0; 4], [0.5, 0.4, 0.3, 1.0], [0.25, 0.2, 0.15, 0.5]],
        };
        composite(&mut image, 2.0);
        assert_eq!(
            image.pixel(0, 1),
            [0.5, 0.4, 0.3, 1.0],
            "covered: unchanged"
        );
        // Uncovered top: the top colour over the exposure.
        assert!((image.pixel(0, 0)[0] - TOP[0] / 2.0).abs() < 1e-7);
        // Half covered bottom: half the bottom colour added.
        assert!((image.pixel(0, 2)[0] - (0.25 + 0.5 * BOTTOM[0] / 2.0)).abs() < 1e-7);
        let before = image.clone();
        composite(&mut image, 0.0);
        assert_eq!(image, before, "exposure 0: nothing added");
    }
}

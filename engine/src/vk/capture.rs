//! Headless capture: read a color image back ([`ImageReadback`]) and write it as PNG (exposure,
//! tone map, sRGB, 8-bit) or EXR (linear float). Files are written to a temporary name in the same
//! folder and renamed, so a reader never sees half a file.
//!
//! ```no_run
//! # use translucent::vk::{Access, Context, Image, ImageReadback};
//! # fn f(ctx: &Context, color: &Image) -> Result<(), translucent::vk::VkError> {
//! let image = ImageReadback::capture(ctx, color, Access::ColorAttachmentWrite)?;
//! image.write_png(std::path::Path::new("out.png"), 1.0)?;
//! image.write_exr(std::path::Path::new("out.exr"))?;
//! # Ok(()) }
//! ```

use std::path::Path;

use ash::vk;

use super::{barrier, Access, Buffer, BufferDesc, Context, Image, MemoryUse, VkError};

/// A linear RGBA float image, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearImage {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 4]>,
}

/// Narkowicz's fit of the ACES filmic curve: maps [0, inf) to [0, 1), keeps mid-tones near linear.
fn tone_map(x: f32) -> f32 {
    // Beyond 1e6 the curve is at its asymptote (2.51/2.43, clamped to 1); avoids inf/inf.
    let x = x.clamp(0.0, 1e6);
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

fn linear_to_srgb(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

impl LinearImage {
    pub fn pixel(&self, x: u32, y: u32) -> [f32; 4] {
        self.pixels[(y * self.width + x) as usize]
    }

    /// 8-bit sRGB RGB after `exposure` (a multiplier) and the tone map; NaN maps to 0.
    pub fn to_srgb8(&self, exposure: f32) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|p| {
                let c = |v: f32| {
                    let v = if v.is_finite() {
                        v * exposure
                    } else if v == f32::INFINITY {
                        1e30
                    } else {
                        0.0
                    };
                    (linear_to_srgb(tone_map(v)) * 255.0)
                        .round()
                        .clamp(0.0, 255.0) as u8
                };
                [c(p[0]), c(p[1]), c(p[2])]
            })
            .collect()
    }

    /// Writes an 8-bit sRGB PNG (exposure + tone map), atomically.
    pub fn write_png(&self, path: &Path, exposure: f32) -> Result<(), VkError> {
        if !exposure.is_finite() || exposure < 0.0 {
            return Err(VkError::invalid(
                "exposure",
                format!("{exposure} is not a finite non-negative number"),
            ));
        }
        let bytes = self.to_srgb8(exposure);
        write_atomically(path, |tmp| {
            image::save_buffer_with_format(
                tmp,
                &bytes,
                self.width,
                self.height,
                image::ColorType::Rgb8,
                image::ImageFormat::Png,
            )
            .map_err(|e| e.to_string())
        })
    }

    /// Writes a linear float RGB EXR (no exposure, no tone map), atomically.
    pub fn write_exr(&self, path: &Path) -> Result<(), VkError> {
        let (w, h) = (self.width as usize, self.height as usize);
        write_atomically(path, |tmp| {
            exr::prelude::write_rgb_file(tmp, w, h, |x, y| {
                let p = self.pixels[y * w + x];
                (p[0], p[1], p[2])
            })
            .map_err(|e| e.to_string())
        })
    }

    /// PNG or EXR by the file extension.
    pub fn write(&self, path: &Path, exposure: f32) -> Result<(), VkError> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("png") => self.write_png(path, exposure),
            Some("exr") => self.write_exr(path),
            _ => Err(VkError::invalid(
                path.display().to_string(),
                "output must end in .png or .exr",
            )),
        }
    }
}

/// Writes through `write(temp path)` then renames onto `path`; removes the temp file on failure.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<(), VkError> {
    let fail = |message: String| VkError::Write {
        path: path.to_path_buf(),
        message,
    };
    let name = path
        .file_name()
        .ok_or_else(|| fail("not a file path".into()))?
        .to_string_lossy()
        .into_owned();
    // Keep the extension last: encoders that look at it still see the right one.
    let tmp = path.with_file_name(format!(
        ".{}.tmp{}-{name}",
        std::process::id(),
        next_tmp_id()
    ));
    // The bytes reach the disk before the name does: after a crash or power loss the real name
    // holds the old file or the complete new one, never an empty or partial one.
    let written = write(&tmp).and_then(|()| {
        std::fs::File::open(&tmp)
            .and_then(|f| f.sync_all())
            .map_err(|e| e.to_string())
    });
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(fail(e));
    }
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        fail(e.to_string())
    })
}

fn next_tmp_id() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

fn texel_size(format: vk::Format) -> Option<u64> {
    match format {
        vk::Format::R16G16B16A16_SFLOAT => Some(8),
        vk::Format::R32G32B32A32_SFLOAT => Some(16),
        vk::Format::R8G8B8A8_UNORM
        | vk::Format::R8G8B8A8_SRGB
        | vk::Format::B8G8R8A8_UNORM
        | vk::Format::B8G8R8A8_SRGB => Some(4),
        vk::Format::D32_SFLOAT => Some(4),
        _ => None,
    }
}

/// A host-visible buffer an image is copied into, and its decoding.
pub struct ImageReadback {
    buffer: Buffer,
    width: u32,
    height: u32,
    format: vk::Format,
}

impl ImageReadback {
    /// A read-back buffer for `image` (RGBA16F, RGBA32F, RGBA8/BGRA8 or D32F).
    pub fn new(ctx: &Context, image: &Image) -> Result<ImageReadback, VkError> {
        let texel = texel_size(image.format).ok_or_else(|| {
            VkError::invalid(
                image.name,
                format!("capture of format {:?} is not supported", image.format),
            )
        })?;
        if !image.usage.contains(vk::ImageUsageFlags::TRANSFER_SRC) {
            return Err(VkError::invalid(
                image.name,
                "capture needs an image created with TRANSFER_SRC usage",
            ));
        }
        let buffer = Buffer::new(
            ctx,
            &BufferDesc {
                name: "capture readback",
                size: u64::from(image.width) * u64::from(image.height) * texel,
                usage: vk::BufferUsageFlags::TRANSFER_DST,
                memory: MemoryUse::Readback,
            },
        )?;
        Ok(ImageReadback {
            buffer,
            width: image.width,
            height: image.height,
            format: image.format,
        })
    }

    /// Records the copy: `image` goes `state -> TransferSrc`, is copied, and returns to `state`.
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope; `image` must be in `state` (not
    /// `Undefined`) and alive until the command buffer completes.
    pub unsafe fn record(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        image: &Image,
        state: Access,
    ) {
        let region = vk::BufferImageCopy::default()
            // Tightly packed rows: the decoder's row pitch is width * texel size.
            .buffer_row_length(0)
            .buffer_image_height(0)
            .image_subresource(
                vk::ImageSubresourceLayers::default()
                    .aspect_mask(image.aspect())
                    .layer_count(1),
            )
            .image_extent(vk::Extent3D {
                width: image.width,
                height: image.height,
                depth: 1,
            });
        // SAFETY: the caller's contract; the buffer is large enough for the tightly packed copy.
        unsafe {
            ctx.begin_label(cb, "capture");
            // why: the copy reads what `state` wrote (RAW) and needs TRANSFER_SRC_OPTIMAL.
            barrier::image(ctx, cb, image, state, Access::TransferSrc);
            ctx.raw().cmd_copy_image_to_buffer(
                cb,
                image.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                self.buffer.raw,
                &[region],
            );
            // why: later passes use the image as before (WAR against the copy, layout back);
            // the host reads the buffer after the fence, so the copy's writes must reach HOST.
            barrier::record(
                ctx,
                cb,
                &[barrier::memory_barrier(
                    Access::TransferDst,
                    Access::HostRead,
                )],
                &[barrier::image_barrier(image, Access::TransferSrc, state)],
            );
            ctx.end_label(cb);
        }
    }

    /// Decodes the copied texels (after the copy's submission completed) into linear RGBA floats.
    pub fn read(&self) -> Result<LinearImage, VkError> {
        let bytes = self.buffer.read_bytes()?;
        let texel = texel_size(self.format).unwrap_or(4) as usize;
        let row_pitch = self.width as usize * texel;
        let mut pixels = Vec::with_capacity((self.width * self.height) as usize);
        for row in bytes.chunks_exact(row_pitch).take(self.height as usize) {
            for t in row.chunks_exact(texel) {
                let f32_at = |i: usize| {
                    f32::from_le_bytes([t[4 * i], t[4 * i + 1], t[4 * i + 2], t[4 * i + 3]])
                };
                let f16_at = |i: usize| half::f16::from_le_bytes([t[2 * i], t[2 * i + 1]]).to_f32();
                let u8_at = |i: usize| f32::from(t[i]) / 255.0;
                let srgb = |v: f32| {
                    if v <= 0.04045 {
                        v / 12.92
                    } else {
                        ((v + 0.055) / 1.055).powf(2.4)
                    }
                };
                pixels.push(match self.format {
                    vk::Format::R16G16B16A16_SFLOAT => [f16_at(0), f16_at(1), f16_at(2), f16_at(3)],
                    vk::Format::R32G32B32A32_SFLOAT => [f32_at(0), f32_at(1), f32_at(2), f32_at(3)],
                    vk::Format::R8G8B8A8_UNORM => [u8_at(0), u8_at(1), u8_at(2), u8_at(3)],
                    vk::Format::B8G8R8A8_UNORM => [u8_at(2), u8_at(1), u8_at(0), u8_at(3)],
                    vk::Format::R8G8B8A8_SRGB => {
                        [srgb(u8_at(0)), srgb(u8_at(1)), srgb(u8_at(2)), u8_at(3)]
                    }
                    vk::Format::B8G8R8A8_SRGB => {
                        [srgb(u8_at(2)), srgb(u8_at(1)), srgb(u8_at(0)), u8_at(3)]
                    }
                    _ => [f32_at(0), f32_at(0), f32_at(0), 1.0],
                });
            }
        }
        Ok(LinearImage {
            width: self.width,
            height: self.height,
            pixels,
        })
    }

    /// Headless: copies `image` (in `state`) back in its own submission and decodes it.
    pub fn capture(ctx: &Context, image: &Image, state: Access) -> Result<LinearImage, VkError> {
        let readback = ImageReadback::new(ctx, image)?;
        ctx.execute("capture", |cb| {
            // SAFETY: `cb` is recording; `image` outlives the waited submission.
            unsafe { readback.record(ctx, cb, image, state) };
            Ok(())
        })?;
        readback.read()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tone_map_is_monotonic_bounded_and_srgb_endpoints_are_exact() {
        let mut last = -1.0;
        for i in 0..1000 {
            let v = tone_map(i as f32 * 0.05);
            assert!(v >= last && (0.0..=1.0).contains(&v));
            last = v;
        }
        let img = LinearImage {
            width: 2,
            height: 1,
            pixels: vec![[0.0, f32::NAN, 1e9, 1.0], [f32::INFINITY, -1.0, 0.0, 1.0]],
        };
        assert_eq!(img.to_srgb8(1.0), vec![0, 0, 255, 255, 0, 0]);
    }

    #[test]
    fn exr_round_trips_linear_values_and_png_has_the_right_size() {
        let dir = std::env::temp_dir().join(format!("translucent-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let pixels: Vec<[f32; 4]> = (0..6)
            .map(|i| [i as f32 * 0.5, 100.0 + i as f32, 1e-3, 1.0])
            .collect();
        let img = LinearImage {
            width: 3,
            height: 2,
            pixels,
        };
        let path = dir.join("x.exr");
        img.write(&path, 1.0).expect("exr");
        let read = exr::prelude::read_first_rgba_layer_from_file(
            &path,
            |res, _| vec![[0.0f32; 3]; res.width() * res.height()],
            |buf, pos, (r, g, b, _a): (f32, f32, f32, f32)| buf[pos.y() * 3 + pos.x()] = [r, g, b],
        )
        .expect("read back");
        for (got, want) in read.layer_data.channel_data.pixels.iter().zip(&img.pixels) {
            assert_eq!(got[..], want[..3]);
        }
        let png = dir.join("x.png");
        img.write(&png, 2.0).expect("png");
        let decoded = image::open(&png).expect("png decodes").to_rgb8();
        assert_eq!(decoded.dimensions(), (3, 2));
        assert_eq!(decoded.as_raw(), &img.to_srgb8(2.0));
        assert!(img.write(&dir.join("x.jpg"), 1.0).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn atomic_write_leaves_nothing_on_failure() {
        let dir = std::env::temp_dir().join(format!("translucent-capture-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let target = dir.join("x.png");
        let err = write_atomically(&target, |tmp| {
            std::fs::write(tmp, b"half").map_err(|e| e.to_string())?;
            Err("encoder failed".into())
        });
        assert!(err.is_err());
        assert_eq!(
            std::fs::read_dir(&dir).expect("read dir").count(),
            0,
            "temp file left behind"
        );
        let _ = std::fs::remove_dir(&dir);
    }
}

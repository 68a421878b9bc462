//! [`MaterialVolume`]: the material as two 3D textures (sigma_s' and sigma_a, RGB in 1/mm) over a
//! box of the object frame, sampled trilinearly by the voxel passes at voxel centres. A
//! homogeneous material is one texel; a `.vol` grid is uploaded as it is (its cells at
//! (i + 0.5) / res of its box, clamped at the border: what [`crate::material::VolGrid::sample`]
//! does); a procedural field is sampled at cell centres of the object's box. An edit stages new
//! texels and the next [`MaterialVolume::record_upload`] copies them: no re-bake, no re-voxelize.
//!
//! The material is a field in the object frame: a deformed mesh moves through it (the grid
//! voxels sample it where they are), it does not carry it along.

use ash::vk;
use glam::{DVec3, Vec3};

use super::bad_param;
use super::sync::ResourceUse;
use crate::material::MaterialField;
use crate::vk::{Access, Buffer, Context, Image, Sampler, VolumeDesc};
use crate::Error;

/// Texel format of the material volumes.
pub const MATERIAL_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// sigma_s' and sigma_a as 3D textures, and the box they cover.
pub struct MaterialVolume {
    pub sigma_s: Image,
    pub sigma_a: Image,
    /// The box the volume covers (mm, object frame).
    pub lo: Vec3,
    pub hi: Vec3,
    /// Trilinear, clamped to the edge (outside the box the border cells repeat).
    pub sampler: Sampler,
    /// Staged texels (sigma_s' then sigma_a) the next upload copies.
    pending: Option<Buffer>,
    /// Incremented whenever the images are replaced (readers allocate new descriptor sets).
    pub generation: u64,
}

fn check_texels(sigma_s: &[[f32; 4]], sigma_a: &[[f32; 4]]) -> Result<(), Error> {
    for (name, texels) in [("sigma_s'", sigma_s), ("sigma_a", sigma_a)] {
        if let Some((i, t)) = texels
            .iter()
            .enumerate()
            .find(|(_, t)| t[..3].iter().any(|v| !v.is_finite() || *v < 0.0))
        {
            return Err(bad_param(
                "material volume",
                format!(
                    "{name} of cell {i} is {:?}: must be finite and >= 0",
                    &t[..3]
                ),
            )
            .into());
        }
    }
    Ok(())
}

/// Texels (rgb, a = 0) of `field` on `res` cell centres of the box (`lo`, `hi`).
fn sample_field(
    field: &MaterialField,
    res: [u32; 3],
    lo: DVec3,
    hi: DVec3,
) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let n = res.iter().map(|&r| r as usize).product();
    let (mut s, mut a) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for z in 0..res[2] {
        for y in 0..res[1] {
            for x in 0..res[0] {
                let cell = DVec3::new(f64::from(x), f64::from(y), f64::from(z)) + 0.5;
                let r = DVec3::new(f64::from(res[0]), f64::from(res[1]), f64::from(res[2]));
                let c = field.sample(lo + (hi - lo) * cell / r);
                s.push(rgba(c.sigma_s));
                a.push(rgba(c.sigma_a));
            }
        }
    }
    (s, a)
}

fn rgba(c: [f64; 3]) -> [f32; 4] {
    [c[0] as f32, c[1] as f32, c[2] as f32, 0.0]
}

impl MaterialVolume {
    /// The volume of `field` over the object's box `bounds` (procedural fields: `resolution` cells
    /// along its longest side).
    pub fn new(
        ctx: &Context,
        field: &MaterialField,
        bounds: (DVec3, DVec3),
        resolution: u32,
    ) -> Result<MaterialVolume, Error> {
        let (res, lo, hi, s, a) = Self::texels(field, bounds, resolution)?;
        Self::from_texels(ctx, res, lo, hi, &s, &a)
    }

    /// A homogeneous volume from raw coefficients: any finite values >= 0, sigma_t' = 0 included
    /// (a [`crate::material::Material`] refuses it; the voxel method stays finite with it).
    pub fn from_coefficients(
        ctx: &Context,
        sigma_s: [f32; 3],
        sigma_a: [f32; 3],
    ) -> Result<MaterialVolume, Error> {
        let s = [sigma_s[0], sigma_s[1], sigma_s[2], 0.0];
        let a = [sigma_a[0], sigma_a[1], sigma_a[2], 0.0];
        Self::from_texels(ctx, [1, 1, 1], Vec3::ZERO, Vec3::ONE, &[s], &[a])
    }

    #[allow(clippy::type_complexity)]
    fn texels(
        field: &MaterialField,
        (lo, hi): (DVec3, DVec3),
        resolution: u32,
    ) -> Result<([u32; 3], Vec3, Vec3, Vec<[f32; 4]>, Vec<[f32; 4]>), Error> {
        if !(lo.is_finite() && hi.is_finite() && (hi - lo).min_element() >= 0.0) {
            return Err(bad_param("material box", format!("{lo} .. {hi} is not a box")).into());
        }
        Ok(match field {
            MaterialField::Homogeneous(m) => (
                [1, 1, 1],
                lo.as_vec3(),
                hi.as_vec3(),
                vec![rgba(m.sigma_s)],
                vec![rgba(m.sigma_a)],
            ),
            MaterialField::Grid { grid, .. } => {
                let (mut s, mut a) = (Vec::new(), Vec::new());
                for cell in grid.data.chunks_exact(6) {
                    s.push([cell[0], cell[1], cell[2], 0.0]);
                    a.push([cell[3], cell[4], cell[5], 0.0]);
                }
                let res = grid.res.map(|r| r as u32);
                (res, grid.bbox_min.as_vec3(), grid.bbox_max.as_vec3(), s, a)
            }
            MaterialField::Procedural { .. } => {
                // A 1% margin: a deformed mesh a little outside its rest box still samples the
                // pattern, not only its clamped border.
                let margin = (hi - lo).max_element() * 0.01;
                let (lo, hi) = (lo - margin, hi + margin);
                let extent = hi - lo;
                let cell = extent.max_element() / f64::from(resolution.max(1));
                let res = [extent.x, extent.y, extent.z]
                    .map(|e| ((e / cell).ceil() as u32).clamp(1, resolution.max(1)));
                let (s, a) = sample_field(field, res, lo, hi);
                (res, lo.as_vec3(), hi.as_vec3(), s, a)
            }
        })
    }

    fn from_texels(
        ctx: &Context,
        res: [u32; 3],
        lo: Vec3,
        hi: Vec3,
        sigma_s: &[[f32; 4]],
        sigma_a: &[[f32; 4]],
    ) -> Result<MaterialVolume, Error> {
        check_texels(sigma_s, sigma_a)?;
        let volume = |name| {
            Image::new_volume(
                ctx,
                &VolumeDesc {
                    name,
                    extent: res,
                    format: MATERIAL_FORMAT,
                    usage: vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
                },
            )
        };
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .max_lod(0.0);
        Ok(MaterialVolume {
            sigma_s: volume("voxel material sigma_s")?,
            sigma_a: volume("voxel material sigma_a")?,
            lo,
            hi,
            sampler: Sampler::new(ctx, "voxel material", &info)?,
            pending: Some(stage(ctx, sigma_s, sigma_a)?),
            generation: 0,
        })
    }

    /// Replaces the material: a volume of the same size re-uploads into its images; another size
    /// makes new images (`generation` changes: readers bind them again). Bad values are a typed
    /// error and change nothing.
    pub fn set_field(
        &mut self,
        ctx: &Context,
        field: &MaterialField,
        bounds: (DVec3, DVec3),
        resolution: u32,
    ) -> Result<(), Error> {
        let (res, lo, hi, s, a) = Self::texels(field, bounds, resolution)?;
        check_texels(&s, &a)?;
        if res != [self.sigma_s.width, self.sigma_s.height, self.sigma_s.depth] {
            let replacement = Self::from_texels(ctx, res, lo, hi, &s, &a)?;
            let generation = self.generation + 1;
            *self = replacement;
            self.generation = generation;
        } else {
            self.pending = Some(stage(ctx, &s, &a)?);
            self.lo = lo;
            self.hi = hi;
        }
        Ok(())
    }

    /// Whether an upload is staged for the next [`Self::record_upload`].
    pub fn upload_pending(&self) -> bool {
        self.pending.is_some()
    }

    /// What the upload writes (only while one is pending): both images as copy destinations.
    /// The staged texels, once their upload was recorded: the caller keeps the buffer alive until
    /// that frame completed.
    pub fn take_pending(&mut self) -> Option<Buffer> {
        self.pending.take()
    }

    pub fn declare_upload(&self) -> Vec<ResourceUse<'_>> {
        if self.pending.is_none() {
            return Vec::new();
        }
        vec![
            ResourceUse::image(&self.sigma_s, Access::TransferDst),
            ResourceUse::image(&self.sigma_a, Access::TransferDst),
        ]
    }

    /// What a reader declares: both images sampled.
    pub fn declare_read(&self) -> Vec<ResourceUse<'_>> {
        vec![
            ResourceUse::image(&self.sigma_s, Access::ShadersSampled),
            ResourceUse::image(&self.sigma_a, Access::ShadersSampled),
        ]
    }

    /// Copies the staged texels into the images (in TRANSFER_DST, as declared). The staging
    /// buffer is released once this frame completes.
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, the images in `Access::TransferDst`.
    pub unsafe fn record_upload(&self, ctx: &Context, cb: vk::CommandBuffer) {
        let Some(staging) = &self.pending else {
            return;
        };
        let bytes = u64::from(self.sigma_s.width)
            * u64::from(self.sigma_s.height)
            * u64::from(self.sigma_s.depth)
            * 16;
        let region = |offset: u64, image: &Image| {
            vk::BufferImageCopy::default()
                .buffer_offset(offset)
                .image_subresource(
                    vk::ImageSubresourceLayers::default()
                        .aspect_mask(vk::ImageAspectFlags::COLOR)
                        .layer_count(1),
                )
                .image_extent(vk::Extent3D {
                    width: image.width,
                    height: image.height,
                    depth: image.depth,
                })
        };
        // SAFETY: the caller's contract; the staging buffer holds both volumes' texels and is
        // retired only after this frame completes.
        unsafe {
            ctx.begin_label(cb, "voxel material upload");
            ctx.raw().cmd_copy_buffer_to_image(
                cb,
                staging.raw,
                self.sigma_s.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region(0, &self.sigma_s)],
            );
            ctx.raw().cmd_copy_buffer_to_image(
                cb,
                staging.raw,
                self.sigma_a.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region(bytes, &self.sigma_a)],
            );
            ctx.end_label(cb);
        }
    }
}

fn stage(ctx: &Context, sigma_s: &[[f32; 4]], sigma_a: &[[f32; 4]]) -> Result<Buffer, Error> {
    let data: Vec<[f32; 4]> = sigma_s.iter().chain(sigma_a).copied().collect();
    Ok(Buffer::with_data(
        ctx,
        "voxel material staging",
        vk::BufferUsageFlags::TRANSFER_SRC,
        &data,
    )?)
}

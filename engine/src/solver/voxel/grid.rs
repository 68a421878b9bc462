//! The voxel grid's dimensions and the per-voxel volumes every pass shares ([`VoxelGrid`]).
//!
//! The dims are fixed when the object is created: N voxels along the rest pose's longest side plus
//! one empty voxel of margin on each side. The origin and the voxel size h are fitted on the GPU
//! every frame to the mesh's current bounds ([`super::VoxelizePass`] writes a [`GridFrame`]), so a
//! deformed or fractured mesh is always covered; if it grows beyond its rest box, h grows with it.

use ash::vk;
use glam::{DVec3, Vec3};

use super::bad_param;
use crate::solver::SolverError;
use crate::vk::{
    barrier, Access, Buffer, BufferDesc, Context, Image, ImageState, MemoryUse, Sampler, VolumeDesc,
};
use crate::Error;

/// The format of every per-voxel volume (rgb per colour channel, a per pass).
pub const GRID_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// The grid of one frame, as `voxel/fit_grid.comp` writes it (std430, `include/voxel_grid.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GridFrame {
    /// xyz: corner of voxel (0, 0, 0), mm; w: voxel size h, mm.
    pub origin: [f32; 4],
    /// xyz: the mesh's bounds (min); w: finite vertices counted.
    pub lo: [f32; 4],
    /// xyz: the mesh's bounds (max).
    pub hi: [f32; 4],
    /// xyz: voxels per axis; w: voxel count.
    pub dims: [u32; 4],
}

impl GridFrame {
    /// The voxel size, mm.
    pub fn h(&self) -> f32 {
        self.origin[3]
    }

    /// The centre of voxel `v` (f32, as the shaders compute it).
    pub fn centre(&self, v: [u32; 3]) -> Vec3 {
        Vec3::from_slice(&self.origin[..3])
            + (Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32) + 0.5) * self.h()
    }
}

/// Voxels per axis, fixed for an object's life.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridDims {
    /// Voxels along x, y, z, margins included.
    pub dims: [u32; 3],
    /// Voxels along the rest pose's longest side (the `--voxels` N).
    pub voxels: u32,
    /// h of the rest pose, mm.
    pub rest_h: f64,
}

impl GridDims {
    /// N voxels along the longest side of the box (`lo`, `hi`), the other sides rounded up, one
    /// voxel of margin on each side.
    pub fn new(lo: DVec3, hi: DVec3, voxels: u32) -> Result<GridDims, SolverError> {
        super::check_voxels(voxels)?;
        let extent = hi - lo;
        let longest = extent.max_element();
        if !(lo.is_finite() && hi.is_finite() && longest > 0.0 && extent.min_element() >= 0.0) {
            return Err(bad_param(
                "mesh bounds",
                format!("{lo} .. {hi} is not a finite, non-empty box"),
            ));
        }
        let h = longest / f64::from(voxels);
        // 1e-9: a side equal to the longest gets exactly N, not N + 1 from rounding.
        let along = |e: f64| ((e / h - 1e-9).ceil().max(1.0) as u32) + 2;
        Ok(GridDims {
            dims: [along(extent.x), along(extent.y), along(extent.z)],
            voxels,
            rest_h: h,
        })
    }

    /// Voxels in the grid.
    pub fn count(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

    /// Linear index of voxel `v` (x fastest), as `voxel_index` in the shaders.
    pub fn index(&self, v: [u32; 3]) -> usize {
        v[0] as usize
            + self.dims[0] as usize * (v[1] as usize + self.dims[1] as usize * v[2] as usize)
    }

    /// The voxel of linear index `i`.
    pub fn coord(&self, i: usize) -> [u32; 3] {
        let (x, y) = (self.dims[0] as usize, self.dims[1] as usize);
        [(i % x) as u32, ((i / x) % y) as u32, (i / (x * y)) as u32]
    }

    /// `[dims.x, dims.y, dims.z, count]` as the push constants carry them.
    pub fn push(&self) -> [u32; 4] {
        [
            self.dims[0],
            self.dims[1],
            self.dims[2],
            self.count() as u32,
        ]
    }
}

/// The per-voxel volumes of one object: every pass reads or writes some of them (each declares
/// which). All RGBA32F 3D images in GENERAL layout; `exit` is also sampled (trilinear).
pub struct VoxelGrid {
    pub dims: GridDims,
    /// The fitted grid of this frame ([`GridFrame`]); host-visible so a report can read it.
    pub frame: Buffer,
    /// rgb: the model's per-mm cost coefficient; a: 1 solid, 0 empty.
    pub medium: Image,
    /// rgb: n0 = -ln q at lit surface voxels, N_UNLIT (1e30) elsewhere.
    pub seed: Image,
    /// rgb: optical depth n, ping and pong; the relaxation leaves the result in `state[0]`.
    pub state: [Image; 2],
    /// rgb: the chosen path's length d (mm), ping and pong; 1x1x1 placeholders when the model
    /// carries no path.
    pub path: [Image; 2],
    /// rgb: D = 1 / (3 sigma_t') per channel (the diffusion model's exit profile); 1x1x1
    /// placeholder otherwise.
    pub transport: Image,
    /// rgb: J+ of solid voxels, a = 1 (0 for empty ones): premultiplied coverage.
    pub exit: Image,
    /// Trilinear, clamped to the edge: reads `exit` at the display vertices.
    pub sampler: Sampler,
    pub track_path: bool,
}

impl VoxelGrid {
    pub fn new(ctx: &Context, dims: GridDims, track_path: bool) -> Result<VoxelGrid, Error> {
        if !ctx.format_supports(
            GRID_FORMAT,
            vk::FormatFeatureFlags::STORAGE_IMAGE
                | vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR,
        ) {
            return Err(bad_param(
                "device",
                "RGBA32F is not a linearly filtered storage format here (the voxel method needs it)",
            )
            .into());
        }
        let volume = |name: &'static str, extent: [u32; 3], sampled: bool| {
            let mut usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
            if sampled {
                usage |= vk::ImageUsageFlags::SAMPLED;
            }
            Image::new_volume(
                ctx,
                &VolumeDesc {
                    name,
                    extent,
                    format: GRID_FORMAT,
                    usage,
                },
            )
        };
        let d = dims.dims;
        let path_extent = if track_path { d } else { [1, 1, 1] };
        let frame = Buffer::new(
            ctx,
            &BufferDesc {
                name: "voxel grid frame",
                size: std::mem::size_of::<GridFrame>() as u64,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER,
                memory: MemoryUse::Readback,
            },
        )?;
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .max_lod(0.0);
        Ok(VoxelGrid {
            dims,
            frame,
            medium: volume("voxel medium", d, false)?,
            seed: volume("voxel seed", d, false)?,
            state: [
                volume("voxel state ping", d, false)?,
                volume("voxel state pong", d, false)?,
            ],
            path: [
                volume("voxel path ping", path_extent, false)?,
                volume("voxel path pong", path_extent, false)?,
            ],
            transport: volume("voxel transport", path_extent, false)?,
            exit: volume("voxel exit", d, true)?,
            sampler: Sampler::new(ctx, "voxel trilinear", &info)?,
            track_path,
        })
    }

    /// GPU memory of the volumes and the frame record, bytes.
    pub fn bytes(&self) -> u64 {
        let volume = |i: &Image| u64::from(i.width) * u64::from(i.height) * u64::from(i.depth) * 16;
        [
            &self.medium,
            &self.seed,
            &self.state[0],
            &self.state[1],
            &self.path[0],
            &self.path[1],
            &self.transport,
            &self.exit,
        ]
        .iter()
        .map(|i| volume(i))
        .sum::<u64>()
            + self.frame.size
    }

    /// Headless, after the frame's submission completed: the grid the GPU fitted.
    pub fn read_frame(&self, ctx: &Context) -> Result<GridFrame, Error> {
        host_sync(ctx)?;
        Ok(bytemuck::pod_read_unaligned(
            &self.frame.read_bytes()?[..std::mem::size_of::<GridFrame>()],
        ))
    }

    /// Headless, after the frame's submission completed: every texel of one of the grid's
    /// volumes (x fastest), from the state its last use left (the image's tracked state, which
    /// it returns to).
    pub fn read_volume(&self, ctx: &Context, image: &Image) -> Result<Vec<[f32; 4]>, Error> {
        let tracked = image.tracked();
        let texels = u64::from(image.width) * u64::from(image.height) * u64::from(image.depth);
        let readback = Buffer::new(
            ctx,
            &BufferDesc {
                name: "voxel volume readback",
                size: texels * 16,
                usage: vk::BufferUsageFlags::TRANSFER_DST,
                memory: MemoryUse::Readback,
            },
        )?;
        let region = vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default()
                    .aspect_mask(vk::ImageAspectFlags::COLOR)
                    .layer_count(1),
            )
            .image_extent(vk::Extent3D {
                width: image.width,
                height: image.height,
                depth: image.depth,
            });
        if tracked.layout == vk::ImageLayout::UNDEFINED {
            return Err(
                bad_param("read_volume", format!("{} was never written", image.name)).into(),
            );
        }
        let from = ImageState {
            stage: tracked.write_stage | tracked.read_stage,
            access: tracked.write_access,
            layout: tracked.layout,
        };
        let src: ImageState = Access::TransferSrc.into();
        ctx.execute("voxel volume readback", |cb| {
            // SAFETY: `cb` is recording; the image and buffer outlive the waited submission.
            unsafe {
                // why: the copy reads what the passes wrote (RAW), in TRANSFER_SRC layout.
                barrier::record(
                    ctx,
                    cb,
                    &[],
                    &[barrier::raw_image_barrier(
                        image.raw,
                        image.format,
                        from,
                        src,
                    )],
                );
                ctx.raw().cmd_copy_image_to_buffer(
                    cb,
                    image.raw,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    readback.raw,
                    &[region],
                );
                // why: the image goes back to where the passes expect it (layout, WAR against the
                // copy); the host reads the buffer after the fence.
                barrier::record(
                    ctx,
                    cb,
                    &[barrier::memory_barrier(
                        Access::TransferDst,
                        Access::HostRead,
                    )],
                    &[barrier::raw_image_barrier(
                        image.raw,
                        image.format,
                        src,
                        from,
                    )],
                );
            }
            Ok(())
        })?;
        let bytes = readback.read_bytes()?;
        Ok(bytes
            .chunks_exact(16)
            .map(bytemuck::pod_read_unaligned::<[f32; 4]>)
            .collect())
    }
}

/// Headless: makes the compute passes' writes to host-visible buffers visible to the host.
pub fn host_sync(ctx: &Context) -> Result<(), Error> {
    ctx.execute("voxel host sync", |cb| {
        // SAFETY: `cb` is recording.
        unsafe {
            // why: the CPU reads buffers the compute passes wrote (RAW across the host boundary).
            barrier::memory(ctx, cb, Access::ComputeWrite, Access::HostRead);
        }
        Ok(())
    })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dims_put_n_voxels_on_the_longest_side_and_a_margin_around() {
        let g = GridDims::new(
            DVec3::new(-10.0, -5.0, -2.5),
            DVec3::new(10.0, 5.0, 2.5),
            40,
        )
        .unwrap();
        assert_eq!(g.dims, [42, 22, 12]);
        assert_eq!(g.rest_h, 0.5);
        assert_eq!(g.count(), 42 * 22 * 12);
        for i in [0, 1, 41, 42, 1000, g.count() - 1] {
            assert_eq!(g.index(g.coord(i)), i);
        }
        let flat = GridDims::new(DVec3::ZERO, DVec3::new(10.0, 0.0, 10.0), 8).unwrap();
        assert_eq!(flat.dims, [10, 3, 10]);
        assert!(GridDims::new(DVec3::ZERO, DVec3::ZERO, 8).is_err());
        assert!(GridDims::new(DVec3::ZERO, DVec3::splat(f64::NAN), 8).is_err());
        assert!(GridDims::new(DVec3::ZERO, DVec3::ONE, 2).is_err());
    }
}

//! [`LaplaceJacobiPass`]: ping-pong Jacobi sweeps of the 2D Laplace equation on two RGBA16F
//! storage images, the smallest end-to-end compute path (upload, reflection-checked pipeline,
//! one memory barrier per iteration, read-back). It is the pattern the QuadGraph solver's
//! iteration loop (DESIGN section 5) follows.
//!
//! With Dirichlet values of a linear function on the border, the exact discrete solution is that
//! linear function (a linear function equals the mean of its four neighbours).
//!
//! ```no_run
//! # use translucent::render::LaplaceJacobiPass;
//! # fn f(ctx: &translucent::vk::Context) -> Result<(), translucent::render::RenderError> {
//! let mut pass = LaplaceJacobiPass::new(ctx, 17, 17)?;
//! let initial = vec![[0.0f32; 4]; 17 * 17]; // border texels hold the boundary values
//! pass.upload(ctx, &initial)?;
//! let result = pass.run(ctx, 1000)?;
//! # Ok(()) }
//! ```

use ash::vk;

use super::RenderError;
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite};
use crate::vk::{
    barrier, Access, Buffer, Context, GpuProfiler, Image, ImageDesc, ImageReadback, LinearImage,
};

/// Push constants of `laplace/jacobi_step.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct JacobiPush {
    pub size: [i32; 2],
}

/// Two RGBA16F images and the Jacobi pipeline; iteration `k` reads image `k % 2`, writes the other.
pub struct LaplaceJacobiPass {
    pipeline: ComputePipeline<JacobiPush>,
    images: [Image; 2],
    /// `sets[k]` reads `images[k]` and writes `images[1 - k]`.
    sets: [vk::DescriptorSet; 2],
    width: u32,
    height: u32,
    /// Which image holds the latest values.
    latest: usize,
}

impl LaplaceJacobiPass {
    pub fn new(ctx: &Context, width: u32, height: u32) -> Result<Self, RenderError> {
        if width < 3 || height < 3 {
            return Err(RenderError::Invalid {
                what: "Laplace grid".into(),
                problem: format!("{width}x{height} has no interior; need at least 3x3"),
            });
        }
        let pipeline = ComputePipeline::<JacobiPush>::new(
            ctx,
            &ComputePipelineDesc {
                name: "jacobi step",
                shader: "laplace/jacobi_step.comp",
                bindings: &["src", "dst"],
                max_sets: 2,
            },
        )?;
        let desc = |name| ImageDesc {
            name,
            width,
            height,
            format: vk::Format::R16G16B16A16_SFLOAT,
            usage: vk::ImageUsageFlags::STORAGE
                | vk::ImageUsageFlags::TRANSFER_DST
                | vk::ImageUsageFlags::TRANSFER_SRC,
        };
        let images = [
            Image::new(ctx, &desc("jacobi ping"))?,
            Image::new(ctx, &desc("jacobi pong"))?,
        ];
        let sets = [
            pipeline.allocate_set(
                ctx,
                &[
                    DescriptorWrite::storage_image("src", &images[0]),
                    DescriptorWrite::storage_image("dst", &images[1]),
                ],
            )?,
            pipeline.allocate_set(
                ctx,
                &[
                    DescriptorWrite::storage_image("src", &images[1]),
                    DescriptorWrite::storage_image("dst", &images[0]),
                ],
            )?,
        ];
        Ok(LaplaceJacobiPass {
            pipeline,
            images,
            sets,
            width,
            height,
            latest: 0,
        })
    }

    /// Headless: uploads `values` (row-major RGBA, row 0 first; border texels are the boundary
    /// values) into the first image and leaves both images in GENERAL.
    pub fn upload(&mut self, ctx: &Context, values: &[[f32; 4]]) -> Result<(), RenderError> {
        let expected = (self.width * self.height) as usize;
        if values.len() != expected {
            return Err(RenderError::Invalid {
                what: "Laplace initial values".into(),
                problem: format!(
                    "{} texels for a {}x{} grid",
                    values.len(),
                    self.width,
                    self.height
                ),
            });
        }
        if values
            .iter()
            .flatten()
            .any(|v| !v.is_finite() || v.abs() > 65504.0)
        {
            return Err(RenderError::Invalid {
                what: "Laplace initial values".into(),
                problem: "not finite in fp16 range".into(),
            });
        }
        let halves: Vec<half::f16> = values
            .iter()
            .flatten()
            .map(|&v| half::f16::from_f32(v))
            .collect();
        let staging = Buffer::with_data(
            ctx,
            "jacobi upload",
            vk::BufferUsageFlags::TRANSFER_SRC,
            &halves,
        )?;
        let [ping, pong] = &self.images;
        ctx.execute("jacobi upload", |cb| {
            // SAFETY: `cb` is recording; images and staging outlive the waited submission.
            unsafe {
                // why: the copy writes the whole image; earlier contents are discarded (layout).
                barrier::image(ctx, cb, ping, Access::Undefined, Access::TransferDst);
                ping.record_upload_from(ctx, cb, &staging);
                barrier::record(
                    ctx,
                    cb,
                    &[],
                    &[
                        // why: the first sweep reads the uploaded values (RAW) in GENERAL.
                        barrier::image_barrier(ping, Access::TransferDst, Access::ComputeReadWrite),
                        // why: the first sweep writes pong in GENERAL; its old contents are unused.
                        barrier::image_barrier(pong, Access::Undefined, Access::ComputeReadWrite),
                    ],
                );
            }
            Ok(())
        })?;
        self.latest = 0;
        Ok(())
    }

    /// Records `iterations` sweeps, one memory barrier each; returns the image index holding the
    /// result. Both images stay in GENERAL; the last writes are in state [`Access::ComputeWrite`].
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, after [`LaplaceJacobiPass::upload`]'s
    /// submission; the pass must outlive `cb`'s execution.
    pub unsafe fn record(
        &mut self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        iterations: u32,
        mut profiler: Option<&mut GpuProfiler>,
    ) -> usize {
        let push = JacobiPush {
            size: [self.width as i32, self.height as i32],
        };
        // SAFETY: the caller's contract (recording `cb`, live pass).
        unsafe {
            ctx.begin_label(cb, "jacobi");
            if let Some(p) = profiler.as_deref_mut() {
                p.begin_scope(cb, "jacobi");
            }
            for _ in 0..iterations {
                // why: this sweep reads what the previous one wrote (RAW) and overwrites what the
                // one before read (WAR): compute write -> compute read|write, no layout change.
                barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeReadWrite);
                self.pipeline.dispatch(
                    ctx,
                    cb,
                    self.sets[self.latest],
                    &push,
                    [self.width, self.height, 1],
                );
                self.latest = 1 - self.latest;
            }
            if let Some(p) = profiler {
                p.end_scope(cb);
            }
            ctx.end_label(cb);
        }
        self.latest
    }

    /// Headless: runs `iterations` sweeps and reads the result back.
    pub fn run(&mut self, ctx: &Context, iterations: u32) -> Result<LinearImage, RenderError> {
        let readback = ImageReadback::new(ctx, &self.images[0])?;
        ctx.execute("jacobi", |cb| {
            // SAFETY: `cb` is recording; `self` outlives the waited submission.
            unsafe {
                let latest = self.record(ctx, cb, iterations, None);
                readback.record(ctx, cb, &self.images[latest], Access::ComputeWrite);
            }
            Ok(())
        })?;
        Ok(readback.read()?)
    }
}

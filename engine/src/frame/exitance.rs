//! [`FixedExitance`]: a method whose surface exitance is given per display vertex (the f64 CPU
//! reference solver's output, or a test fixture such as [`crate::render::lambert_exitance`]). It
//! records nothing unless new values were set ([`FixedExitance::set_exitance`]), which it
//! copies into the display mesh's exitance field in one pass.

use std::sync::Arc;

use ash::vk;
use glam::DVec3;

use super::graph::FrameGraph;
use super::method::{Method, MethodFrame};
use super::plan::MethodWork;
use super::report::{CompletedSolve, SkipReason};
use crate::material::MaterialField;
use crate::mesh::{GpuMesh, Vertex};
use crate::render::ShadowMaps;
use crate::scene::Scene;
use crate::solver::gpu::Deformation;
use crate::vk::barrier::Use;
use crate::vk::{Access, Buffer, Context, VkError};
use crate::Error;

/// The pass copying new per-vertex exitance into the display mesh.
pub const PASS_EXITANCE_UPLOAD: &str = "exitance upload";

/// Exitance given per vertex (see the module doc).
pub struct FixedExitance {
    mesh: Arc<GpuMesh>,
    /// New values waiting for the next frame, and the ones being copied this frame.
    staged: Option<Buffer>,
    recording: Option<Buffer>,
    /// The per-node exit lobe's diffused share per vertex (16 bytes each, the share in the 4th
    /// float; [`Method::exit_share`]): the one the shading reads, one waiting for the next
    /// frame, and the one the last frame read (released a frame later).
    share: Option<Buffer>,
    share_staged: Option<Buffer>,
    share_retired: Option<Buffer>,
}

fn unsupported(what: &str) -> Error {
    VkError::InvalidArgument {
        what: "fixed exitance".into(),
        problem: format!("{what}: the exitance is given, not computed (use the quadgraph method)"),
    }
    .into()
}

impl FixedExitance {
    /// `mesh` already holds the exitance (`GpuMesh::new` with the values).
    pub fn new(mesh: Arc<GpuMesh>) -> FixedExitance {
        FixedExitance {
            mesh,
            staged: None,
            recording: None,
            share: None,
            share_staged: None,
            share_retired: None,
        }
    }

    /// The per-node exit lobe's diffused share per vertex (as many as the mesh has; each in
    /// [0, 1], e.g. [`crate::solver::CpuSolution::vertex_diffused_share`]), read from the next
    /// frame on by [`crate::scene::ExitLobe::Node`].
    pub fn set_diffused_share(&mut self, ctx: &Context, share: &[f32]) -> Result<(), Error> {
        if share.len() != self.mesh.vertex_count() {
            return Err(VkError::invalid(
                "diffused share",
                format!(
                    "{} values for {} vertices",
                    share.len(),
                    self.mesh.vertex_count()
                ),
            )
            .into());
        }
        if let Some(v) = share.iter().position(|s| !(0.0..=1.0).contains(s)) {
            return Err(VkError::invalid(
                "diffused share",
                format!("vertex {v}: {} is not in [0, 1]", share[v]),
            )
            .into());
        }
        let rows: Vec<[f32; 4]> = share.iter().map(|&s| [0.0, 0.0, 0.0, s]).collect();
        self.share_staged = Some(Buffer::with_data(
            ctx,
            "exit lobe share",
            vk::BufferUsageFlags::VERTEX_BUFFER,
            &rows,
        )?);
        Ok(())
    }

    /// New exitance J+ per vertex (as many as the mesh has; finite), drawn from the next frame.
    pub fn set_exitance(&mut self, ctx: &Context, exitance: &[[f32; 3]]) -> Result<(), Error> {
        if exitance.len() != self.mesh.vertex_count() {
            return Err(VkError::invalid(
                "exitance",
                format!(
                    "{} values for {} vertices",
                    exitance.len(),
                    self.mesh.vertex_count()
                ),
            )
            .into());
        }
        if let Some(v) = exitance
            .iter()
            .position(|e| !e.iter().all(|x| x.is_finite()))
        {
            return Err(VkError::invalid("exitance", format!("vertex {v} is not finite")).into());
        }
        self.staged = Some(Buffer::with_data(
            ctx,
            "exitance staging",
            vk::BufferUsageFlags::TRANSFER_SRC,
            exitance,
        )?);
        Ok(())
    }
}

impl Method for FixedExitance {
    fn name(&self) -> &'static str {
        "fixed exitance"
    }
    fn set_lights(&mut self, _: &Scene, _: &ShadowMaps) -> Result<(), Error> {
        // The lights only reach the shading (specular, its shadow); the exitance is given.
        Ok(())
    }
    fn set_material(&mut self, _: &Context, _: &MaterialField) -> Result<(), Error> {
        Err(unsupported("a new material"))
    }
    fn deform(&mut self, _: &Context, _: &Deformation) -> Result<(DVec3, f64), Error> {
        Err(unsupported("a deformation"))
    }
    fn has_solution(&self) -> bool {
        true
    }
    fn reads_shadows(&self) -> bool {
        false
    }
    fn material_variant(&self) -> &'static str {
        "none"
    }
    fn prepare(&mut self, _: MethodWork, _: u64) -> Result<MethodFrame, Error> {
        // The last frame's staging buffer is released once that frame completed.
        self.recording = self.staged.take();
        self.share_retired = match self.share_staged.take() {
            Some(new) => self.share.replace(new),
            None => None,
        };
        let mut out = MethodFrame::default();
        if self.recording.is_none() {
            out.skipped
                .push((PASS_EXITANCE_UPLOAD, SkipReason::Precomputed));
        }
        Ok(out)
    }
    fn add_edit_passes<'g>(&'g self, _: &mut FrameGraph<'g>) {}
    fn add_passes<'g>(
        &'g self,
        graph: &mut FrameGraph<'g>,
        _: &'g ShadowMaps,
    ) -> Result<(), Error> {
        let Some(values) = &self.recording else {
            return Ok(());
        };
        let mesh = self.mesh.vertex_buffer();
        graph
            .pass(PASS_EXITANCE_UPLOAD)
            .uses([
                Use::buffer(values, Access::TransferSrc),
                Use::buffer(mesh, Access::TransferDst),
            ])
            .record(move |p| {
                let stride = std::mem::size_of::<Vertex>() as u64;
                let offset = std::mem::offset_of!(Vertex, exitance) as u64;
                let regions: Vec<vk::BufferCopy> = (0..self.mesh.vertex_count() as u64)
                    .map(|v| {
                        vk::BufferCopy::default()
                            .src_offset(v * 12)
                            .dst_offset(v * stride + offset)
                            .size(12)
                    })
                    .collect();
                // SAFETY: inside the pass declaring both buffers; they outlive the frame.
                unsafe {
                    p.ctx
                        .raw()
                        .cmd_copy_buffer(p.cb, values.raw, mesh.raw, &regions)
                };
                Ok(())
            });
        Ok(())
    }
    fn completed(&mut self, _: u64) -> Result<Vec<CompletedSolve>, Error> {
        Ok(Vec::new())
    }
    fn gpu_bytes(&self) -> u64 {
        0
    }
    fn exit_share(&self) -> Option<&Buffer> {
        self.share.as_ref()
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }
}

//! [`SolveBytes`]: where a GPU solve's memory goes, per kind of resource (issue 13 item 4).
//!
//! Every image and buffer of a [`super::GpuDiffusion`] is counted once, in one field, at its
//! allocated size (texels times the format's bytes, buffers' sizes), so the fields add up to
//! [`super::GpuDiffusion::bytes`]'s total.
//!
//! ```
//! use translucent::solver::gpu::SolveBytes;
//! let b = SolveBytes { state: 48, rhs: 8, graph: 32, links: 32, ..SolveBytes::default() };
//! assert_eq!(b.textures(), 120);
//! assert_eq!(b.total(), b.textures() + b.surface_shading() + b.multigrid + b.other());
//! ```

use ash::vk;

use super::{edit, multigrid, GpuDiffusion, GpuLevel};
use crate::vk::Image;

/// GPU bytes of one solve by what they hold (see the module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SolveBytes {
    /// The iteration state of the levels: ping-pong images, phi and the fp32 residual (mixed),
    /// the coarse levels' saved phi (warm start).
    pub state: u64,
    /// q per level (the gather's output, the solve's right-hand side).
    pub rhs: u64,
    /// The graph: connectivity and geometric factors.
    pub graph: u64,
    /// Heterogeneous (or deformed) materials: fv fractions, per-node kappa and mu, derived
    /// per-channel weights.
    pub material: u64,
    /// Shepard links between levels (indices and weights).
    pub links: u64,
    /// The gather's surface textures: positions, normals, the collimated source's particular
    /// part (surface rows of every level).
    pub surface: u64,
    /// Shading: J+ (finest surface rows), the display vertices' links, weights and exitance, the
    /// interior reconstruction's samples.
    pub shading: u64,
    /// The multigrid schedule's hierarchy ([`super::multigrid::GpuMultigrid::bytes`]).
    pub multigrid: u64,
    /// Deformation data (tetrahedron vertices, rest copies; created by the first deformation).
    pub deform: u64,
    /// Control records, clamp counters, placeholders.
    pub control: u64,
}

impl SolveBytes {
    /// The QuadGraph solve's level textures (state, rhs, graph, material, links).
    pub fn textures(&self) -> u64 {
        self.state + self.rhs + self.graph + self.material + self.links
    }

    /// Neither textures, surface nor multigrid: deformation data and control.
    pub fn other(&self) -> u64 {
        self.deform + self.control
    }

    /// Surface textures and shading (`render --json`'s `surface_shading`).
    pub fn surface_shading(&self) -> u64 {
        self.surface + self.shading
    }

    pub fn total(&self) -> u64 {
        self.textures() + self.surface_shading() + self.multigrid + self.other()
    }
}

impl std::ops::AddAssign for SolveBytes {
    fn add_assign(&mut self, o: SolveBytes) {
        self.state += o.state;
        self.rhs += o.rhs;
        self.graph += o.graph;
        self.material += o.material;
        self.links += o.links;
        self.surface += o.surface;
        self.shading += o.shading;
        self.multigrid += o.multigrid;
        self.deform += o.deform;
        self.control += o.control;
    }
}

impl GpuLevel {
    /// GPU bytes of this level's textures and buffers, by kind ([`SolveBytes`]).
    pub(super) fn bytes(&self) -> SolveBytes {
        let sum = |images: &mut dyn Iterator<Item = &Image>| images.map(image_bytes).sum::<u64>();
        SolveBytes {
            state: sum(&mut self
                .state
                .iter()
                .chain(&self.phi)
                .chain(&self.residual)
                .chain(&self.saved)),
            rhs: image_bytes(&self.q),
            graph: image_bytes(&self.connectivity) + image_bytes(&self.geo),
            material: sum(&mut self
                .frac
                .iter()
                .chain(self.material.iter().flatten())
                .chain(self.weights.iter().flatten())),
            links: sum(&mut self.links.iter()),
            surface: sum(&mut [
                &self.surface_position,
                &self.surface_normal,
                &self.surface_anisotropy,
                &self.particular,
            ]
            .into_iter()),
            deform: self.deform.as_ref().map_or(0, edit::LevelDeform::bytes),
            ..SolveBytes::default()
        }
    }
}

impl GpuDiffusion {
    /// GPU bytes of level `level`'s textures (state, q, graph, material, links, surface geometry).
    pub fn level_bytes(&self, level: usize) -> u64 {
        self.levels.get(level).map_or(0, |l| l.bytes().total())
    }

    /// (total bytes, bytes per node) over all levels, beside the paper's ~90 bytes per node.
    /// Per node counts the nodes of every level ([`Self::bytes_breakdown`] has the parts).
    pub fn bytes(&self) -> (u64, f64) {
        let total = self.bytes_breakdown().total();
        let nodes: usize = self.levels.iter().map(|l| l.node_count).sum();
        (total, total as f64 / nodes.max(1) as f64)
    }

    /// The multigrid hierarchy's bytes per buffer ([`multigrid::GpuMultigrid::bytes_by_buffer`];
    /// empty under the cascade): they sum to [`SolveBytes::multigrid`].
    pub fn multigrid_bytes_by_buffer(&self) -> Vec<(&'static str, u64)> {
        self.multigrid
            .as_ref()
            .map_or_else(Vec::new, |m| m.bytes_by_buffer().to_vec())
    }

    /// Every GPU byte of this solve, by kind (the fields add up to [`Self::bytes`]'s total).
    pub fn bytes_breakdown(&self) -> SolveBytes {
        let mut out = SolveBytes::default();
        for l in &self.levels {
            out += l.bytes();
        }
        out.shading = image_bytes(&self.j_plus)
            + self.vertex_links.size
            + self.vertex_weights.size
            + self.vertex_j_plus.size
            + self
                .interior
                .as_ref()
                .map_or(0, |i| i.nodes.size + i.weights.size + i.cells.size);
        out.multigrid = self
            .multigrid
            .as_ref()
            .map_or(0, multigrid::GpuMultigrid::bytes);
        out.deform += self.edits.mesh_bytes();
        out.control = self.control.size + self.clamp_counts.size + image_bytes(&self.poison);
        out
    }
}

/// Allocated bytes of a 2D image.
pub(super) fn image_bytes(i: &Image) -> u64 {
    u64::from(i.width) * u64::from(i.height) * texel_bytes(i.format)
}

pub(super) fn texel_bytes(format: vk::Format) -> u64 {
    match format {
        vk::Format::R16G16B16A16_SFLOAT => 8,
        vk::Format::R32_UINT | vk::Format::R32_SFLOAT => 4,
        _ => 16,
    }
}

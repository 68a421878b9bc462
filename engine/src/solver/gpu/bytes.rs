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

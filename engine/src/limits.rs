//! Resource limits on hostile input (issue 17): the sizes a mesh, a `.vol` grid, a cache file or a
//! bake or an environment map may reach, each checked BEFORE the memory it implies is allocated, each refused with a
//! [`LimitExceeded`] that names the limit and how to raise it.
//!
//! The defaults fit a 16 GB machine with room to spare and are far above every mesh, grid and bake
//! we ship or test (the largest mesh in `../shared/meshes`, nefertiti, has 100k triangles; a
//! 512-cell bake of a sphere about 5 M lattice nodes). Each can be raised (or lowered) per process
//! with an environment variable, or in code through the [`Limits`] a reader takes:
//!
//! ```
//! use translucent::limits::{Limit, Limits};
//! let defaults = Limits::default();
//! assert_eq!(defaults.get(Limit::Triangles), 32_000_000);
//! // What `TriMesh::load_obj`, `VolGrid::read`, `QuadGraph::load` and `BakeParams::default` use:
//! // the defaults overridden by TRANSLUCENT_MAX_TRIANGLES and friends where those are set.
//! let limits = Limits::from_env();
//! let tight = Limits { max_triangles: 1_000, ..limits };
//! assert!(tight.check(Limit::Triangles, 1_001).is_err());
//! assert!(tight.check(Limit::Triangles, 1_000).is_ok());
//! ```

use std::fmt;

/// One bounded resource.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Limit {
    /// `v` lines of an OBJ file (and vertices of a mesh).
    Vertices,
    /// Triangles of an OBJ file after fan triangulation of its polygons.
    Triangles,
    /// Bytes of an OBJ or cache file, checked before it is read.
    FileBytes,
    /// Voxels of a `.vol` grid (xres * yres * zres), checked before its data is read.
    VolVoxels,
    /// Cells along any one axis of a `.vol` grid.
    VolAxis,
    /// Nodes of one level's background lattice in the bake, estimated before it is built.
    LatticeNodes,
    /// Points sampled on the surface to seed the bake's lattice (one per half lattice spacing on
    /// every triangle: a few large triangles at a fine resolution make many).
    SurfaceSamples,
    /// Texels (width * height) of an EXR environment map, checked from its header before its
    /// pixels are decoded.
    EnvTexels,
}

impl Limit {
    pub const ALL: [Limit; 8] = [
        Limit::Vertices,
        Limit::Triangles,
        Limit::FileBytes,
        Limit::VolVoxels,
        Limit::VolAxis,
        Limit::LatticeNodes,
        Limit::SurfaceSamples,
        Limit::EnvTexels,
    ];

    /// The environment variable that overrides it.
    pub fn env_var(self) -> &'static str {
        match self {
            Limit::Vertices => "TRANSLUCENT_MAX_VERTICES",
            Limit::Triangles => "TRANSLUCENT_MAX_TRIANGLES",
            Limit::FileBytes => "TRANSLUCENT_MAX_FILE_BYTES",
            Limit::VolVoxels => "TRANSLUCENT_MAX_VOL_VOXELS",
            Limit::VolAxis => "TRANSLUCENT_MAX_VOL_AXIS",
            Limit::LatticeNodes => "TRANSLUCENT_MAX_LATTICE_NODES",
            Limit::SurfaceSamples => "TRANSLUCENT_MAX_SURFACE_SAMPLES",
            Limit::EnvTexels => "TRANSLUCENT_MAX_ENV_TEXELS",
        }
    }

    /// The [`Limits`] field that holds it.
    pub fn field(self) -> &'static str {
        match self {
            Limit::Vertices => "max_vertices",
            Limit::Triangles => "max_triangles",
            Limit::FileBytes => "max_file_bytes",
            Limit::VolVoxels => "max_vol_voxels",
            Limit::VolAxis => "max_vol_axis",
            Limit::LatticeNodes => "max_lattice_nodes",
            Limit::SurfaceSamples => "max_surface_samples",
            Limit::EnvTexels => "max_env_texels",
        }
    }

    /// What is counted, for messages.
    pub fn what(self) -> &'static str {
        match self {
            Limit::Vertices => "vertices",
            Limit::Triangles => "triangles",
            Limit::FileBytes => "bytes in the file",
            Limit::VolVoxels => "voxels in the .vol grid",
            Limit::VolAxis => "cells along one axis of the .vol grid",
            Limit::LatticeNodes => "lattice nodes (estimated) in one bake level",
            Limit::SurfaceSamples => "surface samples seeding the bake's lattice",
            Limit::EnvTexels => "texels in the environment map",
        }
    }
}

/// The limits a reader or a bake enforces. [`Limits::default`] holds the built-in values,
/// [`Limits::from_env`] the same overridden by the environment (what the readers use when given no
/// limits explicitly).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// OBJ `v` lines. Default 16 M (a mesh costs ~100 bytes per vertex through the bake).
    pub max_vertices: u64,
    /// OBJ triangles after fan triangulation. Default 32 M.
    pub max_triangles: u64,
    /// OBJ or cache file size, checked before reading. Default 4 GiB.
    pub max_file_bytes: u64,
    /// `.vol` voxels. Default 64 M (1.5 GB of f32 at 6 channels).
    pub max_vol_voxels: u64,
    /// `.vol` cells along one axis. Default 4096.
    pub max_vol_axis: u64,
    /// Lattice nodes of one bake level, estimated from the octree before the lattice is built.
    /// Default 16 M (~3 GB through stuffing and graph; a 512-cell sphere has about 5 M).
    pub max_lattice_nodes: u64,
    /// Surface samples seeding one bake level's lattice. Default 32 M (~1.2 GB).
    pub max_surface_samples: u64,
    /// EXR environment map texels. Default 64 M (768 MB of f32 RGB; a 16k x 8k map is 128 M: raise
    /// it for such maps; the projection keeps only nine coefficients).
    pub max_env_texels: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_vertices: 16_000_000,
            max_triangles: 32_000_000,
            max_file_bytes: 4 << 30,
            max_vol_voxels: 64 << 20,
            max_vol_axis: 4096,
            max_lattice_nodes: 16 << 20,
            max_surface_samples: 32 << 20,
            max_env_texels: 64 << 20,
        }
    }
}

/// A count above its limit.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub struct LimitExceeded {
    pub limit: Limit,
    /// What was asked for (saturated at `u64::MAX`).
    pub count: u64,
    /// The limit in force.
    pub max: u64,
}

impl fmt::Display for LimitExceeded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "too many {}: {}, the limit is {} (raise it with the environment variable {}=N, or \
             Limits::{} in code)",
            self.limit.what(),
            self.count,
            self.max,
            self.limit.env_var(),
            self.limit.field()
        )
    }
}

impl Limits {
    /// The defaults, each overridden by its environment variable ([`Limit::env_var`]) where that
    /// holds a decimal integer (`_` separators allowed); any other value is ignored.
    pub fn from_env() -> Self {
        let mut limits = Limits::default();
        for limit in Limit::ALL {
            let value = std::env::var(limit.env_var())
                .ok()
                .and_then(|v| v.trim().replace('_', "").parse::<u64>().ok());
            if let Some(v) = value {
                *limits.get_mut(limit) = v;
            }
        }
        limits
    }

    pub fn get(&self, limit: Limit) -> u64 {
        match limit {
            Limit::Vertices => self.max_vertices,
            Limit::Triangles => self.max_triangles,
            Limit::FileBytes => self.max_file_bytes,
            Limit::VolVoxels => self.max_vol_voxels,
            Limit::VolAxis => self.max_vol_axis,
            Limit::LatticeNodes => self.max_lattice_nodes,
            Limit::SurfaceSamples => self.max_surface_samples,
            Limit::EnvTexels => self.max_env_texels,
        }
    }

    fn get_mut(&mut self, limit: Limit) -> &mut u64 {
        match limit {
            Limit::Vertices => &mut self.max_vertices,
            Limit::Triangles => &mut self.max_triangles,
            Limit::FileBytes => &mut self.max_file_bytes,
            Limit::VolVoxels => &mut self.max_vol_voxels,
            Limit::VolAxis => &mut self.max_vol_axis,
            Limit::LatticeNodes => &mut self.max_lattice_nodes,
            Limit::SurfaceSamples => &mut self.max_surface_samples,
            Limit::EnvTexels => &mut self.max_env_texels,
        }
    }

    /// `Ok` if `count` is within `limit`.
    pub fn check(&self, limit: Limit, count: u64) -> Result<(), LimitExceeded> {
        let max = self.get(limit);
        if count > max {
            Err(LimitExceeded { limit, count, max })
        } else {
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_message_names_the_limit_and_how_to_raise_it() {
        let e = Limits {
            max_vertices: 3,
            ..Limits::default()
        }
        .check(Limit::Vertices, 4)
        .unwrap_err();
        let text = e.to_string();
        for needle in [
            "too many vertices: 4",
            "limit is 3",
            "TRANSLUCENT_MAX_VERTICES",
            "max_vertices",
        ] {
            assert!(text.contains(needle), "{text}");
        }
    }

    #[test]
    fn every_limit_has_its_own_field_and_variable() {
        let mut limits = Limits::default();
        for (i, limit) in Limit::ALL.into_iter().enumerate() {
            *limits.get_mut(limit) = i as u64 + 1;
        }
        for (i, limit) in Limit::ALL.into_iter().enumerate() {
            assert_eq!(limits.get(limit), i as u64 + 1, "{limit:?}");
        }
        let vars: std::collections::HashSet<_> = Limit::ALL.iter().map(|l| l.env_var()).collect();
        assert_eq!(vars.len(), Limit::ALL.len());
    }
}

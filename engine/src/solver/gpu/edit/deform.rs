//! A deform edit: the GPU passes that move the graph's nodes and the display mesh, their push
//! constants and pipelines, and the staging of a new deformation.

use std::sync::Arc;

use ash::vk;
use glam::Mat4;

use crate::mesh::{GpuMesh, Vertex};
use crate::quadgraph::graph::NO_NODE;
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite};
use crate::solver::gpu::{bad_param, bytes_of, surface_packing, GpuDiffusion, GpuLevel};
use crate::vk::{Buffer, Context};
use crate::{Error, QuadGraph};

use super::*;

/// Push constants of `edit/derive_weights.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DerivePush {
    pub size: [i32; 2],
    pub width: u32,
    pub surface_rows: u32,
    pub paper: u32,
    pub two_a: f32,
    pub q_gain: f32,
    pub pad: u32,
}

/// Push constants of `edit/map_vertices.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MapPush {
    pub affine: [f32; 16],
    pub count: u32,
    /// 0 affine, 1 twist.
    pub mode: u32,
    pub rate: f32,
    pub pad: u32,
}

/// Push constants of `edit/deform_nodes.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct NodesPush {
    pub size: [i32; 2],
    pub width: u32,
    pub surface_rows: u32,
}

/// Push constants of `edit/deform_geometry.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GeometryPush {
    pub size: [i32; 2],
    pub width: u32,
    pub surface_rows: u32,
    pub paper: u32,
    pub min_volume: f32,
    pub min_distance: f32,
    pub pad: u32,
}

/// Push constants of `edit/deform_mesh.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MeshPush {
    pub count: u32,
}

/// One display-mesh vertex's anchor (`MeshVertex` in `edit/deform_mesh.comp`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct MeshAnchor {
    pub(super) bary: [f32; 4],
    pub(super) normal: [f32; 4],
    pub(super) tet: [u32; 4],
}

pub(crate) struct DeformPipelines {
    pub(super) map: ComputePipeline<MapPush>,
    pub(super) nodes: ComputePipeline<NodesPush>,
    pub(super) geometry: ComputePipeline<GeometryPush>,
    pub(super) mesh: ComputePipeline<MeshPush>,
}

impl DeformPipelines {
    pub(super) fn new(ctx: &Context, levels: u32) -> Result<Self, Error> {
        let sets = levels.max(1);
        Ok(Self {
            map: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: "edit map vertices",
                    shader: "edit/map_vertices.comp",
                    bindings: &["rest", "vertices"],
                    max_sets: sets,
                },
            )?,
            nodes: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: "edit deform nodes",
                    shader: "edit/deform_nodes.comp",
                    bindings: &[
                        "cells",
                        "bary",
                        "rest_normals",
                        "tets",
                        "rest",
                        "vertices",
                        "node_pos",
                        "surface_position",
                        "surface_normal",
                    ],
                    max_sets: sets,
                },
            )?,
            geometry: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: "edit deform geometry",
                    shader: "edit/deform_geometry.comp",
                    bindings: &[
                        "cells",
                        "tets",
                        "vertices",
                        "node_pos",
                        "connectivity",
                        "geo",
                        "frac",
                    ],
                    max_sets: sets,
                },
            )?,
            mesh: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: PASS_DEFORM_MESH,
                    shader: "edit/deform_mesh.comp",
                    bindings: &["map", "tets", "rest", "vertices", "values"],
                    max_sets: 1,
                },
            )?,
        })
    }
}

/// One level's deformation data on the GPU (created on the first deformation).
pub(crate) struct LevelDeform {
    pub(super) buffers: Vec<Buffer>,
    pub(super) vertex_count: u32,
    pub(super) map_set: vk::DescriptorSet,
    pub(super) nodes_set: vk::DescriptorSet,
    pub(super) geometry_set: vk::DescriptorSet,
    pub(super) min_volume: f32,
    pub(super) min_distance: f32,
    /// Index into `buffers` of the deformed vertices.
    pub(super) vertices: usize,
    /// Whether the level is not at rest.
    pub(super) deformed: bool,
}

impl LevelDeform {
    pub(crate) fn bytes(&self) -> u64 {
        self.buffers.iter().map(|b| b.size).sum()
    }
    pub(super) fn vertices(&self) -> &Buffer {
        &self.buffers[self.vertices]
    }
}

/// The display meshes' deformation data (finest level).
pub(crate) struct MeshDeform {
    /// Vertex anchors (the descriptor set refers to it; counted by `EditState::mesh_bytes`).
    pub(super) anchors: Buffer,
    /// Rest vertices in the `Vertex` layout (restores `Identity` exactly).
    pub(super) rest: Buffer,
    /// Deformed vertices in the `Vertex` layout.
    pub(super) out: Buffer,
    pub(super) count: u32,
    pub(super) set: vk::DescriptorSet,
}

impl GpuDiffusion {
    pub(super) fn check_graph(&self, graph: &QuadGraph) -> Result<(), Error> {
        let same = graph.levels.len() == self.levels.len()
            && graph
                .levels
                .iter()
                .zip(&self.levels)
                .all(|(g, l)| g.node_count() == l.node_count);
        if same {
            Ok(())
        } else {
            Err(bad_param(
                "graph",
                "not the graph this solve was built from (level or node counts differ)".into(),
            ))
        }
    }

    pub(super) fn ensure_deform(&mut self, ctx: &Context, graph: &QuadGraph) -> Result<(), Error> {
        if self.pipelines.edit.is_none() {
            self.pipelines.edit = Some(DeformPipelines::new(ctx, self.levels.len() as u32)?);
        }
        self.ensure_frac(ctx)?;
        let Some(pipes) = &self.pipelines.edit else {
            return Ok(());
        };
        for (level, l) in graph.levels.iter().zip(&mut self.levels) {
            if l.deform.is_some() {
                continue;
            }
            let texels = l.rest.texel_count();
            let inner = level.inner_count();
            let mut cells = vec![u32::MAX; texels];
            let mut bary = vec![[0f32; 4]; texels];
            let mut normals = vec![[0f32; 4]; texels];
            for node in 0..level.node_count() {
                let t = l.packing.linear_index(node as u32) as usize;
                let (tet, cell) = if node < inner {
                    (node, node as u32)
                } else {
                    let (k, f) = level.surface_faces[node - inner];
                    normals[t] = to_f32x4(level.surface_normals[node - inner], 0.0);
                    (k as usize, k * 4 + u32::from(f))
                };
                cells[t] = cell;
                let rest = level.tets.tets[tet].map(|v| level.tets.vertices[v as usize]);
                bary[t] = barycentric(rest, level.positions[node]).map(|b| b as f32);
            }
            let rest: Vec<[f32; 4]> = level
                .tets
                .vertices
                .iter()
                .map(|&v| to_f32x4(v, 1.0))
                .collect();
            let tets: Vec<[u32; 4]> = level.tets.tets.clone();
            let buffers = vec![
                storage(ctx, "deform cells", &cells)?,
                storage(ctx, "deform bary", &bary)?,
                storage(ctx, "deform rest normals", &normals)?,
                storage(ctx, "deform tets", &tets)?,
                storage(ctx, "deform rest vertices", &rest)?,
                gpu_buffer(ctx, "deform vertices", rest.len() as u64 * 16)?,
                gpu_buffer(ctx, "deform node positions", texels as u64 * 16)?,
            ];
            let sb = |name, i: usize| DescriptorWrite::StorageBuffer {
                name,
                buffer: &buffers[i],
            };
            let map_set = pipes
                .map
                .allocate_set(ctx, &[sb("rest", 4), sb("vertices", 5)])?;
            let nodes_set = pipes.nodes.allocate_set(
                ctx,
                &[
                    sb("cells", 0),
                    sb("bary", 1),
                    sb("rest_normals", 2),
                    sb("tets", 3),
                    sb("rest", 4),
                    sb("vertices", 5),
                    sb("node_pos", 6),
                    DescriptorWrite::storage_image("surface_position", &l.surface_position),
                    DescriptorWrite::storage_image("surface_normal", &l.surface_normal),
                ],
            )?;
            let Some(frac) = &l.frac else {
                return Err(bad_param("deformation", "no fraction texture".into()));
            };
            let geometry_set = pipes.geometry.allocate_set(
                ctx,
                &[
                    sb("cells", 0),
                    sb("tets", 3),
                    sb("vertices", 5),
                    sb("node_pos", 6),
                    DescriptorWrite::storage_image("connectivity", &l.connectivity),
                    DescriptorWrite::storage_image("geo", &l.geo),
                    DescriptorWrite::storage_image("frac", frac),
                ],
            )?;
            let h = level.spacing.max(1e-6);
            l.deform = Some(LevelDeform {
                vertex_count: rest.len() as u32,
                buffers,
                map_set,
                nodes_set,
                geometry_set,
                min_volume: (1e-9 * h * h * h).max(f64::from(f32::MIN_POSITIVE)) as f32,
                min_distance: (1e-6 * h) as f32,
                vertices: 5,
                deformed: false,
            });
        }
        Ok(())
    }

    /// The display meshes' anchors (finest level), built on first use.
    pub(super) fn ensure_mesh(&mut self, ctx: &Context, graph: &QuadGraph) -> Result<(), Error> {
        if self.edits.mesh.is_some() {
            return Ok(());
        }
        let (Some(pipes), Some(finest)) = (&self.pipelines.edit, self.levels.last()) else {
            return Ok(());
        };
        let Some(deform) = &finest.deform else {
            return Ok(());
        };
        let level = graph.finest();
        let surface = &graph.surface;
        let inner = level.inner_count();
        let mut anchors = Vec::with_capacity(surface.positions.len());
        let mut rest = Vec::with_capacity(surface.positions.len());
        for (v, (&p, &n)) in surface.positions.iter().zip(&surface.normals).enumerate() {
            // The tetrahedron under the vertex's first shading link, else the nearest surface
            // node's (rare: vertices with no link).
            let s = graph
                .shading
                .links
                .get(v)
                .and_then(|l| l.iter().copied().find(|&s| s != NO_NODE))
                .map(|s| s as usize)
                .filter(|&s| s < level.surface_count())
                .or_else(|| {
                    (0..level.surface_count()).min_by(|&a, &b| {
                        let da = level.positions[inner + a].distance_squared(p);
                        let db = level.positions[inner + b].distance_squared(p);
                        da.total_cmp(&db)
                    })
                })
                .ok_or_else(|| bad_param("mesh", "the finest level has no surface node".into()))?;
            let t = level.surface_faces[s].0 as usize;
            let tet = level.tets.tets[t].map(|i| level.tets.vertices[i as usize]);
            anchors.push(MeshAnchor {
                bary: barycentric(tet, p).map(|b| b as f32),
                normal: to_f32x4(n, 0.0),
                tet: [t as u32, 0, 0, 0],
            });
            rest.push(Vertex {
                position: p.as_vec3().to_array(),
                normal: n.as_vec3().to_array(),
                exitance: [0.0; 3],
            });
        }
        if anchors.is_empty() {
            return Err(bad_param(
                "mesh",
                "the display surface has no vertices".into(),
            ));
        }
        let anchors_buf = storage(ctx, "deform mesh anchors", &anchors)?;
        let rest_buf = Buffer::with_data(
            ctx,
            "deform mesh rest",
            vk::BufferUsageFlags::TRANSFER_SRC,
            &rest,
        )?;
        let out = gpu_buffer(
            ctx,
            "deform mesh vertices",
            (rest.len() * std::mem::size_of::<Vertex>()) as u64,
        )?;
        let set = pipes.mesh.allocate_set(
            ctx,
            &[
                DescriptorWrite::StorageBuffer {
                    name: "map",
                    buffer: &anchors_buf,
                },
                DescriptorWrite::StorageBuffer {
                    name: "tets",
                    buffer: &deform.buffers[3],
                },
                DescriptorWrite::StorageBuffer {
                    name: "rest",
                    buffer: &deform.buffers[4],
                },
                DescriptorWrite::StorageBuffer {
                    name: "vertices",
                    buffer: deform.vertices(),
                },
                DescriptorWrite::StorageBuffer {
                    name: "values",
                    buffer: &out,
                },
            ],
        )?;
        self.edits.mesh = Some(MeshDeform {
            anchors: anchors_buf,
            rest: rest_buf,
            out,
            count: rest.len() as u32,
            set,
        });
        Ok(())
    }

    /// Stages a deformation of every level (see the module doc) and of `meshes` (each must have
    /// the display surface's vertex count), recorded by the next [`Self::record_edits`], which
    /// rewrites their positions and normals.
    pub fn deform(
        &mut self,
        ctx: &Context,
        graph: &QuadGraph,
        deformation: &Deformation,
        meshes: &[Arc<GpuMesh>],
    ) -> Result<(), Error> {
        self.check_graph(graph)?;
        deformation.validate(graph)?;
        if self.multigrid.is_some() && !matches!(deformation, Deformation::Identity) {
            // The multigrid schedule's Galerkin levels are built on the CPU from the rest
            // pose; re-deriving them per deformation is not built.
            return Err(bad_param(
                "deformation",
                "the multigrid schedule solves the rest pose only: use the cascade schedule to \
                 deform"
                    .into(),
            ));
        }
        for m in meshes {
            if m.vertex_count() != graph.surface.positions.len() {
                return Err(bad_param(
                    "meshes",
                    format!(
                        "a mesh has {} vertices, the display surface {}",
                        m.vertex_count(),
                        graph.surface.positions.len()
                    ),
                ));
            }
        }
        let was_deformed = self.levels.iter().any(GpuLevel::deformed);
        if *deformation == Deformation::Identity {
            if was_deformed {
                for h in 0..self.levels.len() {
                    let l = &self.levels[h];
                    let surface = surface_packing(&l.packing);
                    let n = (surface.width * surface.height) as usize;
                    let uploads = [
                        (Target::Geo, bytes_of(&l.rest.geo)),
                        (Target::Frac, bytes_of(&l.rest.frac)),
                        (
                            Target::SurfacePosition,
                            bytes_of(&l.rest.surface_position[..n.min(l.rest.texel_count())]),
                        ),
                        (
                            Target::SurfaceNormal,
                            bytes_of(&l.rest.surface_normal[..n.min(l.rest.texel_count())]),
                        ),
                    ];
                    for (target, bytes) in uploads {
                        self.stage(ctx, h, target, &bytes, false)?;
                    }
                    if let Some(d) = &mut self.levels[h].deform {
                        d.deformed = false;
                    }
                }
                self.edits.derive |= !self.homogeneous;
                self.edits.deform = None;
                self.edits.vertex_uploads.clear();
            }
            self.edits.mesh_from_rest = true;
        } else {
            self.ensure_deform(ctx, graph)?;
            self.ensure_mesh(ctx, graph)?;
            self.edits.vertex_uploads.clear();
            let source = match deformation {
                Deformation::Affine(m) => VertexSource::Map(MapPush {
                    affine: m.to_cols_array(),
                    count: 0,
                    mode: 0,
                    rate: 0.0,
                    pad: 0,
                }),
                Deformation::Twist { radians_per_mm } => VertexSource::Map(MapPush {
                    affine: Mat4::IDENTITY.to_cols_array(),
                    count: 0,
                    mode: 1,
                    rate: *radians_per_mm,
                    pad: 0,
                }),
                Deformation::TetPositions(levels) => {
                    for (h, p) in levels.iter().enumerate() {
                        let v: Vec<[f32; 4]> = p.iter().map(|x| [x[0], x[1], x[2], 1.0]).collect();
                        let buf = staging(ctx, &v)?;
                        self.edits.vertex_uploads.push((h, buf));
                    }
                    VertexSource::Uploaded
                }
                Deformation::Identity => return Ok(()),
            };
            // Rest uploads staged earlier would land before (and be overwritten by) the passes;
            // a fresh texture's first upload stays (it also leaves UNDEFINED).
            self.edits.uploads.retain(|u| match u.target {
                Target::Geo | Target::SurfacePosition | Target::SurfaceNormal => false,
                Target::Frac => u.fresh,
                _ => true,
            });
            self.edits.deform = Some(source);
            self.edits.derive |= !self.homogeneous;
            self.edits.mesh_from_rest = false;
            for l in &mut self.levels {
                if let Some(d) = &mut l.deform {
                    d.deformed = true;
                }
            }
        }
        if deformation != &Deformation::Identity || was_deformed {
            self.edits.meshes = meshes.to_vec();
        }
        self.edits.current = Some(deformation.clone());
        Ok(())
    }
}

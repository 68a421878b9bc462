//! Builds one level's GPU textures from the baked graph (state, connectivity, material, surface).
//!
//! Under the multigrid schedule ([`GpuSolveParams::multigrid`]) the cascade's iteration never
//! runs: its state, residual, saved phi, links and (on coarse levels) graph are then 1x1
//! placeholders ([`placeholder`]), bound in the descriptor sets but never dispatched over. What
//! that schedule reads stays full size: q on every level (the gather writes it), and on the
//! finest level phi (the multigrid's output) and the connectivity (the J+ pass); with the
//! matrix-free finest operator (`FinestOperator::Graph`) also the finest level's geometric
//! factors, which its `K x` reads (`multigrid/graph_operator.glsl`).

use super::bytes::{image_bytes, texel_bytes};
use super::*;

impl GpuDiffusion {
    pub(super) fn upload_level(
        ctx: &Context,
        pipelines: &Pipelines,
        precision: Precision,
        t: LevelTexels,
        coarser: Option<&GpuLevel>,
        finest: bool,
        multigrid: Option<FinestOperator>,
    ) -> Result<GpuLevel, Error> {
        let graph_finest = finest && multigrid == Some(FinestOperator::Graph);
        let multigrid = multigrid.is_some();
        use vk::Format as F;
        let p = &t.packing;
        let one = placeholder();
        // The cascade's resources: full size unless the multigrid schedule never reads them.
        let cascade = if multigrid { &one } else { p };
        let result_state = if multigrid && !(finest && precision != Precision::Mixed) {
            &one
        } else {
            p
        };
        let state_format = match precision {
            Precision::Fp32 => F::R32G32B32A32_SFLOAT,
            Precision::Mixed | Precision::Fp16 => F::R16G16B16A16_SFLOAT,
        };
        let state = [
            image(ctx, "diffusion ping", result_state, state_format)?,
            image(ctx, "diffusion pong", cascade, state_format)?,
        ];
        let (phi, residual) = if precision == Precision::Mixed {
            (
                Some(image(
                    ctx,
                    "diffusion phi",
                    if finest { p } else { cascade },
                    F::R32G32B32A32_SFLOAT,
                )?),
                Some(image(
                    ctx,
                    "diffusion residual",
                    cascade,
                    F::R32G32B32A32_SFLOAT,
                )?),
            )
        } else {
            (None, None)
        };
        // Only the surface rows: q is a surface node's source; every reader (the iterations,
        // J+, the vertices, the multigrid's right-hand side) reads it on surface rows only.
        let q = image(
            ctx,
            "diffusion q",
            &surface_packing(p),
            F::R16G16B16A16_SFLOAT,
        )?;
        let connectivity = image(
            ctx,
            "diffusion connectivity",
            if finest { p } else { cascade },
            F::R32G32B32A32_UINT,
        )?;
        let geo = image(
            ctx,
            "diffusion weight geo",
            if graph_finest { p } else { cascade },
            F::R32G32B32A32_SFLOAT,
        )?;
        // The coarsest level links to nothing (its init is zero, its warm start corrects nothing).
        let linked = if coarser.is_some() { cascade } else { &one };
        let links = [
            image(ctx, "diffusion links lo", linked, F::R32G32B32A32_UINT)?,
            image(ctx, "diffusion links hi", linked, F::R32G32B32A32_UINT)?,
        ];
        // Only the surface rows: the gather writes nothing below them (saves 24 bytes per inner
        // texel; the gather accepts images with at least `surface_rows` rows).
        let surface = surface_packing(p);
        let surface_texels = (surface.width * surface.height) as usize;
        let surface_position = image(ctx, "surface position", &surface, F::R32G32B32A32_SFLOAT)?;
        let surface_normal = image(ctx, "surface normal", &surface, F::R16G16B16A16_SFLOAT)?;
        let surface_anisotropy =
            image(ctx, "surface anisotropy", &surface, F::R16G16B16A16_SFLOAT)?;
        // The collimated source's exit-query part (DESIGN 2.7), written by the gather.
        let particular = image(
            ctx,
            "diffusion particular",
            &surface,
            F::R16G16B16A16_SFLOAT,
        )?;
        let particular_zero = vec![0u8; surface_texels * 8];
        // The phi format: what a level's result is stored in (`GpuLevel::result`).
        let phi_format = match precision {
            Precision::Mixed | Precision::Fp32 => F::R32G32B32A32_SFLOAT,
            Precision::Fp16 => F::R16G16B16A16_SFLOAT,
        };
        let saved = if finest {
            None
        } else {
            Some(image(ctx, "diffusion saved phi", cascade, phi_format)?)
        };
        let n = t.texel_count();
        let zeros16 = vec![0u8; n * 8];
        let state_zero = vec![0u8; n * texel_bytes(state_format) as usize];
        let mut items: Vec<(&Image, Vec<u8>)> = vec![
            (&state[0], state_zero.clone()),
            (&state[1], state_zero),
            (&q, zeros16),
            (&connectivity, bytes_of(&t.connectivity)),
            (&geo, bytes_of(&t.geo)),
            (&links[0], bytes_of(&t.links[0])),
            (&links[1], bytes_of(&t.links[1])),
            (
                &surface_position,
                bytes_of(&t.surface_position[..surface_texels.min(n)]),
            ),
            (
                &surface_normal,
                bytes_of(&t.surface_normal[..surface_texels.min(n)]),
            ),
            (
                &surface_anisotropy,
                bytes_of(&t.surface_anisotropy[..surface_texels.min(n)]),
            ),
        ];
        items.push((&particular, particular_zero));
        for img in phi.iter().chain(&residual) {
            items.push((img, vec![0u8; n * 16]));
        }
        if let Some(img) = &saved {
            items.push((img, vec![0u8; n * texel_bytes(phi_format) as usize]));
        }
        // Placeholders take the first texels (their contents are never read).
        for (img, bytes) in &mut items {
            bytes.truncate(image_bytes(img) as usize);
        }
        upload_images(ctx, "diffusion level upload", &items)?;
        drop(items);
        let apply_set = match (&phi, &pipelines.apply) {
            // The last correction of a block (PingPong::latest).
            (Some(phi), Some(ap)) => ap.allocate_set(
                ctx,
                &[
                    DescriptorWrite::storage_image(
                        "delta",
                        &state[PingPong::new(precision).latest().0],
                    ),
                    DescriptorWrite::storage_image("phi", phi),
                ],
            )?,
            _ => vk::DescriptorSet::null(),
        };
        let dst = phi.as_ref().unwrap_or(&state[PingPong::FIRST]);
        // The coarsest level never reads `coarse` (zero init); any image of the right format binds.
        let coarse = match coarser {
            Some(c) => c.result(),
            None => residual.as_ref().unwrap_or(&state[1]),
        };
        // Bound but never touched (flags): the finest level saves nothing, the coarsest level
        // corrects from nothing; any image of the phi format stands in.
        let spare = residual.as_ref().unwrap_or(&state[1]);
        let (coarse_new, coarse_prev) = match coarser {
            Some(c) => (c.result(), c.saved.as_ref().unwrap_or(spare)),
            None => (spare, spare),
        };
        let warm_set = pipelines.warm.allocate_set(
            ctx,
            &[
                DescriptorWrite::storage_image("phi", dst),
                DescriptorWrite::storage_image("saved", saved.as_ref().unwrap_or(spare)),
                DescriptorWrite::storage_image("coarse_new", coarse_new),
                DescriptorWrite::storage_image("coarse_prev", coarse_prev),
                DescriptorWrite::storage_image("links_lo", &links[0]),
                DescriptorWrite::storage_image("links_hi", &links[1]),
            ],
        )?;
        let init_set = pipelines.init.allocate_set(
            ctx,
            &[
                DescriptorWrite::storage_image("coarse", coarse),
                DescriptorWrite::storage_image("dst", dst),
                DescriptorWrite::storage_image("links_lo", &links[0]),
                DescriptorWrite::storage_image("links_hi", &links[1]),
            ],
        )?;
        Ok(GpuLevel {
            packing: t.packing.clone(),
            node_count: t.packing.texels.len(),
            inner_count: t
                .packing
                .texels
                .iter()
                .filter(|&&[_, v]| v >= t.packing.surface_rows)
                .count(),
            state,
            phi,
            residual,
            q,
            connectivity,
            geo,
            frac: None,
            material: None,
            weights: None,
            links,
            surface_position,
            surface_normal,
            surface_anisotropy,
            particular,
            iterate_sets: [Vec::new(), Vec::new()],
            apply_set,
            init_set,
            saved,
            warm_set,
            reduce_set: vk::DescriptorSet::null(),
            derive_set: None,
            rest: t,
            deform: None,
        })
    }
}

/// A 1x1 texture's packing: the size of a resource the chosen schedule never reads.
pub(crate) fn placeholder() -> Packing {
    Packing {
        width: 1,
        height: 1,
        ..Packing::default()
    }
}

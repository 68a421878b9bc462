//! Builds one level's GPU textures from the baked graph (state, connectivity, material, surface).

use super::*;

impl GpuDiffusion {
    pub(super) fn upload_level(
        ctx: &Context,
        pipelines: &Pipelines,
        precision: Precision,
        t: LevelTexels,
        coarser: Option<&GpuLevel>,
        finest: bool,
    ) -> Result<GpuLevel, Error> {
        use vk::Format as F;
        let p = &t.packing;
        let state_format = match precision {
            Precision::Fp32 => F::R32G32B32A32_SFLOAT,
            Precision::Mixed | Precision::Fp16 => F::R16G16B16A16_SFLOAT,
        };
        let state = [
            image(ctx, "diffusion ping", p, state_format)?,
            image(ctx, "diffusion pong", p, state_format)?,
        ];
        let (phi, residual) = if precision == Precision::Mixed {
            (
                Some(image(ctx, "diffusion phi", p, F::R32G32B32A32_SFLOAT)?),
                Some(image(ctx, "diffusion residual", p, F::R32G32B32A32_SFLOAT)?),
            )
        } else {
            (None, None)
        };
        let q = image(ctx, "diffusion q", p, F::R16G16B16A16_SFLOAT)?;
        let connectivity = image(ctx, "diffusion connectivity", p, F::R32G32B32A32_UINT)?;
        let geo = image(ctx, "diffusion weight geo", p, F::R32G32B32A32_SFLOAT)?;
        let links = [
            image(ctx, "diffusion links lo", p, F::R32G32B32A32_UINT)?,
            image(ctx, "diffusion links hi", p, F::R32G32B32A32_UINT)?,
        ];
        let link_weights = [
            image(ctx, "diffusion link weights lo", p, F::R16G16B16A16_SFLOAT)?,
            image(ctx, "diffusion link weights hi", p, F::R16G16B16A16_SFLOAT)?,
        ];
        // Only the surface rows: the gather writes nothing below them (saves 24 bytes per inner
        // texel; the gather accepts images with at least `surface_rows` rows).
        let surface = surface_packing(p);
        let surface_texels = (surface.width * surface.height) as usize;
        let surface_position = image(ctx, "surface position", &surface, F::R32G32B32A32_SFLOAT)?;
        let surface_normal = image(ctx, "surface normal", &surface, F::R16G16B16A16_SFLOAT)?;
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
            Some(image(ctx, "diffusion saved phi", p, phi_format)?)
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
            (&link_weights[0], bytes_of(&t.link_weights[0])),
            (&link_weights[1], bytes_of(&t.link_weights[1])),
            (
                &surface_position,
                bytes_of(&t.surface_position[..surface_texels.min(n)]),
            ),
            (
                &surface_normal,
                bytes_of(&t.surface_normal[..surface_texels.min(n)]),
            ),
        ];
        items.push((&particular, particular_zero));
        for img in phi.iter().chain(&residual) {
            items.push((img, vec![0u8; n * 16]));
        }
        if let Some(img) = &saved {
            items.push((img, vec![0u8; n * texel_bytes(phi_format) as usize]));
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
                DescriptorWrite::storage_image("link_weights_lo", &link_weights[0]),
                DescriptorWrite::storage_image("link_weights_hi", &link_weights[1]),
            ],
        )?;
        let init_set = pipelines.init.allocate_set(
            ctx,
            &[
                DescriptorWrite::storage_image("coarse", coarse),
                DescriptorWrite::storage_image("dst", dst),
                DescriptorWrite::storage_image("links_lo", &links[0]),
                DescriptorWrite::storage_image("links_hi", &links[1]),
                DescriptorWrite::storage_image("link_weights_lo", &link_weights[0]),
                DescriptorWrite::storage_image("link_weights_hi", &link_weights[1]),
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
            link_weights,
            surface_position,
            surface_normal,
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

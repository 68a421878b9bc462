//! Recording an object's frame into a caller's command buffer (the host path of DESIGN 5).

use super::*;

impl TranslucentObject {
    /// Records this frame's work into the host's command buffer: what the changes since the last
    /// frame require (see the module doc), then the shading into `targets`, all through one
    /// frame graph (barriers between passes from their declarations, one label and timestamp
    /// scope per pass).
    ///
    /// # Safety
    /// `rc.cb` must be recording, outside a rendering scope, on a queue with graphics and compute;
    /// the targets' images and views must be valid, in their `before` states (or the declared
    /// ones with `host_barriers`), and outlive the command buffer's execution, as must `self`;
    /// `rc.frame` must be the frame being recorded and `rc.completed_frame` truly completed. After
    /// an error the command buffer must not be submitted.
    pub unsafe fn record(
        &mut self,
        rc: &mut RecordCtx<'_>,
        targets: &Targets,
    ) -> Result<FrameReport, Error> {
        let ctx = rc.ctx;
        self.check_targets(targets)?;
        if self.last_frame.is_some_and(|f| rc.frame < f) || rc.completed_frame >= rc.frame {
            return Err(invalid(
                "frame",
                format!(
                    "frame {} (completed {}): frames must not go back and the recorded one cannot be complete",
                    rc.frame, rc.completed_frame
                ),
            ));
        }
        ctx.begin_frame(rc.frame);
        ctx.frame_completed(rc.completed_frame);
        let completed = self.method.completed(rc.completed_frame)?;
        // The march depends on the eye, the lights, the material and the shape: with none of
        // them changed (and skipping on) its last output stands.
        let scatter_stale = self.changes != Changes::default() || !self.params.skip;
        let plan = FramePlan::decide(
            self.changes,
            &Conditions {
                skip: self.params.skip,
                has_solution: self.method.has_solution(),
                casts_shadows: self.shadows.any_shadows(),
                shadows_read: self.method.reads_shadows()
                    || self.params.specular
                    || self.params.single_scattering.is_some(),
            },
        );
        let method = self.method.prepare(plan.method, rc.frame)?;
        self.changes = Changes::default();

        // Our own depth buffer, sized to the target (an old one is released after its frames).
        if targets.depth.is_none() {
            let extent = targets.color.extent;
            if !self
                .own_depth
                .as_ref()
                .is_some_and(|d| d.extent() == extent)
            {
                self.own_depth = Some(Image::new(
                    ctx,
                    &ImageDesc {
                        name: "object depth",
                        width: extent.width,
                        height: extent.height,
                        format: self.params.depth_format,
                        usage: vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
                    },
                )?);
            }
        }
        let (uniforms, specular) = self.uniforms(targets.color.extent);
        let [lobe_slope, lobe_k, lobe_own] =
            self.params.exit_lobe.shading_push(f64::from(self.eta));
        let push = ShadePush {
            eta: self.eta,
            radiance_mode: match self.params.radiance {
                RadianceMode::Physical => 0,
                RadianceMode::Paper => 1,
            },
            roughness: self.params.roughness,
            specular: u32::from(specular),
            lobe_slope: lobe_slope as f32,
            lobe_k: lobe_k as f32,
            lobe_own: lobe_own as f32,
            lobe_bounce: u32::from(
                self.bounce.is_some()
                    && self.params.exit_lobe.reads_share()
                    && self.method.exit_share().is_some()
                    && self.method.exit_share_carries_exitance(),
            ),
        };

        let eye = glam::Vec3::from_slice(&uniforms.camera_pos[..3]);
        // DESIGN 2.8's error budget: a front-lit view skips the march (zeros written once, when
        // the last output held a march).
        let below_budget = self
            .params
            .single_scattering
            .and_then(|_| self.scatter.skip_reason(eye.as_dvec3()));
        let clear = below_budget.is_some() && self.scatter.live();
        let scattering = self.params.single_scattering.is_some()
            && (clear || (scatter_stale && below_budget.is_none()));
        // No light above the error budget, an environment and the whole mode: the pass writes
        // the environment's closed form without the march's depths (recorded once, empty, so
        // that the march's descriptor reads a written atlas).
        let environment_only = scattering
            && !clear
            && self.scatter.environment_only()
            && self.scatter.depths_written();
        if scattering {
            self.scatter.bind(ctx, &self.mesh, &self.shadows, eye)?;
            self.scatter.set_live(!clear);
            if !clear {
                self.scatter.set_depths_written();
            }
        }
        let mut graph = FrameGraph::new(ctx);
        let after = |t: &TargetImage| (!targets.host_barriers).then_some(t.after);
        let c = &targets.color;
        let color = graph.import("colour target", c.image, c.format, c.before, after(c));
        let host_depth = targets
            .depth
            .as_ref()
            .map(|d| graph.import("depth target", d.image, d.format, d.before, after(d)));
        for &(pass, why) in plan.skipped.iter().chain(&method.skipped) {
            graph.skip(pass, why);
        }
        if self.params.single_scattering.is_some() && (!scattering || clear) {
            let why = below_budget.unwrap_or(crate::frame::SkipReason::Unchanged);
            graph.skip(PASS_SCATTER_DEPTHS, why);
            if !scattering {
                graph.skip(PASS_SINGLE_SCATTERING, why);
            }
        } else if environment_only {
            graph.skip(PASS_SCATTER_DEPTHS, crate::frame::SkipReason::DarkLights);
        }
        self.method.add_edit_passes(&mut graph);
        let mesh = &*self.mesh;
        let shadows = &self.shadows;
        if plan.shadows {
            graph
                .pass(PASS_SHADOW)
                .uses(shadows.uses(mesh))
                .record(move |p| {
                    // SAFETY: inside the graph's pass declaring the shadow maps' uses; `self`
                    // outlives the frame (the record contract).
                    unsafe { shadows.record(p.ctx, p.cb, mesh) };
                    Ok(())
                });
        }
        let before_method = graph.pass_names().len();
        self.method.add_passes(&mut graph, shadows)?;
        // The per-node exit lobe's share per vertex (only the node lobe reads it).
        let share = self
            .params
            .exit_lobe
            .reads_share()
            .then(|| self.method.exit_share())
            .flatten();
        // The bounce is added in place to the exitance: only on frames whose method wrote a new
        // one (its passes ran), otherwise the last frame's sum stands.
        if let Some(bounce) = &self.bounce {
            if graph.pass_names().len() > before_method {
                graph
                    .pass(PASS_BOUNCE)
                    .uses(bounce.uses(mesh))
                    .record(move |p| {
                        // SAFETY: inside the graph's pass declaring the bounce's uses of the mesh
                        // it was built for; `self` outlives the frame (the record contract).
                        unsafe { bounce.record(p.ctx, p.cb) };
                        Ok(())
                    });
                // `--bounce source`: E_b into the solve's q, a second solve, its exitance.
                self.method
                    .add_bounce_passes(&mut graph, bounce.irradiance());
            } else {
                graph.skip(PASS_BOUNCE, crate::frame::SkipReason::Unchanged);
            }
        }
        // The tangential flux's smooth gradient of the exitance the shading reads (the method's,
        // after the bounce): on frames whose method wrote a new one, and on the pass's first.
        let gradient = self.tangential.as_ref();
        let fresh = graph.pass_names().len() > before_method || !self.tangential_written.get();
        if let Some(tangential) = gradient {
            if fresh {
                self.tangential_written.set(true);
                graph
                    .pass(crate::frame::PASS_TANGENTIAL)
                    .uses(tangential.uses(mesh))
                    .record(move |p| {
                        // SAFETY: inside the graph's pass declaring the gradient's uses of the
                        // mesh it was built for; `self` outlives the frame (the record contract).
                        unsafe { tangential.record(p.ctx, p.cb) };
                        Ok(())
                    });
            } else {
                graph.skip(
                    crate::frame::PASS_TANGENTIAL,
                    crate::frame::SkipReason::Unchanged,
                );
            }
        }
        let gradient = gradient.map(|t| t.gradient());
        let scatter = &self.scatter;
        if scattering && !clear && !environment_only {
            graph
                .pass(PASS_SCATTER_DEPTHS)
                .uses(scatter.depth_uses(mesh))
                .record(move |p| {
                    // SAFETY: inside the graph's pass declaring the depth pre-pass's uses, after
                    // `bind`; `self` outlives the frame (the record contract).
                    unsafe { scatter.record_depths(p.ctx, p.cb, mesh) }
                });
        }
        if scattering {
            graph
                .pass(PASS_SINGLE_SCATTERING)
                .uses(scatter.uses(mesh, shadows))
                .record(move |p| {
                    // SAFETY: inside the graph's pass declaring the march's uses, after `bind`;
                    // `self` outlives the frame (the record contract).
                    unsafe { scatter.record(p.ctx, p.cb, eye, clear) }
                });
        }
        let own_depth = self.own_depth.as_ref().filter(|_| targets.depth.is_none());
        let mut shading = graph
            .pass(PASS_SHADING)
            .uses(
                self.shading
                    .uses(mesh, scatter.buffer(), share, gradient, shadows),
            )
            .host(color, COLOR_USE);
        shading = match (host_depth, own_depth) {
            (Some(id), _) => shading.host(id, DEPTH_USE),
            (None, Some(own)) => shading.uses([crate::vk::barrier::Use::image(own, DEPTH_USE)]),
            (None, None) => return Err(invalid("depth", "no depth buffer".into())),
        };
        let attachments = ShadeAttachments {
            color: c.view,
            load_color: true,
            depth: targets.depth.map_or_else(
                || own_depth.map_or(vk::ImageView::null(), |d| d.view),
                |d| d.view,
            ),
            load_depth: targets.depth.is_some(),
            store_depth: targets.depth.is_some(),
            extent: c.extent,
        };
        let shading_pass = &self.shading;
        shading.record(move |p| {
            // SAFETY: inside the graph's pass declaring the attachments in their attachment
            // layouts; everything outlives the frame (the record contract).
            unsafe {
                shading_pass.record_into(
                    p.ctx,
                    p.cb,
                    mesh,
                    scatter.buffer(),
                    share,
                    gradient,
                    &attachments,
                    &uniforms,
                    &push,
                )
            }
            .map_err(Error::from)
        });
        // SAFETY: the caller's contract.
        let run =
            unsafe { graph.execute(rc.cb, rc.profiler.as_deref_mut(), targets.host_barriers)? };
        self.last_frame = Some(rc.frame);
        Ok(FrameReport {
            frame: rc.frame,
            method: self.method.name(),
            method_choice: self.method_choice,
            passes: run.passes,
            skipped: run.skipped.into_iter().collect(),
            warm_start: method.warm_start,
            levels_iterated: method.levels_iterated,
            material_variant: self.method.material_variant(),
            completed,
            barriers: run.barriers,
        })
    }
}

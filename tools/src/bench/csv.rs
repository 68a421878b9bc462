//! One result row per configuration and its CSV and JSON forms.

use super::*;

/// One line of the CSV.
#[derive(Clone, Debug, serde::Serialize)]
pub(super) struct Row {
    /// `gpu` (a GPU frame) or `exact` (the exact discrete solution, on the CPU).
    pub(super) solver: &'static str,
    pub(super) family: usize,
    pub(super) family_name: String,
    pub(super) colour: String,
    pub(super) k: f64,
    pub(super) levels: u32,
    pub(super) resolution: u32,
    pub(super) scheme: &'static str,
    pub(super) precision: Option<&'static str>,
    pub(super) start: Option<&'static str>,
    /// GPU rows: `cascade` or `multigrid` (`--schedule`).
    pub(super) schedule: Option<&'static str>,
    pub(super) iterations_cap: Option<u32>,
    pub(super) tolerance: Option<f32>,
    pub(super) iterations: Vec<u32>,
    /// Sum over levels of iterations x nodes: a work measure that, unlike lavapipe's times on
    /// a loaded machine, does not move between runs.
    pub(super) node_updates: Option<u64>,
    pub(super) finest_nodes: usize,
    pub(super) finest_surface_nodes: usize,
    pub(super) solve_gpu_ms: Option<f64>,
    pub(super) frame_gpu_ms: Option<f64>,
    pub(super) cpu_s: Option<f64>,
    pub(super) gpu_bytes: Option<u64>,
    pub(super) bytes_per_node: Option<f64>,
    pub(super) discrete: Errors,
    /// (a') against the exact solution of the same system for the q this frame gathered: the
    /// error the iterations leave, without the gather's (shadow maps, fp16 q).
    pub(super) solver_error: Errors,
    pub(super) closed_form: Option<Errors>,
    pub(super) image: Option<Errors>,
    pub(super) pareto_solver: bool,
    pub(super) pareto_image: bool,
    /// GPU rows: `off` or `local` (`--bounce`).
    pub(super) bounce: Option<&'static str>,
    /// GPU rows: the exit lobe (`--exit-lobe`).
    pub(super) exit_lobe: Option<&'static str>,
}

pub(super) const CSV_HEADER: &str =
    "solver,family,family_name,colour,k,levels,resolution,scheme,precision,start,schedule,\
iterations_cap,tolerance,iterations_per_level,node_updates,finest_nodes,finest_surface_nodes,solve_gpu_ms,\
frame_gpu_ms,cpu_s,gpu_bytes,bytes_per_node,discrete_r,discrete_g,discrete_b,discrete_all,\
solver_r,solver_g,solver_b,solver_all,\
closed_form_r,closed_form_g,closed_form_b,closed_form_all,image_r,image_g,image_b,image_all,\
pareto_solver,pareto_image,bounce,exit_lobe";

pub(super) fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map_or(String::new(), |v| v.to_string())
}

pub(super) fn errs(e: Option<&Errors>) -> String {
    (0..4)
        .map(|c| {
            e.and_then(|e| e[c])
                .map_or(String::new(), |v| format!("{v:.6e}"))
        })
        .collect::<Vec<_>>()
        .join(",")
}

impl Row {
    pub(super) fn empty() -> Row {
        Row {
            solver: "gpu",
            family: 0,
            family_name: String::new(),
            colour: String::new(),
            k: 0.0,
            levels: 0,
            resolution: 0,
            scheme: "fv",
            precision: None,
            start: None,
            schedule: None,
            iterations_cap: None,
            tolerance: None,
            iterations: Vec::new(),
            node_updates: None,
            finest_nodes: 0,
            finest_surface_nodes: 0,
            solve_gpu_ms: None,
            frame_gpu_ms: None,
            cpu_s: None,
            gpu_bytes: None,
            bytes_per_node: None,
            discrete: [None; 4],
            solver_error: [None; 4],
            closed_form: None,
            image: None,
            pareto_solver: false,
            pareto_image: false,
            bounce: None,
            exit_lobe: None,
        }
    }

    pub(super) fn csv(&self) -> String {
        let iterations: Vec<String> = self.iterations.iter().map(u32::to_string).collect();
        [
            self.solver.to_string(),
            self.family.to_string(),
            self.family_name.clone(),
            self.colour.clone(),
            self.k.to_string(),
            self.levels.to_string(),
            self.resolution.to_string(),
            self.scheme.to_string(),
            opt(self.precision),
            opt(self.start),
            opt(self.schedule),
            opt(self.iterations_cap),
            opt(self.tolerance),
            iterations.join(";"),
            opt(self.node_updates),
            self.finest_nodes.to_string(),
            self.finest_surface_nodes.to_string(),
            opt(self.solve_gpu_ms.map(|v| format!("{v:.3}"))),
            opt(self.frame_gpu_ms.map(|v| format!("{v:.3}"))),
            opt(self.cpu_s.map(|v| format!("{v:.3}"))),
            opt(self.gpu_bytes),
            opt(self.bytes_per_node.map(|v| format!("{v:.1}"))),
            errs(Some(&self.discrete)),
            errs(Some(&self.solver_error)),
            errs(self.closed_form.as_ref()),
            errs(self.image.as_ref()),
            self.pareto_solver.to_string(),
            self.pareto_image.to_string(),
            opt(self.bounce),
            opt(self.exit_lobe),
        ]
        .join(",")
    }

    /// The error drawn in the plot's second panel: the image's, else the closed form's.
    pub(super) fn absolute(&self) -> Option<f64> {
        self.image.or(self.closed_form).and_then(|e| e[3])
    }

    /// What the solve did: iterations per level for the cascade, work units (node updates per
    /// finest node) for the multigrid, whose per-level iteration counters stay at zero.
    fn work(&self) -> String {
        match (self.schedule, self.node_updates) {
            (Some("multigrid"), Some(updates)) if self.finest_nodes > 0 => format!(
                "{:.1} work units",
                updates as f64 / self.finest_nodes as f64
            ),
            _ => format!("iterations {:?}", self.iterations),
        }
    }

    pub(super) fn summary(&self) -> String {
        let e = |v: Option<&Errors>| {
            v.and_then(|e| e[3])
                .map_or_else(|| "-".to_string(), |v| format!("{v:.2e}"))
        };
        let ms = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| format!("{v:.1}"));
        format!(
            "{:<5} {:<40} cap {:>5} tol {:>7} | {} | solve {} ms, frame {} ms | error: discrete {}, solver {}, closed form {}, image {}",
            self.solver,
            self.family_name,
            opt(self.iterations_cap),
            opt(self.tolerance),
            self.work(),
            ms(self.solve_gpu_ms),
            ms(self.frame_gpu_ms),
            e(Some(&self.discrete)),
            e(Some(&self.solver_error)),
            e(self.closed_form.as_ref()),
            e(self.image.as_ref()),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_summary_names_work_units_for_the_multigrid_and_iterations_for_the_cascade() {
        let mut row = Row::empty();
        row.iterations = vec![0, 0, 0];
        row.node_updates = Some(3975);
        row.finest_nodes = 100;
        row.schedule = Some("multigrid");
        assert!(
            row.summary().contains("| 39.8 work units |"),
            "{}",
            row.summary()
        );
        row.schedule = Some("cascade");
        row.iterations = vec![184, 336, 608];
        assert!(
            row.summary().contains("| iterations [184, 336, 608] |"),
            "{}",
            row.summary()
        );
    }
}

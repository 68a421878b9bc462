//! The overlay's text, as a grid of character cells the present shader draws with an 8x8 bitmap
//! font (`font8x8`'s public-domain glyphs): per pass GPU ms, the solve's iterations per level
//! (cascade) or cycles and work units (multigrid), the skipped
//! passes with their reasons, the switches, and the key list. Lines are laid out on the CPU
//! (a few hundred cells); the GPU reads one `u32` per cell.

use std::collections::BTreeMap;

/// Colours of the overlay (indices into the palette of `viewer/present.frag`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Colour {
    Text = 0,
    Dim = 1,
    Heading = 2,
    Warning = 3,
    Good = 4,
}

/// Glyph rows of ASCII 0..128, four rows (bytes) per `u32`, little-endian: what the shader's
/// `font` buffer holds. Row byte bit `i` is pixel column `i` (left first).
pub fn font_words() -> Vec<u32> {
    font8x8::legacy::BASIC_LEGACY
        .iter()
        .flat_map(|glyph| {
            [
                u32::from_le_bytes([glyph[0], glyph[1], glyph[2], glyph[3]]),
                u32::from_le_bytes([glyph[4], glyph[5], glyph[6], glyph[7]]),
            ]
        })
        .collect()
}

/// Bit 16 of a cell: the cell belongs to a line of text (the shader darkens behind it).
pub const CELL_PANEL: u32 = 1 << 16;

/// `lines` laid out in a `cols` x `rows` grid, top-left first: per cell `ascii | colour << 8`,
/// plus [`CELL_PANEL`] for the cells of a line up to its end. Longer lines are cut; characters
/// outside printable ASCII show as `?`.
pub fn layout(lines: &[(String, Colour)], cols: usize, rows: usize) -> Vec<u32> {
    let mut cells = vec![u32::from(b' '); cols * rows];
    for (row, (text, colour)) in lines.iter().take(rows).enumerate() {
        let width = text.chars().count().min(cols);
        // One blank cell of panel after the text, so the last glyph does not touch the scene.
        for col in 0..(width + 1).min(cols) {
            let c = text.chars().nth(col).unwrap_or(' ');
            let code = if c.is_ascii() && !c.is_ascii_control() {
                c as u32
            } else {
                u32::from(b'?')
            };
            cells[row * cols + col] = code | (*colour as u32) << 8 | CELL_PANEL;
        }
    }
    cells
}

/// GPU ms per scope name with its nesting depth (0: a frame-graph pass or a host pass; 1: a
/// scope inside one, such as `diffusion jacobi` inside `diffusion`), in the order the scopes
/// first ran, with the frame's total (the sum of the top-level scopes).
pub fn passes_in_order(timings: &translucent::vk::FrameTimings) -> (Vec<(String, f64, u32)>, f64) {
    let mut order: Vec<(String, f64, u32)> = Vec::new();
    let mut total = 0.0;
    for scope in &timings.scopes {
        if scope.depth == 0 {
            total += scope.duration_ms;
        }
        match order.iter_mut().find(|(n, _, _)| *n == scope.name) {
            Some((_, ms, _)) => *ms += scope.duration_ms,
            None => order.push((scope.name.clone(), scope.duration_ms, scope.depth)),
        }
    }
    (order, total)
}

/// The skipped passes of a frame as `pass: reason` lines.
pub fn skipped_lines(skipped: &BTreeMap<&'static str, translucent::SkipReason>) -> Vec<String> {
    skipped
        .iter()
        .map(|(pass, why)| format!("  {pass}: {why}"))
        .collect()
}

/// The overlay's line for a completed solve and its colour: per level iterations for the
/// cascade; cycles, work units and the relative residual for the multigrid schedule, whose
/// levels run none of the cascade's Jacobi iterations (they would read [0, 0, 0]).
pub fn solve_line(solve: &translucent::frame::CompletedSolve) -> (String, Colour) {
    let frame = solve.frame.saturating_sub(1);
    let converged = solve.converged();
    let text = match &solve.multigrid {
        Some(mg) => format!(
            "solve of frame {frame}: multigrid, {} cycles{}, {:.1} work units, residual {:.1e}{}{}",
            mg.cycles.len(),
            if mg.warm { " (warm)" } else { "" },
            mg.work_units,
            mg.residual,
            // `--bounce source`: the second solve of the same frame.
            solve.bounce.as_ref().map_or_else(String::new, |b| format!(
                "; bounce {} cycles, {:.1} work units",
                b.cycles.len(),
                b.work_units
            )),
            match (converged, &solve.bounce) {
                (true, _) => String::new(),
                (false, Some(b)) if mg.converged => format!(" (bounce {:?})", b.state),
                (false, _) => format!(" ({:?})", mg.state),
            }
        ),
        None => format!(
            "solve of frame {frame}: iterations per level {:?}{}",
            solve.iterations(),
            if converged { "" } else { " (cap reached)" }
        ),
    };
    (
        text,
        if converged {
            Colour::Text
        } else {
            Colour::Warning
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use translucent::vk::{FrameTimings, ScopeTiming};

    #[test]
    fn layout_cuts_long_lines_marks_the_panel_and_replaces_non_ascii() {
        let cells = layout(
            &[
                ("ab".into(), Colour::Heading),
                ("x\u{e9}yz".into(), Colour::Text),
                ("dropped".into(), Colour::Text),
            ],
            3,
            2,
        );
        assert_eq!(cells.len(), 6);
        assert_eq!(cells[0], u32::from(b'a') | 2 << 8 | CELL_PANEL);
        assert_eq!(
            cells[2],
            u32::from(b' ') | 2 << 8 | CELL_PANEL,
            "one cell of margin"
        );
        assert_eq!(cells[4] & 0xff, u32::from(b'?'));
        assert_eq!(cells[5] & 0xff, u32::from(b'y'), "cut at 3 columns");
        let empty = layout(&[], 4, 1);
        assert!(empty.iter().all(|&c| c == u32::from(b' ')));
    }

    #[test]
    fn font_words_hold_every_glyph_row() {
        let words = font_words();
        assert_eq!(words.len(), 128 * 2);
        // 'A' (65) has lit pixels, ' ' (32) has none.
        assert!(words[65 * 2] != 0 || words[65 * 2 + 1] != 0);
        assert_eq!((words[32 * 2], words[32 * 2 + 1]), (0, 0));
    }

    #[test]
    fn passes_keep_execution_order_sum_repeats_and_total_the_top_level() {
        let scope = |name: &str, depth, ms| ScopeTiming {
            name: name.into(),
            depth,
            start_ms: 0.0,
            duration_ms: ms,
        };
        let t = FrameTimings {
            frame: 3,
            scopes: vec![
                scope("shadow_map", 0, 1.0),
                scope("diffusion jacobi", 0, 2.0),
                scope("inner", 1, 0.5),
                scope("diffusion jacobi", 0, 3.0),
                scope("shading", 0, 0.25),
            ],
        };
        let (order, total) = passes_in_order(&t);
        let names: Vec<&str> = order.iter().map(|(n, _, _)| n.as_str()).collect();
        assert_eq!(
            names,
            ["shadow_map", "diffusion jacobi", "inner", "shading"]
        );
        assert_eq!(order[1].1, 5.0);
        assert_eq!(order[2].2, 1, "inner is nested");
        assert_eq!(total, 6.25);
    }

    fn level(iterations: u32, stopped_early: u32) -> translucent::solver::gpu::LevelControl {
        translucent::solver::gpu::LevelControl {
            iterations,
            stopped_early,
            ..Default::default()
        }
    }

    #[test]
    fn a_multigrid_solve_shows_cycles_and_work_units_not_the_cascades_zeros() {
        use translucent::solver::gpu::multigrid::{CycleState, GpuMultigridReport};
        use translucent::solver::multigrid::CycleReport;
        let cycle = |residual: f64, work_units: f64| CycleReport {
            residual,
            factor: 0.1,
            work_units,
        };
        let mut solve = translucent::frame::CompletedSolve {
            frame: 3,
            levels: vec![level(0, 0); 3],
            multigrid: Some(GpuMultigridReport {
                warm: false,
                cycles: vec![cycle(0.06, 16.7), cycle(6e-3, 12.1), cycle(6e-5, 12.1)],
                start_residual: 0.06,
                residual: 6e-5,
                converged: true,
                state: CycleState::Converged,
                work_units: 40.9,
                matvec_units: 80.0,
                mean_factor: Some(0.1),
                coarse_steps: 8,
                warm_order: 0,
                local_nodes: 0,
                texel_reads: false,
                packed_columns: true,
            }),
            bounce: None,
        };
        let (text, colour) = solve_line(&solve);
        assert_eq!(
            text,
            "solve of frame 2: multigrid, 3 cycles, 40.9 work units, residual 6.0e-5"
        );
        assert_eq!(colour, Colour::Text);
        assert!(!text.contains("[0, 0, 0]"), "{text}");
        if let Some(mg) = &mut solve.multigrid {
            mg.converged = false;
            mg.state = CycleState::Diverged;
        }
        let (text, colour) = solve_line(&solve);
        assert!(text.ends_with("(Diverged)"), "{text}");
        assert_eq!(colour, Colour::Warning);
        // `--bounce source`: the second solve's work shows, and so does its failure.
        if let Some(mg) = &mut solve.multigrid {
            mg.converged = true;
            mg.state = CycleState::Converged;
        }
        let mut second = solve.multigrid.clone().expect("a multigrid report");
        second.converged = false;
        second.state = CycleState::Diverged;
        second.work_units = 27.7;
        second.cycles.truncate(2);
        solve.bounce = Some(second);
        let (text, colour) = solve_line(&solve);
        assert!(
            text.contains("; bounce 2 cycles, 27.7 work units"),
            "{text}"
        );
        assert!(text.ends_with("(bounce Diverged)"), "{text}");
        assert_eq!(colour, Colour::Warning);
        // The cascade keeps its iterations per level.
        let cascade = translucent::frame::CompletedSolve {
            frame: 3,
            levels: vec![
                level(40, translucent::solver::gpu::LevelControl::CONVERGED),
                level(12, translucent::solver::gpu::LevelControl::CONVERGED),
            ],
            multigrid: None,
            bounce: None,
        };
        assert_eq!(
            solve_line(&cascade),
            (
                "solve of frame 2: iterations per level [40, 12]".to_string(),
                Colour::Text
            )
        );
    }
}

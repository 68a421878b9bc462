//! The run time against error chart (`translucent_benches::plot`) and `--replot` from a CSV.

use std::path::Path;

use anyhow::Context as _;
use translucent::vk::capture::write_atomically;
use translucent_benches::plot::{error_vs_time, palette, palette_hex, Panel, Series};

use super::*;

/// Redraws `dir/bench.png` from `dir/bench.csv` (the columns the plot reads).
pub(super) fn replot(dir: &Path) -> anyhow::Result<()> {
    let csv_path = dir.join("bench.csv");
    let text = std::fs::read_to_string(&csv_path)
        .with_context(|| format!("--replot: reading {}", csv_path.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let column = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .with_context(|| format!("{}: no column {name}", csv_path.display()))
    };
    let [solver, family, family_name, ms, discrete, closed, image, front_d, front_i] = [
        "solver",
        "family",
        "family_name",
        "solve_gpu_ms",
        "solver_all",
        "closed_form_all",
        "image_all",
        "pareto_solver",
        "pareto_image",
    ]
    .map(column);
    let (solver, family, family_name, ms) = (solver?, family?, family_name?, ms?);
    let discrete = discrete?;
    let (closed, image, front_d, front_i) = (closed?, image?, front_d?, front_i?);
    let mut rows = Vec::new();
    for (n, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        let bad = || anyhow::anyhow!("{} line {}: malformed", csv_path.display(), n + 2);
        if cells.len() != header.len() {
            return Err(bad());
        }
        let number = |i: usize| -> anyhow::Result<Option<f64>> {
            match cells[i] {
                "" => Ok(None),
                v => v.parse::<f64>().map(Some).map_err(|_| bad()),
            }
        };
        let all = |i: usize| -> anyhow::Result<Option<Errors>> {
            Ok(number(i)?.map(|v| [None, None, None, Some(v)]))
        };
        rows.push(Row {
            solver: if cells[solver] == "exact" {
                "exact"
            } else {
                "gpu"
            },
            family: cells[family].parse().map_err(|_| bad())?,
            family_name: cells[family_name].to_string(),
            solve_gpu_ms: number(ms)?,
            solver_error: all(discrete)?.unwrap_or([None; 4]),
            closed_form: all(closed)?,
            image: all(image)?,
            pareto_solver: cells[front_d] == "true",
            pareto_image: cells[front_i] == "true",
            ..Row::empty()
        });
    }
    let png_path = dir.join("bench.png");
    write_atomically(&png_path, |tmp| plot(tmp, &rows).map_err(|e| e.to_string()))
        .with_context(|| format!("writing {}", png_path.display()))?;
    println!("wrote {}", png_path.display());
    Ok(())
}

pub(super) fn colour_name(family: usize) -> String {
    palette_hex(family)
}

/// Log-log error against solve GPU ms (`translucent_benches::plot`): one colour per family (named
/// in the legend), the Pareto front in black. Left: error (a); right (when any row has one): error (c) or (b), with
/// each exact row's value (the floor) as a grey line.
pub(super) fn plot(path: &Path, rows: &[Row]) -> Result<(), Box<dyn std::error::Error>> {
    type ErrorOf<'a> = &'a dyn Fn(&Row) -> Option<f64>;
    type OnFront<'a> = &'a dyn Fn(&Row) -> bool;
    let solver = |r: &Row| r.solver_error[3];
    let absolute = |r: &Row| r.absolute();
    let mut kinds: Vec<(ErrorOf, OnFront)> = vec![(&solver, &|r: &Row| r.pareto_solver)];
    if rows.iter().any(|r| r.absolute().is_some()) {
        kinds.push((&absolute, &|r: &Row| r.pareto_image));
    }
    let families = rows.iter().map(|r| r.family).max().map_or(0, |m| m + 1);
    let panels: Vec<Panel> = kinds
        .iter()
        .map(|(error, on_front)| {
            let timed = |r: &Row| Some((r.solve_gpu_ms?, error(r)?));
            Panel {
                series: (0..families)
                    .map(|f| Series {
                        name: rows
                            .iter()
                            .find(|r| r.family == f)
                            .map_or_else(String::new, |r| r.family_name.clone()),
                        colour: palette(f),
                        points: rows
                            .iter()
                            .filter(|r| r.family == f)
                            .filter_map(timed)
                            .collect(),
                    })
                    .collect(),
                front: rows
                    .iter()
                    .filter(|r| on_front(r))
                    .filter_map(timed)
                    .collect(),
                floors: rows
                    .iter()
                    .filter(|r| r.solver == "exact")
                    .filter_map(error)
                    .filter(|&e| e > 0.0)
                    .collect(),
            }
        })
        .collect();
    error_vs_time(path, &panels)
}

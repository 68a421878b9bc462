//! Benchmarks: see `benches/` and `benches/RESULTS.md`. This library holds what the bench bins
//! and `translucent bench` share: [`plot::error_vs_time`], the log-log chart of error against GPU
//! time with the Pareto front; [`soak`], the per-frame schedule the soak bin and the CI soak
//! test (`tests/tests/soak.rs`) both run; and [`fixtures`], the hand-made OBJ meshes of the stress
//! matrix (`stress` bin) and its CI tests (`tests/tests/stress_geometry.rs`).
//!
//! ```no_run
//! use translucent_benches::plot::{error_vs_time, palette, Panel, Series};
//! let panel = Panel {
//!     series: vec![Series {
//!         name: "K4 mixed cold".into(),
//!         colour: palette(0),
//!         points: vec![(10.0, 1e-2), (40.0, 1e-3)],
//!     }],
//!     front: vec![(10.0, 1e-2), (40.0, 1e-3)],
//!     floors: vec![5e-4],
//! };
//! error_vs_time(std::path::Path::new("plot.png"), &[panel]).expect("plot");
//! ```

pub mod plot {
    //! Log-log plots without a font backend (this `plotters` build has none): decade tick labels
    //! are drawn with a built-in 3x5 pixel font holding only digits, `.`, `-` and `e`; the axis
    //! titles ([`X_TITLE`], [`Y_TITLE`]) with the 8x8 bitmap font of the `font8x8` crate (the y
    //! title turned a quarter) and the legend under each panel naming every series, the Pareto
    //! front and the floor.

    use std::path::Path;

    use plotters::coord::Shift;
    use plotters::prelude::*;
    pub use plotters::style::RGBColor;

    type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

    /// Points of one family, joined in the order given (e.g. of decreasing error: measured times
    /// are noisy, and sorting by them would zigzag).
    pub struct Series {
        /// Shown in the legend (printable ASCII; other characters are drawn as `?`).
        pub name: String,
        pub colour: RGBColor,
        pub points: Vec<(f64, f64)>,
    }

    /// One chart: x = GPU ms, y = error.
    pub struct Panel {
        pub series: Vec<Series>,
        /// The Pareto front: drawn as a black line with ringed points.
        pub front: Vec<(f64, f64)>,
        /// Horizontal grey lines (e.g. the exact solution's error: the floor).
        pub floors: Vec<f64>,
    }

    /// Colour `i` of the palette the CSVs name (`Palette99`).
    pub fn palette(i: usize) -> RGBColor {
        let (r, g, b) = Palette99::pick(i).rgb();
        RGBColor(r, g, b)
    }

    /// `#rrggbb` of [`palette`]`(i)`.
    pub fn palette_hex(i: usize) -> String {
        let RGBColor(r, g, b) = palette(i);
        format!("#{r:02x}{g:02x}{b:02x}")
    }

    /// Values at or below this are drawn at it (a log axis has no 0).
    pub const LOG_FLOOR: f64 = 1e-7;

    /// 3x5 glyphs, one row per 3 bits (top first).
    fn glyph(c: char) -> Option<[u8; 5]> {
        Some(match c {
            '0' => [0b111, 0b101, 0b101, 0b101, 0b111],
            '1' => [0b010, 0b110, 0b010, 0b010, 0b111],
            '2' => [0b111, 0b001, 0b111, 0b100, 0b111],
            '3' => [0b111, 0b001, 0b111, 0b001, 0b111],
            '4' => [0b101, 0b101, 0b111, 0b001, 0b001],
            '5' => [0b111, 0b100, 0b111, 0b001, 0b111],
            '6' => [0b111, 0b100, 0b111, 0b101, 0b111],
            '7' => [0b111, 0b001, 0b001, 0b001, 0b001],
            '8' => [0b111, 0b101, 0b111, 0b101, 0b111],
            '9' => [0b111, 0b101, 0b111, 0b001, 0b111],
            '.' => [0b000, 0b000, 0b000, 0b000, 0b010],
            '-' => [0b000, 0b000, 0b111, 0b000, 0b000],
            'e' => [0b010, 0b101, 0b111, 0b100, 0b011],
            _ => return None,
        })
    }

    const SCALE: i32 = 2;

    /// The axis titles every panel gets.
    pub const X_TITLE: &str = "solve GPU time (ms)";
    pub const Y_TITLE: &str = "relative RMS error";

    /// Draws `text` in the 8x8 font (ASCII), top-left at `at`; `vertical` turns it a quarter
    /// counter-clockwise (reading bottom to top, `at` is then the bottom-left).
    fn draw_title(
        area: &DrawingArea<BitMapBackend, Shift>,
        text: &str,
        at: (i32, i32),
        vertical: bool,
    ) -> Result<()> {
        for (i, c) in text.chars().enumerate() {
            let Some(rows) = font8x8::legacy::BASIC_LEGACY.get(c as usize) else {
                continue;
            };
            let advance = i as i32 * 8;
            for (y, bits) in rows.iter().enumerate() {
                for x in 0..8 {
                    // font8x8: bit 0 is the leftmost pixel.
                    if bits & (1 << x) != 0 {
                        let (gx, gy) = (advance + x, y as i32);
                        let p = if vertical {
                            (at.0 + gy, at.1 - gx)
                        } else {
                            (at.0 + gx, at.1 + gy)
                        };
                        area.draw_pixel(p, &BLACK)?;
                    }
                }
            }
        }
        Ok(())
    }

    /// Width in pixels of `text` in the pixel font.
    fn text_width(text: &str) -> i32 {
        text.chars().count() as i32 * 4 * SCALE - SCALE
    }

    /// Draws `text` with its top-left corner at `at` (pixels of `area`).
    fn draw_text(
        area: &DrawingArea<BitMapBackend, Shift>,
        text: &str,
        at: (i32, i32),
    ) -> Result<()> {
        for (i, c) in text.chars().enumerate() {
            let Some(rows) = glyph(c) else { continue };
            let x0 = at.0 + i as i32 * 4 * SCALE;
            for (y, bits) in rows.iter().enumerate() {
                for x in 0..3 {
                    if bits & (0b100 >> x) != 0 {
                        let (px, py) = (x0 + x * SCALE, at.1 + y as i32 * SCALE);
                        area.draw(&Rectangle::new(
                            [(px, py), (px + SCALE, py + SCALE)],
                            BLACK.filled(),
                        ))?;
                    }
                }
            }
        }
        Ok(())
    }

    /// `10^p` as a short label: plain between 0.01 and 1000, else `1eP`.
    fn decade_label(p: i32) -> String {
        match p {
            -2 => "0.01".into(),
            -1 => "0.1".into(),
            0..=3 => 10u32.pow(p as u32).to_string(),
            _ => format!("1e{p}"),
        }
    }

    /// Height of the chart part of an [`error_vs_time`] panel (the legend goes below it).
    const CHART_HEIGHT: u32 = 560;
    /// The legend's columns per panel, and the pixels per column and per line: two columns from
    /// x = 16 end inside the 700-pixel panel (names are cut to their column's width).
    const LEGEND_COLUMNS: usize = 2;
    const LEGEND_COLUMN_WIDTH: i32 = 330;
    const LEGEND_LINE: i32 = 14;

    /// What one legend line shows before its name.
    enum Swatch {
        /// A series: a short line with a dot in its colour.
        Series(RGBColor),
        /// The Pareto front: a black line with a ring.
        Front,
        /// A floor: a grey line.
        Floor,
    }

    /// The legend lines of `panel`: each series with points, the front, the floors.
    fn legend(panel: &Panel) -> Vec<(Swatch, String)> {
        let mut lines: Vec<(Swatch, String)> = panel
            .series
            .iter()
            .filter(|s| !s.points.is_empty())
            .map(|s| (Swatch::Series(s.colour), s.name.clone()))
            .collect();
        if !panel.front.is_empty() {
            lines.push((Swatch::Front, "Pareto front".into()));
        }
        if !panel.floors.is_empty() {
            lines.push((Swatch::Floor, "exact solution (floor)".into()));
        }
        lines
    }

    /// Draws `lines` in columns from `at` (top-left), cutting names to their column's width.
    fn draw_legend(
        area: &DrawingArea<BitMapBackend, Shift>,
        lines: &[(Swatch, String)],
        at: (i32, i32),
    ) -> Result<()> {
        let rows = lines.len().div_ceil(LEGEND_COLUMNS);
        let fits = ((LEGEND_COLUMN_WIDTH - 40) / 8) as usize;
        for (i, (swatch, name)) in lines.iter().enumerate() {
            let (column, row) = (i / rows.max(1), i % rows.max(1));
            let x = at.0 + column as i32 * LEGEND_COLUMN_WIDTH;
            let y = at.1 + row as i32 * LEGEND_LINE;
            let (a, b, mid) = ((x, y + 4), (x + 24, y + 4), (x + 12, y + 4));
            match swatch {
                Swatch::Series(colour) => {
                    area.draw(&PathElement::new(vec![a, b], colour.stroke_width(1)))?;
                    area.draw(&Circle::new(mid, 4, colour.filled()))?;
                }
                Swatch::Front => {
                    area.draw(&PathElement::new(vec![a, b], BLACK.stroke_width(2)))?;
                    area.draw(&Circle::new(mid, 5, BLACK.stroke_width(2)))?;
                }
                Swatch::Floor => {
                    let grey = RGBColor(150, 150, 150);
                    area.draw(&PathElement::new(vec![a, b], grey.stroke_width(2)))?;
                }
            }
            let shown: String = if name.chars().count() > fits {
                name.chars().take(fits - 1).chain(['~']).collect()
            } else {
                name.clone()
            };
            draw_text8(area, &shown, (x + 32, y), false, BLACK)?;
        }
        Ok(())
    }

    /// Writes a PNG of the panels side by side (700 x 560 each, and the legend below):
    /// log-log, decade grid with labels, axis titles, each series in its colour (lines and
    /// dots), the front in black, floors in grey, and a legend naming them.
    pub fn error_vs_time(path: &Path, panels: &[Panel]) -> Result<()> {
        let count = panels.len().max(1);
        let legend_rows = panels
            .iter()
            .map(|p| legend(p).len().div_ceil(LEGEND_COLUMNS))
            .max()
            .unwrap_or(0) as i32;
        let legend_height = (legend_rows * LEGEND_LINE + 16) as u32;
        let root = BitMapBackend::new(path, (700 * count as u32, CHART_HEIGHT + legend_height))
            .into_drawing_area();
        root.fill(&WHITE)?;
        let (charts, legends) = root.split_vertically(CHART_HEIGHT);
        let areas = charts.split_evenly((1, count));
        for (i, (panel, area)) in panels.iter().zip(&areas).enumerate() {
            draw_legend(&legends, &legend(panel), (700 * i as i32 + 16, 4))?;
            let all = panel
                .series
                .iter()
                .flat_map(|s| s.points.iter().copied())
                .chain(panel.front.iter().copied());
            let (mut x0, mut x1, mut y0, mut y1) =
                (f64::MAX, f64::MIN_POSITIVE, f64::MAX, LOG_FLOOR);
            for (x, y) in all {
                (x0, x1) = (x0.min(x.max(1e-3)), x1.max(x));
                (y0, y1) = (y0.min(y.max(LOG_FLOOR)), y1.max(y));
            }
            for &f in &panel.floors {
                (y0, y1) = (y0.min(f.max(LOG_FLOOR)), y1.max(f));
            }
            if x0 > x1 {
                (x0, x1, y0, y1) = (1.0, 10.0, LOG_FLOOR, 1.0);
            }
            let (x0, x1, y0, y1) = (x0 * 0.8, x1 * 1.25, y0 * 0.5, y1 * 2.0);
            // No label areas and no `configure_mesh`: both make plotters lay out text, which
            // panics without a font. The margins leave room for the pixel-font labels.
            let mut chart = ChartBuilder::on(area)
                .margin(16)
                .margin_left(80)
                .margin_bottom(48)
                .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)],
                BLACK.stroke_width(1),
            )))?;
            let grey = RGBColor(225, 225, 225);
            let decades =
                |lo: f64, hi: f64| (lo.log10().ceil() as i32)..=(hi.log10().floor() as i32);
            for p in decades(x0, x1) {
                let x = 10f64.powi(p);
                chart.draw_series(LineSeries::new([(x, y0), (x, y1)], grey.stroke_width(1)))?;
                let (px, py) = chart.backend_coord(&(x, y0));
                let label = decade_label(p);
                draw_text(&root, &label, (px - text_width(&label) / 2, py + 6))?;
            }
            // Axis titles: centred under the x axis, along the y axis at the left edge.
            let (left, bottom) = chart.backend_coord(&(x0, y0));
            let (right, top) = chart.backend_coord(&(x1, y1));
            let title_x = (left + right) / 2 - 4 * X_TITLE.len() as i32;
            draw_title(&root, X_TITLE, (title_x, bottom + 24), false)?;
            let title_y = (top + bottom) / 2 + 4 * Y_TITLE.len() as i32;
            draw_title(&root, Y_TITLE, (left - 76, title_y), true)?;
            for p in decades(y0, y1) {
                let y = 10f64.powi(p);
                chart.draw_series(LineSeries::new([(x0, y), (x1, y)], grey.stroke_width(1)))?;
                let (px, py) = chart.backend_coord(&(x0, y));
                let label = decade_label(p);
                draw_text(&root, &label, (px - text_width(&label) - 6, py - 5))?;
            }
            for &f in &panel.floors {
                chart.draw_series(LineSeries::new(
                    [(x0, f.max(LOG_FLOOR)), (x1, f.max(LOG_FLOOR))],
                    RGBColor(150, 150, 150).stroke_width(2),
                ))?;
            }
            for s in &panel.series {
                let pts: Vec<(f64, f64)> = s
                    .points
                    .iter()
                    .map(|&(x, y)| (x, y.max(LOG_FLOOR)))
                    .collect();
                chart.draw_series(LineSeries::new(
                    pts.iter().copied(),
                    s.colour.stroke_width(1),
                ))?;
                chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, s.colour.filled())))?;
            }
            let mut front: Vec<(f64, f64)> = panel
                .front
                .iter()
                .map(|&(x, y)| (x, y.max(LOG_FLOOR)))
                .collect();
            front.sort_by(|a, b| a.0.total_cmp(&b.0));
            chart.draw_series(LineSeries::new(
                front.iter().copied(),
                BLACK.stroke_width(2),
            ))?;
            chart.draw_series(
                front
                    .iter()
                    .map(|&p| Circle::new(p, 8, BLACK.stroke_width(2))),
            )?;
        }
        root.present()?;
        Ok(())
    }

    /// A point's marker on [`methods_chart`]: with the colour, what tells the methods apart
    /// (in grey print too).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Marker {
        Circle,
        Triangle,
        Square,
        Cross,
    }

    /// One method on [`methods_chart`]: its points (x, y, a short label written beside the
    /// point, e.g. the scene's number), not joined.
    pub struct Labelled {
        pub name: String,
        pub colour: RGBColor,
        pub marker: Marker,
        pub points: Vec<(f64, f64, String)>,
    }

    /// One panel of [`methods_chart`]: axis titles (units included) and the methods.
    pub struct LabelledPanel {
        pub title: String,
        pub x_title: String,
        pub y_title: String,
        pub series: Vec<Labelled>,
    }

    /// Draws `text` in `font8x8`'s 8x8 glyphs (printable ASCII), top-left at `at`; `vertical`
    /// turns it 90 degrees counter-clockwise (reading bottom to top, `at` its bottom-left).
    fn draw_text8(
        area: &DrawingArea<BitMapBackend, Shift>,
        text: &str,
        at: (i32, i32),
        vertical: bool,
        colour: RGBColor,
    ) -> Result<()> {
        use font8x8::legacy::BASIC_LEGACY;
        for (i, c) in text.chars().enumerate() {
            let code = if c.is_ascii() {
                c as usize
            } else {
                b'?' as usize
            };
            let glyph = BASIC_LEGACY[code];
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) == 0 {
                        continue;
                    }
                    let (x, y) = (i as i32 * 8 + col, row as i32);
                    let p = if vertical {
                        (at.0 + y, at.1 - x)
                    } else {
                        (at.0 + x, at.1 + y)
                    };
                    area.draw_pixel(p, &colour)?;
                }
            }
        }
        Ok(())
    }

    /// Writes a PNG of labelled scatter panels side by side (720 x 600 each): log-log, decade
    /// grid with labels, a title, axis titles, each series with its colour and marker, each point
    /// with its label, and a legend of the series.
    pub fn methods_chart(path: &Path, panels: &[LabelledPanel]) -> Result<()> {
        let count = panels.len().max(1);
        let root = BitMapBackend::new(path, (720 * count as u32, 600)).into_drawing_area();
        root.fill(&WHITE)?;
        let areas = root.split_evenly((1, count));
        for (panel, area) in panels.iter().zip(&areas) {
            let (ox, _) = area.get_base_pixel();
            let (mut x0, mut x1, mut y0, mut y1) =
                (f64::MAX, f64::MIN_POSITIVE, f64::MAX, LOG_FLOOR);
            for (x, y, _) in panel.series.iter().flat_map(|s| s.points.iter()) {
                (x0, x1) = (x0.min(x.max(1e-3)), x1.max(*x));
                (y0, y1) = (y0.min(y.max(LOG_FLOOR)), y1.max(*y));
            }
            if x0 > x1 {
                (x0, x1, y0, y1) = (1.0, 10.0, 0.01, 1.0);
            }
            // At least one decade on each axis, so the grid has a label.
            let (x0, x1) = (x0.min(x1 / 10.0) * 0.7, x1 * 1.5);
            let (y0, y1) = (y0.min(y1 / 10.0) * 0.7, y1 * 1.5);
            let mut chart = ChartBuilder::on(area)
                .margin(16)
                .margin_top(40)
                .margin_left(80)
                .margin_bottom(56)
                .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)],
                BLACK.stroke_width(1),
            )))?;
            let grey = RGBColor(225, 225, 225);
            let decades =
                |lo: f64, hi: f64| (lo.log10().ceil() as i32)..=(hi.log10().floor() as i32);
            for d in decades(x0, x1) {
                let x = 10f64.powi(d);
                chart.draw_series(LineSeries::new([(x, y0), (x, y1)], grey.stroke_width(1)))?;
                let (px, py) = chart.backend_coord(&(x, y0));
                let label = decade_label(d);
                draw_text(&root, &label, (px - text_width(&label) / 2, py + 6))?;
            }
            for d in decades(y0, y1) {
                let y = 10f64.powi(d);
                chart.draw_series(LineSeries::new([(x0, y), (x1, y)], grey.stroke_width(1)))?;
                let (px, py) = chart.backend_coord(&(x0, y));
                let label = decade_label(d);
                draw_text(&root, &label, (px - text_width(&label) - 6, py - 5))?;
            }
            let (left, bottom) = chart.backend_coord(&(x0, y0));
            let (right, top) = chart.backend_coord(&(x1, y1));
            draw_text8(&root, &panel.title, (left, top - 28), false, BLACK)?;
            let x_width = 8 * panel.x_title.chars().count() as i32;
            draw_text8(
                &root,
                &panel.x_title,
                ((left + right - x_width) / 2, bottom + 24),
                false,
                BLACK,
            )?;
            let y_width = 8 * panel.y_title.chars().count() as i32;
            draw_text8(
                &root,
                &panel.y_title,
                (ox + 12, (top + bottom + y_width) / 2),
                true,
                BLACK,
            )?;
            for (k, s) in panel.series.iter().enumerate() {
                let style = s.colour.filled();
                let stroke = s.colour.stroke_width(2);
                for (x, y, label) in &s.points {
                    let c = (*x, y.max(LOG_FLOOR));
                    let one = std::iter::once(c);
                    match s.marker {
                        Marker::Circle => {
                            chart.draw_series(one.map(|c| Circle::new(c, 5, style)))?;
                        }
                        Marker::Triangle => {
                            chart.draw_series(one.map(|c| TriangleMarker::new(c, 7, style)))?;
                        }
                        Marker::Square => {
                            chart.draw_series(one.map(|c| {
                                EmptyElement::at(c) + Rectangle::new([(-5, -5), (5, 5)], style)
                            }))?;
                        }
                        Marker::Cross => {
                            chart.draw_series(one.map(|c| Cross::new(c, 6, stroke)))?;
                        }
                    }
                    let (px, py) = chart.backend_coord(&c);
                    draw_text8(&root, label, (px + 8, py - 10), false, s.colour)?;
                }
                // Legend: above the plot at the right, one entry per series (outside the
                // data, so it hides no point).
                let entries = panel.series.len() as i32;
                let (lx, ly) = (right - 120 * (entries - k as i32), top - 28);
                draw_text8(&root, &s.name, (lx + 14, ly + 2), false, s.colour)?;
                let at = (lx + 4, ly + 6);
                match s.marker {
                    Marker::Circle => root.draw(&Circle::new(at, 5, style))?,
                    Marker::Triangle => root.draw(&TriangleMarker::new(at, 7, style))?,
                    Marker::Square => root.draw(&Rectangle::new(
                        [(at.0 - 5, at.1 - 5), (at.0 + 5, at.1 + 5)],
                        style,
                    ))?,
                    Marker::Cross => root.draw(&Cross::new(at, 6, stroke))?,
                }
            }
        }
        root.present()?;
        Ok(())
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        #[test]
        fn labels_use_only_drawable_characters() {
            for p in -9..=9 {
                let label = decade_label(p);
                assert!(label.chars().all(|c| glyph(c).is_some()), "{label}");
            }
            assert_eq!(decade_label(-3), "1e-3");
            assert_eq!(decade_label(2), "100");
            assert_eq!(text_width("10"), 14);
        }
    }
}

pub mod soak {
    //! The soak's schedule (issue 6 item 4): what changes in frame `i`. One definition for the
    //! long run (`benches/src/bin/soak.rs`) and its CI-sized version (`tests/tests/soak.rs`), so
    //! the test exercises exactly what the recorded 10,000-frame result measured.

    use glam::{DVec3, Mat4, Vec3};
    use translucent::material::{Material, MaterialField, Procedural};
    use translucent::scene::{Environment, Light, Scene};
    use translucent::solver::gpu::Deformation;

    /// Frames after which the material and deformation schedules repeat (4 and 10): what the
    /// object allocates for them depends only on `i % SCHEDULE_PERIOD`.
    pub const SCHEDULE_PERIOD: usize = 20;

    /// A directional light turning 0.2 rad per frame, brightness 1 +- 0.5, a dim environment.
    pub fn scene_at(i: usize) -> Scene {
        let a = 0.2 * i as f64;
        let e = 1.0 + 0.5 * (0.3 * i as f64).sin();
        Scene {
            lights: vec![Light::Directional {
                direction: DVec3::new(a.cos(), -1.0, a.sin()),
                irradiance: [e, 0.9 * e, 0.8 * e],
            }],
            environment: Environment::Constant([0.05; 3]),
        }
    }

    /// Marble with drifting coefficients; every fourth frame a heterogeneous split (marble /
    /// skin1, moving plane) with eta 1.4.
    pub fn material_at(i: usize) -> Result<MaterialField, translucent::material::MaterialError> {
        let t = i as f64;
        let mut m = Material::preset("marble")?;
        for c in 0..3 {
            m.sigma_a[c] *= 1.0 + 0.5 * (0.1 * t).sin();
            m.sigma_s[c] *= 1.0 + 0.3 * (0.13 * t).cos();
        }
        if i % 4 == 3 {
            MaterialField::procedural(
                Procedural::Split {
                    normal: DVec3::new(0.3, 1.0, 0.0).normalize(),
                    offset: 3.0 * (0.05 * t).sin(),
                    below: m.coefficients(),
                    above: Material::preset("skin1")?.coefficients(),
                },
                1.4,
            )
        } else {
            Ok(MaterialField::Homogeneous(m))
        }
    }

    /// A twist of 0.03 sin(0.07 i) rad/mm; every tenth frame the identity, every tenth an affine
    /// squash of y by up to 20%.
    pub fn deformation_at(i: usize) -> Deformation {
        let t = i as f32;
        match i % 10 {
            5 => Deformation::Identity,
            7 => Deformation::Affine(Mat4::from_scale(Vec3::new(
                1.0,
                1.0 - 0.2 * (0.1 * t).sin().abs(),
                1.0,
            ))),
            _ => Deformation::Twist {
                radians_per_mm: 0.03 * (0.07 * t).sin(),
            },
        }
    }
}

pub mod fixtures {
    //! Small OBJ fixtures written by the stress matrix and its CI tests: raw vertex and face
    //! arrays (not `mesh::shapes`, whose boxes are subdivided), so a test can perturb one vertex
    //! or add one degenerate face and write exactly that.

    use std::fmt::Write as _;
    use std::path::Path;

    use glam::DVec3;

    /// Writes a Wavefront OBJ (1-based faces).
    pub fn write_obj(path: &Path, vertices: &[DVec3], faces: &[[u32; 3]]) -> std::io::Result<()> {
        let mut text = String::new();
        for v in vertices {
            // Writing into a String cannot fail.
            let _ = writeln!(text, "v {} {} {}", v.x, v.y, v.z);
        }
        for f in faces {
            let _ = writeln!(text, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1);
        }
        std::fs::write(path, text)
    }

    /// An axis-aligned box centred at the origin: 8 vertices, 12 outward triangles.
    pub fn box_mesh(half: DVec3) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let v = (0..8)
            .map(|i| {
                DVec3::new(
                    if i & 1 == 1 { half.x } else { -half.x },
                    if i & 2 == 2 { half.y } else { -half.y },
                    if i & 4 == 4 { half.z } else { -half.z },
                )
            })
            .collect();
        let f = vec![
            [0, 2, 3],
            [0, 3, 1],
            [4, 5, 7],
            [4, 7, 6],
            [0, 1, 5],
            [0, 5, 4],
            [2, 6, 7],
            [2, 7, 3],
            [0, 4, 6],
            [0, 6, 2],
            [1, 3, 7],
            [1, 7, 5],
        ];
        (v, f)
    }
}

pub mod dipole {
    //! Meshes of the dipole method's benches and tests (`benches/src/bin/dipole.rs`,
    //! `tests/tests/dipole_*.rs`): 4-to-1 midpoint subdivision (the paper's Table 3 uses a
    //! subdivision model at 2k, 8k, 32k and 130k triangles), a flat lit patch, and loading a shared
    //! mesh normalized to a size.

    use std::collections::HashMap;
    use std::path::Path;

    use glam::DVec3;
    use translucent::mesh::{MeshError, TriMesh, ValidateOptions};

    /// Splits every triangle into four at its edge midpoints (the shape is unchanged; midpoints of
    /// shared edges are shared, so a closed mesh stays closed).
    pub fn subdivide_midpoint(mesh: &TriMesh) -> TriMesh {
        let mut out = TriMesh {
            positions: mesh.positions.clone(),
            normals: Vec::new(),
            indices: Vec::with_capacity(4 * mesh.indices.len()),
        };
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, out: &mut TriMesh| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let p = 0.5 * (out.positions[a as usize] + out.positions[b as usize]);
                out.positions.push(p);
                out.positions.len() as u32 - 1
            })
        };
        for &[a, b, c] in &mesh.indices {
            let (ab, bc, ca) = (
                midpoint(a, b, &mut out),
                midpoint(b, c, &mut out),
                midpoint(c, a, &mut out),
            );
            out.indices
                .extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        out.compute_normals();
        out
    }

    /// A flat square patch in the plane y = 0, normal +Y, `cells` x `cells` quads of two triangles
    /// each, `side` mm wide, centred at the origin; interior vertices moved in the plane by up to
    /// `jitter` of a cell (deterministic), so no symmetry of the grid helps the method.
    pub fn flat_patch(side: f64, cells: u32, jitter: f64) -> TriMesh {
        let n = cells + 1;
        let h = side / cells as f64;
        let mut mesh = TriMesh::default();
        for j in 0..n {
            for i in 0..n {
                let mut p = DVec3::new(i as f64 * h - side / 2.0, 0.0, side / 2.0 - j as f64 * h);
                if i > 0 && j > 0 && i < cells && j < cells {
                    // A cheap hash to [-1, 1]^2.
                    let k = (i * 7919 + j * 104_729) as f64;
                    p.x += jitter * h * (k * 0.618_034).fract().mul_add(2.0, -1.0);
                    p.z += jitter * h * (k * 0.414_214).fract().mul_add(2.0, -1.0);
                }
                mesh.positions.push(p);
            }
        }
        for j in 0..cells {
            for i in 0..cells {
                let (a, b) = (j * n + i, j * n + i + 1);
                let (c, d) = (a + n, b + n);
                // Counter-clockwise seen from +Y (z decreases with j).
                mesh.indices.push([a, b, d]);
                mesh.indices.push([a, d, c]);
            }
        }
        mesh.compute_normals();
        mesh
    }

    /// Loads an OBJ, validates it (forced: the dipole method renders open meshes too) and
    /// normalizes its longest side to `size_mm`.
    pub fn load_normalized(path: &Path, size_mm: f64) -> Result<TriMesh, MeshError> {
        let mut mesh = TriMesh::load_obj(path)?;
        mesh.validate(&ValidateOptions {
            force_open: true,
            force_non_manifold: true,
            ..Default::default()
        })?;
        Ok(mesh.normalized(size_mm)?.0)
    }
}

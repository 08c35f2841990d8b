//! The cost of a heat run against the part's size, log-log: docs/PERFORMANCE.md "Parts at full
//! scale". Reads the table `docs/scaling/measure.sh` writes (one row a run: model, mode, dome
//! radius, bead length, deposits, wall time, peak memory) and draws wall time and peak memory
//! against the number of deposits, each series with its exponent against the bead's length
//! fitted from R 100 up (the measure: at most 1.2).
//!
//! `cargo run --release -p sim --example scaling_plot -- docs/scaling/scaling.csv docs/img/scaling.png`

use plotters::prelude::*;
use std::collections::BTreeMap;
use std::process::ExitCode;

const FONT: &str = "sans-serif";
static FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// One measured run.
struct Row {
    radius_mm: f64,
    bead_m: f64,
    deposits: f64,
    wall_s: f64,
    peak_mb: f64,
}

/// The rows by series ("thin-wall, local steps"), each by the dome's radius.
type Series = BTreeMap<String, Vec<Row>>;

fn read(path: &str) -> Result<Series, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    let mut lines = text.lines().enumerate();
    let header = lines.next().map(|l| l.1).unwrap_or_default();
    let want = "model,mode,radius_mm,bead_m,deposits,wall_s,peak_mb";
    if header.trim() != want {
        return Err(format!(
            "{path}: line 1 is {header:?}, expected the header {want:?}"
        ));
    }
    let mut series = Series::new();
    for (n, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() != 7 {
            return Err(format!(
                "{path}: line {}: {} fields, expected 7",
                n + 1,
                f.len()
            ));
        }
        let num = |k: usize| -> Result<f64, String> {
            f[k].parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v > 0.0)
                .ok_or_else(|| {
                    format!(
                        "{path}: line {}: field {k} is {:?}, expected a positive number",
                        n + 1,
                        f[k]
                    )
                })
        };
        series
            .entry(format!("{}, {}", f[0], f[1]))
            .or_default()
            .push(Row {
                radius_mm: num(2)?,
                bead_m: num(3)?,
                deposits: num(4)?,
                wall_s: num(5)?,
                peak_mb: num(6)?,
            });
    }
    // Rows are appended as runs are made, not by size: each line is drawn from the smallest.
    for rows in series.values_mut() {
        rows.sort_by(|a, b| a.radius_mm.total_cmp(&b.radius_mm));
    }
    Ok(series)
}

/// Least-squares slope of log y against log x over the rows from R 100 up.
fn exponent(rows: &[Row], y: fn(&Row) -> f64) -> Option<f64> {
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.radius_mm >= 100.0 - 1e-9)
        .map(|r| (r.bead_m.ln(), y(r).ln()))
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

type Drawn = Result<(), Box<dyn std::error::Error>>;

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    series: &Series,
    what: &str,
    y: fn(&Row) -> f64,
) -> Drawn
where
    DB::ErrorType: 'static,
{
    let all = series.values().flatten();
    let (x0, x1) = all.clone().fold((f64::MAX, 0.0f64), |(a, b), r| {
        (a.min(r.deposits), b.max(r.deposits))
    });
    let (y0, y1) = all.fold((f64::MAX, 0.0f64), |(a, b), r| (a.min(y(r)), b.max(y(r))));
    let mut chart = ChartBuilder::on(area)
        .caption(format!("{what} against the deposits"), (FONT, 22))
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(
            (x0 / 1.5..x1 * 1.2).log_scale(),
            (y0 / 1.5..y1 * 1.5).log_scale(),
        )?;
    chart
        .configure_mesh()
        // Whole numbers, few of them: a log axis's default labels ran into one another.
        .x_labels(12)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .x_desc("deposits (path points)")
        .y_desc(what)
        .label_style((FONT, 14))
        .draw()?;
    let colours = [
        RGBColor(200, 60, 60),
        RGBColor(40, 90, 200),
        RGBColor(230, 140, 20),
        RGBColor(30, 150, 80),
        RGBColor(140, 60, 170),
        RGBColor(20, 160, 190),
        RGBColor(120, 120, 120),
        RGBColor(160, 110, 40),
        RGBColor(20, 20, 20),
        RGBColor(230, 90, 160),
        RGBColor(120, 150, 20),
        RGBColor(0, 0, 110),
    ];
    for (k, (name, rows)) in series.iter().enumerate() {
        let c = colours[k % colours.len()];
        let pts: Vec<(f64, f64)> = rows.iter().map(|r| (r.deposits, y(r))).collect();
        let label = match exponent(rows, y) {
            Some(e) => format!("{name}: exponent {e:.2} (R ≥ 100)"),
            None => name.clone(),
        };
        chart
            .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?
            .label(label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

fn draw(series: &Series, out: &str) -> Drawn {
    let _ = plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES);
    let size = (1400, 560);
    let mut rgb = vec![255u8; (size.0 * size.1 * 3) as usize];
    {
        let area = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        area.fill(&WHITE)?;
        let (left, right) = area.split_horizontally(700);
        panel(&left, series, "wall time, s", |r| r.wall_s)?;
        panel(&right, series, "peak memory, MB", |r| r.peak_mb)?;
        area.present()?;
    }
    let staged = format!("{out}.partial.png");
    sim::record::write_png(std::path::Path::new(&staged), &rgb, size)?;
    std::fs::rename(&staged, out)?;
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [table, out] = args.as_slice() else {
        eprintln!("usage: scaling_plot TABLE.csv OUT.png");
        return ExitCode::from(2);
    };
    let series = match read(table) {
        Ok(s) if !s.is_empty() => s,
        Ok(_) => {
            eprintln!("{table}: no rows");
            return ExitCode::from(2);
        }
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    for (name, rows) in &series {
        for (what, y) in [
            ("wall time", (|r: &Row| r.wall_s) as fn(&Row) -> f64),
            ("peak memory", |r: &Row| r.peak_mb),
        ] {
            if let Some(e) = exponent(rows, y) {
                println!("{name}: {what} exponent against the bead's length {e:.2}");
            }
        }
    }
    if let Err(e) = draw(&series, out) {
        eprintln!("{out}: {e}");
        return ExitCode::from(1);
    }
    ExitCode::SUCCESS
}

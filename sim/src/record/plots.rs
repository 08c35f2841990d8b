//! PNG plots a person reads first: the preheat per revolution against the interpass limit (with
//! and without dwells), deposit heights CTPP against planar slicing, temperature histories at
//! points of the wall, the dwell schedule; and a study's trade-off between dwell and preheat.
//! Text is drawn with DejaVu Sans, embedded (`assets/`), so no system font is needed.

use super::{Moment, Scene, Sink};
use crate::error::{Error, Result};
use crate::output::RunDir;
use crate::pipeline::replay::Sample;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::sync::Once;

const SIZE: (u32, u32) = (1000, 620);
const FONT: &str = "sans-serif";
static FONT_BYTES: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

#[derive(Default)]
pub struct PlotSink;

fn fail(e: impl std::fmt::Display) -> Error {
    Error::failure(format!("plots: {e}"))
}

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType font, checked by the plot tests.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES);
    });
}

impl Sink for PlotSink {
    fn begin(&mut self, _scene: &Scene, _dir: &RunDir) -> Result<()> {
        Ok(())
    }

    /// Everything the plots show is in the scene; they are drawn at the end.
    fn moment(&mut self, _scene: &Scene, _m: Moment<'_>) -> Result<()> {
        Ok(())
    }

    fn finish(self: Box<Self>, scene: &Scene, dir: &mut RunDir) -> Result<()> {
        draw(dir, "preheat.png", |a| preheat(a, scene))?;
        draw(dir, "deposits.png", |a| deposits(a, scene))?;
        if !scene.frames.is_empty() {
            draw(dir, "temperature_history.png", |a| history(a, scene))?;
        }
        if scene.points.iter().any(|p| p.dwell_s > 0.0) {
            draw(dir, "dwells.png", |a| dwells(a, scene))?;
        }
        Ok(())
    }
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
type Drawn = std::result::Result<(), Box<dyn std::error::Error>>;

/// Draw into an RGB image, write it as a staged PNG and rename it into place.
fn draw(dir: &mut RunDir, name: &str, f: impl FnOnce(&Area) -> Drawn) -> Result<()> {
    register_font();
    let mut rgb = vec![255u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let area = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        area.fill(&WHITE).map_err(fail)?;
        f(&area).map_err(fail)?;
        area.present().map_err(fail)?;
    }
    let staged = dir.stage(name);
    if let Err(e) = write_png(&staged, &rgb, SIZE) {
        let _ = std::fs::remove_file(&staged);
        return Err(Error::failure(format!(
            "cannot write {}: {e}",
            staged.display()
        )));
    }
    dir.commit(&staged, name)?;
    Ok(())
}

/// An 8-bit RGB image (rows top down, `width · height · 3` bytes) as a PNG file. The `png`
/// crate directly, rather than plotters' encoder, which stands on an older `image` than
/// rerun's: one PNG encoder in the build, not two.
pub fn write_png(
    path: &std::path::Path,
    rgb: &[u8],
    (width, height): (u32, u32),
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    let file = std::io::BufWriter::new(std::fs::File::create(path)?);
    let mut png = png::Encoder::new(file, width, height);
    png.set_color(png::ColorType::Rgb);
    png.set_depth(png::BitDepth::Eight);
    let mut writer = png.write_header()?;
    writer.write_image_data(rgb)?;
    writer.finish()?;
    Ok(())
}

fn span(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = planner::plan::range(values.filter(|v| v.is_finite()));
    if lo > hi {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-6);
    (lo - pad, hi + pad)
}

fn preheat(area: &Area, scene: &Scene) -> Drawn {
    let without = scene.layers_without_dwells.as_deref().unwrap_or(&[]);
    let all = scene
        .layers
        .iter()
        .chain(without)
        .map(|l| l.preheat_max_c)
        .chain([scene.interpass_c, scene.ambient_c]);
    let (lo, hi) = span(all);
    let n = scene.layers.len().max(1) as f64;
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!("{}: preheat per revolution", scene.title),
            (FONT, 24),
        )
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(0.0..n, lo..hi)?;
    chart
        .configure_mesh()
        .x_desc("revolution (layer)")
        .y_desc("preheat, °C")
        .x_label_formatter(&whole)
        .y_label_formatter(&whole)
        .label_style((FONT, 15))
        .draw()?;
    // The limit first, so that the curves are drawn over it.
    chart
        .draw_series(LineSeries::new(
            [(0.0, scene.interpass_c), (n, scene.interpass_c)],
            BLACK.stroke_width(2),
        ))?
        .label(format!("interpass limit {:.0} °C", scene.interpass_c))
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
    let series = |rows: &[super::scene::LayerRecord], f: fn(&super::scene::LayerRecord) -> f64| {
        rows.iter()
            .map(move |l| (l.layer as f64, f(l)))
            .collect::<Vec<_>>()
    };
    if !without.is_empty() {
        chart
            .draw_series(LineSeries::new(
                series(without, |l| l.preheat_max_c),
                RGBColor(200, 60, 60).stroke_width(2),
            ))?
            .label("max, without dwells")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RGBColor(200, 60, 60)));
    }
    let label = if without.is_empty() {
        "max"
    } else {
        "max, with the planned dwells"
    };
    chart
        .draw_series(LineSeries::new(
            series(&scene.layers, |l| l.preheat_max_c),
            BLUE.stroke_width(2),
        ))?
        .label(label)
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLUE));
    chart
        .draw_series(LineSeries::new(
            series(&scene.layers, |l| l.preheat_mean_c),
            RGBColor(90, 150, 250),
        ))?
        .label("mean")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RGBColor(90, 150, 250)));
    // Revolutions whose hottest preheat still passes the limit, as layers.csv flags them.
    let above: Vec<&super::scene::LayerRecord> = scene
        .layers
        .iter()
        .filter(|l| l.preheat_max_c > scene.interpass_c)
        .collect();
    if !above.is_empty() {
        let red = RGBColor(220, 0, 0);
        chart
            .draw_series(
                above.iter().map(|l| {
                    Circle::new((l.layer as f64, l.preheat_max_c), 6, red.stroke_width(2))
                }),
            )?
            .label(format!(
                "above the limit{}: revolutions {}",
                if without.is_empty() {
                    ""
                } else {
                    " with dwells"
                },
                super::scene::ranges(&above.iter().map(|l| l.layer).collect::<Vec<_>>())
            ))
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, red.stroke_width(2)));
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft)
}

/// An axis label without decimals: revolutions, °C and seconds are read as whole numbers.
fn whole(v: &f64) -> String {
    format!("{v:.0}")
}

fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    at: SeriesLabelPosition,
) -> Drawn
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FONT, 15))
        .position(at)
        .draw()?;
    Ok(())
}

/// Share of points per bin; values off either end count in the end bins.
fn histogram(values: &[f64], lo: f64, bin: f64, n: usize) -> Vec<(f64, f64)> {
    let mut counts = vec![0usize; n];
    for &v in values {
        let k = ((v - lo) / bin).floor().clamp(0.0, (n - 1) as f64);
        counts[k as usize] += 1;
    }
    let total = values.len().max(1) as f64;
    counts
        .iter()
        .enumerate()
        .map(|(k, &c)| (lo + (k as f64 + 0.5) * bin, c as f64 / total))
        .collect()
}

fn deposits(area: &Area, scene: &Scene) -> Drawn {
    const BIN: f64 = 0.05;
    let ctpp: Vec<f64> = scene.points.iter().map(|p| p.deposit_mm).collect();
    let planar = scene.planar_deposits_mm.clone().unwrap_or_default();
    // The window and a margin as wide again on each side; the rest piles up in the end bins.
    let [h_min, h_max] = scene.window_mm;
    let margin = (h_max - h_min).max(BIN);
    let (lo, hi) = span(ctpp.iter().chain(&planar).copied());
    let (lo, hi) = (lo.max(h_min - margin), hi.min(h_max + margin));
    let (lo, hi) = (
        (lo.min(h_min) / BIN).floor() * BIN,
        (hi.max(h_max) / BIN).ceil() * BIN,
    );
    let beyond = |v: &Vec<f64>| v.iter().filter(|&&x| x < lo || x >= hi).count();
    let n = ((hi - lo) / BIN).round().max(1.0) as usize;
    let h_ctpp = histogram(&ctpp, lo, BIN, n);
    let h_planar = histogram(&planar, lo, BIN, n);
    let top = h_ctpp
        .iter()
        .chain(&h_planar)
        .map(|p| p.1)
        .fold(0.0, f64::max)
        // Headroom for the legend's three lines across the top: at 1.1 a straight wall's
        // planar bar (every point one height) ran up under it.
        * 1.3;
    let mut chart = ChartBuilder::on(area)
        .caption(
            "deposit height: CTPP (one continuous spiral) against planar 2.5D slicing",
            (FONT, 24),
        )
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(lo..hi, 0.0..top.max(1e-3))?;
    chart
        .configure_mesh()
        .x_desc("deposit height H, mm (bins of 0.05 mm; the end bins hold what lies beyond)")
        .y_desc("share of path points")
        .label_style((FONT, 15))
        .draw()?;
    let bars = |h: Vec<(f64, f64)>, shift: f64, c: RGBColor| {
        h.into_iter().map(move |(x, y)| {
            let x0 = x - BIN / 2.0 + shift * BIN / 2.0;
            Rectangle::new([(x0, 0.0), (x0 + BIN / 2.0, y)], c.filled())
        })
    };
    chart
        .draw_series(bars(h_ctpp, 0.0, RGBColor(50, 100, 220)))?
        .label(format!(
            "CTPP, continuous three-dimensional path planning ({} points, {} beyond the axis)",
            ctpp.len(),
            beyond(&ctpp)
        ))
        .legend(|(x, y)| {
            Rectangle::new(
                [(x, y - 5), (x + 15, y + 5)],
                RGBColor(50, 100, 220).filled(),
            )
        });
    if !planar.is_empty() {
        chart
            .draw_series(bars(h_planar, 1.0, RGBColor(230, 120, 40)))?
            .label(format!(
                "planar 2.5D ({} points, {} beyond the axis)",
                planar.len(),
                beyond(&planar)
            ))
            .legend(|(x, y)| {
                Rectangle::new(
                    [(x, y - 5), (x + 15, y + 5)],
                    RGBColor(230, 120, 40).filled(),
                )
            });
    }
    for (k, &h) in scene.window_mm.iter().enumerate() {
        let s = chart.draw_series(LineSeries::new([(h, 0.0), (h, top)], BLACK.stroke_width(2)))?;
        if k == 0 {
            s.label(format!(
                "window [{:.2}, {:.2}] mm",
                scene.window_mm[0], scene.window_mm[1]
            ))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
        }
    }
    // Upper right: CTPP's tallest bar stands at the window's lower edge, on the left.
    legend(&mut chart, SeriesLabelPosition::UpperRight)
}

fn history(area: &Area, scene: &Scene) -> Drawn {
    let picks = super::history_points(scene.points.len());
    // Every step of the heat model where the run traced the point (each pass's peak shows),
    // else the field frames.
    let curves: Vec<Vec<(f64, f64)>> = picks
        .iter()
        .map(|&i| match scene.histories.iter().find(|h| h.point == i) {
            Some(h) => h
                .t_s
                .iter()
                .copied()
                .zip(h.temperature_c.iter().copied())
                .collect(),
            None => scene
                .frames
                .iter()
                .filter(|f| f.temperature_c[i].is_finite())
                .map(|f| (f.t_s, f.temperature_c[i] as f64))
                .collect(),
        })
        .collect();
    let (lo, hi) = span(
        curves
            .iter()
            .flatten()
            .map(|p| p.1)
            .chain([scene.interpass_c, scene.ambient_c]),
    );
    let sampled = if scene.histories.is_empty() {
        format!("{} field frames", scene.frames.len())
    } else {
        "every step of the heat model".to_string()
    };
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!("temperature of the wall at three path points ({sampled})"),
            (FONT, 24),
        )
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(0.0..scene.build_s.max(1e-3), lo..hi)?;
    chart
        .configure_mesh()
        .x_desc("build time, s")
        .y_desc("temperature, °C")
        .x_label_formatter(&whole)
        .y_label_formatter(&whole)
        .label_style((FONT, 15))
        .draw()?;
    chart
        .draw_series(LineSeries::new(
            [(0.0, scene.interpass_c), (scene.build_s, scene.interpass_c)],
            BLACK.stroke_width(1),
        ))?
        .label("interpass limit")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
    let colours = [
        RGBColor(50, 100, 220),
        RGBColor(40, 160, 80),
        RGBColor(210, 60, 60),
    ];
    for ((&i, pts), c) in picks.iter().zip(curves).zip(colours) {
        let p = &scene.points[i];
        chart
            .draw_series(LineSeries::new(pts, c.stroke_width(1)))?
            .label(format!(
                "point {i} (layer {}, z = {:.0} mm)",
                p.layer, p.position_mm[2]
            ))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight)
}

fn dwells(area: &Area, scene: &Scene) -> Drawn {
    let n = scene.layers.len().max(1) as f64;
    let top = scene.layers.iter().map(|l| l.dwell_s).fold(0.0, f64::max) * 1.1;
    let total: f64 = scene.points.iter().map(|p| p.dwell_s).sum();
    // A drop's wait is its dwell.
    let count = scene.arc_stops();
    let drops = scene.points.iter().filter(|p| p.strikes_drop).count();
    let caption = match drops {
        0 => format!("dwell schedule: {count} arc stops, {total:.0} s in all"),
        k => format!("dwell schedule: {count} arc stops ({k} drops), {total:.0} s in all"),
    };
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FONT, 24))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(0.0..n, 0.0..top.max(1.0))?;
    chart
        .configure_mesh()
        .x_desc("revolution (layer)")
        .y_desc("dwell in the revolution (drops' waits too), s")
        .x_label_formatter(&whole)
        .y_label_formatter(&whole)
        .label_style((FONT, 15))
        .draw()?;
    chart.draw_series(scene.layers.iter().map(|l| {
        let x = l.layer as f64;
        Rectangle::new(
            [(x, 0.0), (x + 0.8, l.dwell_s)],
            RGBColor(50, 100, 220).filled(),
        )
    }))?;
    Ok(())
}

/// One case of a study, as its trade-off plot shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct Case {
    pub label: String,
    pub total_dwell_s: f64,
    pub max_preheat_c: f64,
    pub interpass_max_c: f64,
}

/// A study's cases: total dwell against the highest preheat, one marker per case, coloured by
/// the case's interpass limit (each limit also drawn as a line).
pub fn study_plots(dir: &mut RunDir, cases: &[Case]) -> Result<()> {
    let mut limits: Vec<f64> = cases.iter().map(|c| c.interpass_max_c).collect();
    limits.sort_by(f64::total_cmp);
    limits.dedup();
    let palette = [
        RGBColor(50, 100, 220),
        RGBColor(210, 60, 60),
        RGBColor(40, 160, 80),
        RGBColor(230, 140, 30),
        RGBColor(130, 60, 180),
    ];
    let colour = |limit: f64| {
        let k = limits.iter().position(|&l| l == limit).unwrap_or(0);
        palette[k % palette.len()]
    };
    draw(dir, "tradeoff.png", |area| {
        let (x_lo, x_hi) = span(cases.iter().map(|c| c.total_dwell_s).chain([0.0]));
        let (y_lo, y_hi) = span(
            cases
                .iter()
                .map(|c| c.max_preheat_c)
                .chain(limits.iter().copied()),
        );
        let mut chart = ChartBuilder::on(area)
            .caption(
                format!(
                    "study of {} cases: total dwell against the highest preheat",
                    cases.len()
                ),
                (FONT, 24),
            )
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(x_lo..x_hi, y_lo..y_hi)?;
        chart
            .configure_mesh()
            .x_desc("total dwell, s")
            .y_desc("highest preheat, °C")
            .label_style((FONT, 15))
            .draw()?;
        chart.draw_series(cases.iter().map(|c| {
            EmptyElement::at((c.total_dwell_s, c.max_preheat_c))
                + Circle::new((0, 0), 5, colour(c.interpass_max_c).filled())
                + Text::new(c.label.clone(), (7, -7), (FONT, 12))
        }))?;
        for &l in &limits {
            let c = colour(l);
            chart
                .draw_series(LineSeries::new([(x_lo, l), (x_hi, l)], c.stroke_width(1)))?
                .label(format!("cases with the interpass limit {l:.0} °C"))
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c));
        }
        legend(&mut chart, SeriesLabelPosition::LowerLeft)
    })
}

/// The arc-stop front: build time against arc stops, one point a real plan (its weight per arc
/// stop beside it), the plans nothing beats joined, the budget as a line where there is one.
pub fn pareto_plot(
    dir: &mut RunDir,
    title: &str,
    plans: &[crate::pipeline::arc_stops::Tried],
    budget: Option<usize>,
    lower_bound: usize,
) -> Result<()> {
    use crate::pipeline::arc_stops::on_front;
    draw(dir, "pareto.png", |area| {
        let stops = plans.iter().map(|t| t.arc_stops as f64);
        let (x_lo, x_hi) = span(
            stops
                .chain([0.0, lower_bound as f64])
                .chain(budget.map(|b| b as f64)),
        );
        let (y_lo, y_hi) = span(plans.iter().map(|t| t.build_time_s / 60.0));
        let mut chart = ChartBuilder::on(area)
            .caption(format!("{title}: build time against arc stops"), (FONT, 24))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(x_lo..x_hi, y_lo..y_hi)?;
        chart
            .configure_mesh()
            .x_desc("arc stops (arc starts after the first)")
            .y_desc("build time, min")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .label_style((FONT, 15))
            .draw()?;
        let mut front: Vec<(f64, f64)> = plans
            .iter()
            .filter(|t| on_front(t, plans))
            .map(|t| (t.arc_stops as f64, t.build_time_s / 60.0))
            .collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        let blue = RGBColor(50, 100, 220);
        chart
            .draw_series(LineSeries::new(front, blue.stroke_width(2)))?
            .label("Pareto front (no plan beats these on both)")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], blue));
        chart.draw_series(plans.iter().map(|t| {
            let c = if on_front(t, plans) {
                blue
            } else {
                RGBColor(150, 150, 150)
            };
            EmptyElement::at((t.arc_stops as f64, t.build_time_s / 60.0))
                + Circle::new((0, 0), 5, c.filled())
                + Text::new(
                    match t.slowed_points {
                        0 => format!("{:.0} s/stop", t.weight_s),
                        k => format!("{:.0} s/stop, {k} points slowed", t.weight_s),
                    },
                    (7, -14),
                    (FONT, 12),
                )
        }))?;
        let grey = RGBColor(90, 90, 90);
        chart
            .draw_series(LineSeries::new(
                [(lower_bound as f64, y_lo), (lower_bound as f64, y_hi)],
                grey.stroke_width(2),
            ))?
            .label(format!(
                "lower bound: no plan makes fewer than {lower_bound} arc stops"
            ))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], grey));
        if let Some(b) = budget {
            let red = RGBColor(210, 60, 60);
            chart
                .draw_series(LineSeries::new(
                    [(b as f64, y_lo), (b as f64, y_hi)],
                    red.stroke_width(1),
                ))?
                .label(format!("budget: {b} arc stops"))
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], red));
        }
        // Fewer stops cost more build time: the lower left stays empty.
        legend(&mut chart, SeriesLabelPosition::LowerLeft)
    })
}

/// Highest temperature on the colour scale, °C: the colour map is white from 1500 °C.
const SCALE_TOP_C: f64 = 1600.0;

/// The colour legend of the wall's temperature ([`super::temperature_colour`]) as an RGB image
/// of `size` pixels: the scale from ambient to [`SCALE_TOP_C`] with its anchors labelled, for
/// viewers that colour a mesh without a legend of their own (rerun).
pub fn colour_scale(ambient_c: f64, interpass_c: f64, size: (u32, u32)) -> Result<Vec<u8>> {
    register_font();
    let mut rgb = vec![255u8; (size.0 * size.1 * 3) as usize];
    {
        let area = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        scale(&area, ambient_c, interpass_c).map_err(fail)?;
        area.present().map_err(fail)?;
    }
    Ok(rgb)
}

fn scale(area: &Area, ambient_c: f64, interpass_c: f64) -> Drawn {
    area.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(area)
        .caption("wall temperature, °C", (FONT, 18))
        .margin(12)
        .build_cartesian_2d(ambient_c..SCALE_TOP_C, -0.7..1.0)?;
    let (w, _) = chart.plotting_area().dim_in_pixel();
    let step = (SCALE_TOP_C - ambient_c) / w.max(1) as f64;
    chart.draw_series((0..w).map(|k| {
        let t = ambient_c + k as f64 * step;
        let [r, g, b, _] = super::temperature_colour(t, ambient_c, interpass_c);
        Rectangle::new([(t, 0.0), (t + step, 1.0)], RGBColor(r, g, b).filled())
    }))?;
    // The anchors a process engineer reads: ambient, the interpass limit, glow, red, melt.
    let label = TextStyle::from((FONT, 14)).pos(Pos::new(HPos::Center, VPos::Top));
    for t in [ambient_c, interpass_c, 600.0, 1200.0, 1500.0] {
        chart.draw_series([PathElement::new(
            [(t, -0.15), (t, 1.0)],
            BLACK.stroke_width(1),
        )])?;
        chart.draw_series([Text::new(format!("{t:.0}"), (t, -0.2), label.clone())])?;
    }
    Ok(())
}

/// Measured and predicted temperature against time at up to six probes spread over those
/// given (first and last included), one panel each: what a person compares first. A judged
/// `window` (s) is shaded.
pub fn probe_plot(
    dir: &mut RunDir,
    name: &str,
    title: &str,
    series: &[(&str, &[Sample])],
    window: Option<[f64; 2]>,
) -> Result<()> {
    if series.is_empty() {
        return Ok(());
    }
    // The same six the replay's run.rrd opens on.
    let shown = super::replay::shown(series.len());
    draw(dir, name, |area| {
        // Two columns, as many rows as the probes shown need (three at most).
        let panels = area.split_evenly((shown.len().div_ceil(2), 2));
        for (panel, &k) in panels.iter().zip(&shown) {
            probe_panel(panel, title, series[k], window)?;
        }
        Ok(())
    })
}

fn probe_panel(
    area: &Area,
    title: &str,
    (name, s): (&str, &[Sample]),
    window: Option<[f64; 2]>,
) -> Drawn {
    let (t0, t1) = span(s.iter().map(|x| x.0));
    let (lo, hi) = span(s.iter().flat_map(|x| [x.1, x.2]));
    let mut chart = ChartBuilder::on(area)
        .caption(format!("{title}: {name}"), (FONT, 15))
        .margin(6)
        .x_label_area_size(30)
        .y_label_area_size(48)
        .build_cartesian_2d(t0..t1, lo..hi)?;
    // The judged window shaded, under the grid and the curves.
    if let Some(w) = window {
        chart.draw_series(std::iter::once(Rectangle::new(
            [(w[0].max(t0), lo), (w[1].min(t1), hi)],
            RGBColor(235, 240, 250).filled(),
        )))?;
    }
    chart
        .configure_mesh()
        .x_desc("build time, s")
        .y_desc("°C")
        .x_label_formatter(&whole)
        .y_label_formatter(&whole)
        .label_style((FONT, 12))
        .draw()?;
    chart
        .draw_series(LineSeries::new(s.iter().map(|x| (x.0, x.1)), BLACK))?
        .label("measured")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 14, y)], BLACK));
    let orange = RGBColor(230, 120, 20);
    chart
        .draw_series(LineSeries::new(s.iter().map(|x| (x.0, x.2)), orange))?
        .label("predicted")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 14, y)], orange));
    let points = s.iter().flat_map(|x| [(x.0, x.1), (x.0, x.2)]);
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font((FONT, 12))
        .position(clearest(points, (t0, t1), (lo, hi)))
        .draw()?;
    Ok(())
}

/// Where a legend hides the least of the curves: of the four corners and the middle of either
/// side, the one whose box (a legend's share of the plot, `LEGEND_SHARE`) holds the fewest of
/// `points`; the first of the least in the order listed. Plotters' own place (the middle of
/// the right side) lies on a replay's predicted curve where it levels off.
fn clearest(
    points: impl Iterator<Item = (f64, f64)>,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> SeriesLabelPosition {
    use SeriesLabelPosition::*;
    const LEGEND_SHARE: (f64, f64) = (0.3, 0.25);
    // Each place's box in the plot's fractions: (x from, y from), up from the bottom.
    let (w, h) = LEGEND_SHARE;
    let places = [
        (UpperRight, (1.0 - w, 1.0 - h)),
        (UpperLeft, (0.0, 1.0 - h)),
        (LowerRight, (1.0 - w, 0.0)),
        (LowerLeft, (0.0, 0.0)),
        (MiddleRight, (1.0 - w, 0.5 - h / 2.0)),
        (MiddleLeft, (0.0, 0.5 - h / 2.0)),
    ];
    let mut hidden = [0usize; 6];
    for (x, y) in points {
        let (u, v) = ((x - x0) / (x1 - x0), (y - y0) / (y1 - y0));
        for (k, (_, (bu, bv))) in places.iter().enumerate() {
            if (*bu..=bu + w).contains(&u) && (*bv..=bv + h).contains(&v) {
                hidden[k] += 1;
            }
        }
    }
    let best = (0..places.len()).min_by_key(|&k| hidden[k]).unwrap_or(0);
    places.into_iter().nth(best).map_or(UpperRight, |p| p.0)
}

/// The map of the local inter-layer distance (Chalvin et al. 2019 Fig. 5 and 7): each path point
/// at (`x`, its layer), coloured by its variation from Δ (blue shorter, red longer, white Δ,
/// saturated at ±50 %), with the colour bar; interlayer.png.
pub fn interlayer_map(
    dir: &mut RunDir,
    title: &str,
    points: &[(f64, f64, f64)],
    x_desc: &str,
) -> Result<()> {
    const SAT: f64 = 50.0;
    let colour = |pct: f64| {
        let f = (pct / SAT).clamp(-1.0, 1.0);
        let fade = |c: u8| (255.0 - (255.0 - c as f64) * f.abs()).round() as u8;
        if f < 0.0 {
            RGBColor(fade(30), fade(70), fade(200))
        } else {
            RGBColor(fade(210), fade(40), fade(30))
        }
    };
    draw(dir, "interlayer.png", |area| {
        let (map, bar) = area.split_horizontally(SIZE.0 - 130);
        let (x_lo, x_hi) = span(points.iter().map(|p| p.0));
        let (y_lo, y_hi) = span(points.iter().map(|p| p.1));
        let (lo, hi) = planner::plan::range(points.iter().map(|p| p.2));
        let mut chart = ChartBuilder::on(&map)
            .caption(
                format!("{title}: inter-layer distance, {lo:+.1} % to {hi:+.1} % of Δ"),
                (FONT, 22),
            )
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(x_lo..x_hi, y_lo..y_hi)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc("layer")
            .x_label_formatter(&whole)
            .y_label_formatter(&whole)
            .label_style((FONT, 15))
            .draw()?;
        chart.draw_series(
            points
                .iter()
                .map(|&(x, y, v)| Circle::new((x, y), 2, colour(v).filled())),
        )?;
        let mut scale = ChartBuilder::on(&bar)
            .margin_top(60)
            .margin_bottom(56)
            .margin_right(12)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..1.0, -SAT..SAT)?;
        scale
            .configure_mesh()
            .disable_x_mesh()
            .disable_x_axis()
            .y_desc("% of Δ")
            .y_label_formatter(&whole)
            .label_style((FONT, 14))
            .draw()?;
        scale.draw_series((0..100).map(|k| {
            let v = -SAT + 2.0 * SAT * k as f64 / 100.0;
            Rectangle::new(
                [(0.0, v), (1.0, v + 2.0 * SAT / 100.0)],
                colour(v + SAT / 100.0).filled(),
            )
        }))?;
        Ok(())
    })
}

/// Skeleton arc AM: the contact tip's real distance to the metal per drop, closed loop and
/// open loop on the same drops, against the CTDWP kept (Radel et al. 2019 §4.1); standoff.png.
pub fn standoff_plot(
    dir: &mut RunDir,
    title: &str,
    closed: &[f64],
    open: &[f64],
    target_mm: f64,
) -> Result<()> {
    draw(dir, "standoff.png", |area| {
        let n = closed.len().max(open.len()).max(1) as f64;
        let (lo, hi) = span(closed.iter().chain(open).copied().chain([target_mm]));
        let mut chart = ChartBuilder::on(area)
            .caption(
                format!("{title}: contact tip to work distance per drop"),
                (FONT, 24),
            )
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..n, lo..hi)?;
        chart
            .configure_mesh()
            .x_desc("drop")
            .y_desc("CTDWP, mm")
            .x_label_formatter(&whole)
            .label_style((FONT, 15))
            .draw()?;
        let red = RGBColor(210, 60, 60);
        let blue = RGBColor(50, 100, 220);
        chart
            .draw_series(LineSeries::new(
                open.iter().enumerate().map(|(k, &v)| (k as f64, v)),
                red.stroke_width(2),
            ))?
            .label("open loop (increment δ)")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], red));
        chart
            .draw_series(LineSeries::new(
                closed.iter().enumerate().map(|(k, &v)| (k as f64, v)),
                blue.stroke_width(2),
            ))?
            .label("closed loop (the camera's top)")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], blue));
        chart
            .draw_series(LineSeries::new(
                [(0.0, target_mm), (n, target_mm)],
                BLACK.stroke_width(1),
            ))?
            .label(format!("set: {target_mm} mm"))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
        legend(&mut chart, SeriesLabelPosition::UpperLeft)
    })
}

/// Skeleton arc AM: per drop, the time from the arc's end until the drop and the metal beneath
/// it are solid (Radel et al. 2019 Fig. 11); solidification.png.
pub fn solidification_plot(dir: &mut RunDir, title: &str, seconds: &[f64]) -> Result<()> {
    draw(dir, "solidification.png", |area| {
        let n = seconds.len().max(1) as f64;
        let (_, hi) = span(seconds.iter().copied().chain([0.0]));
        let mut chart = ChartBuilder::on(area)
            .caption(format!("{title}: solidification time per drop"), (FONT, 24))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..n, 0.0..hi)?;
        chart
            .configure_mesh()
            .x_desc("drop")
            .y_desc("time to solidify after the arc, s")
            .x_label_formatter(&whole)
            .label_style((FONT, 15))
            .draw()?;
        let blue = RGBColor(50, 100, 220);
        chart.draw_series(LineSeries::new(
            seconds
                .iter()
                .enumerate()
                .map(|(k, &v)| (k as f64 + 1.0, v)),
            blue.stroke_width(2),
        ))?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use plotters::chart::SeriesLabelPosition;

    /// A legend goes where the curves are not: a curve rising to the upper right and levelling
    /// there leaves the lower right; one falling from the upper left leaves the upper right;
    /// with nothing drawn the first place listed.
    #[test]
    fn a_legend_goes_where_the_curves_are_not() {
        let place = |f: fn(f64) -> f64| {
            let points = (0..=100).map(|k| (k as f64, f(k as f64)));
            super::clearest(points, (0.0, 100.0), (0.0, 100.0))
        };
        let rising = |t: f64| 100.0 * (1.0 - (-t / 20.0).exp());
        assert!(matches!(place(rising), SeriesLabelPosition::LowerRight));
        assert!(matches!(
            place(|t| 100.0 - t),
            SeriesLabelPosition::UpperRight
        ));
        let level = |_| 50.0;
        assert!(matches!(place(level), SeriesLabelPosition::UpperRight));
        let (x, y) = ((0.0, 1.0), (0.0, 1.0));
        let none = super::clearest(std::iter::empty(), x, y);
        assert!(matches!(none, SeriesLabelPosition::UpperRight));
    }

    #[test]
    fn histogram_shares_sum_to_one_inside_the_range() {
        let h = super::histogram(&[1.81, 1.84, 2.0, 2.19], 1.8, 0.05, 8);
        assert_eq!(h.len(), 8);
        assert!((h.iter().map(|b| b.1).sum::<f64>() - 1.0).abs() < 1e-12);
        assert_eq!(h[0].1, 0.5);
        let h = super::histogram(&[0.0, 5.0], 1.8, 0.05, 8);
        assert_eq!((h[0].1, h[7].1), (0.5, 0.5));
        assert!((h[0].0 - 1.825).abs() < 1e-12);
    }

    /// What `write_png` writes decodes to the pixels it was given, in their order (rows top
    /// down, RGB), at 8 bits.
    #[test]
    fn a_written_png_reads_back_to_the_same_pixels() {
        let (w, h) = (7u32, 5u32);
        let rgb: Vec<u8> = (0..w * h * 3).map(|k| (k * 37 % 251) as u8).collect();
        let path = std::env::temp_dir().join(format!("waamtwin-png-{}.png", std::process::id()));
        super::write_png(&path, &rgb, (w, h)).unwrap();
        let file = std::io::BufReader::new(std::fs::File::open(&path).unwrap());
        let mut reader = png::Decoder::new(file).read_info().unwrap();
        let mut back = vec![0u8; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut back).unwrap();
        std::fs::remove_file(&path).unwrap();
        assert_eq!((info.width, info.height), (w, h));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(info.bit_depth, png::BitDepth::Eight);
        assert_eq!(&back[..info.buffer_size()], &rgb[..]);
    }

    #[test]
    fn the_embedded_font_is_valid() {
        assert!(
            plotters::style::register_font(
                "check",
                plotters::style::FontStyle::Normal,
                super::FONT_BYTES
            )
            .is_ok()
        );
    }

    /// The legend carries the colour map: its bar runs from the ambient blue to the white of the
    /// melt, with the interpass green between.
    #[test]
    fn colour_scale_shows_the_colour_map() {
        let (w, h) = (640, 90);
        let rgb = super::colour_scale(20.0, 200.0, (w, h)).unwrap();
        assert_eq!(rgb.len(), (w * h * 3) as usize);
        let count = |f: &dyn Fn(&[u8]) -> bool| rgb.chunks(3).filter(|p| f(p)).count();
        // Just above ambient (the ambient column itself carries the anchor's line).
        let blue = count(&|p| p[0] < 60 && p[1] < 90 && p[2] > 180);
        assert!(blue > 50, "{blue} blue pixels");
        let greenish = rgb
            .chunks(3)
            .filter(|p| p[1] > 150 && p[0] < 80 && p[2] < 120)
            .count();
        assert!(greenish > 50, "{greenish} green pixels");
    }
}

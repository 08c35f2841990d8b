//! report.html: the one page a process engineer opens first. Self-contained (the plots inlined
//! as data URIs, no script from elsewhere, no font to fetch): the verdict (safe or not, where and
//! why), the plan's key numbers, the plots, and what each file of the run is for. Written after
//! the plot sink, whose PNGs it inlines.

use super::foxglove::base64;
use super::{Moment, PointRecord, Scene, Sink};
use crate::error::{Error, Result};
use crate::output::RunDir;
use std::fmt::Write;

pub struct ReportSink;

/// The plots, in reading order, with what each shows.
const PLOTS: [(&str, &str); 4] = [
    (
        "preheat.png",
        "Preheat per revolution against the interpass limit, with and without the planned dwells.",
    ),
    (
        "temperature_history.png",
        "The wall's temperature at three path points, every step of the heat model.",
    ),
    (
        "dwells.png",
        "The dwell schedule: dwell time per revolution.",
    ),
    (
        "deposits.png",
        "Deposit heights of the CTPP spiral against planar 2.5D slicing, with the process window.",
    ),
];

/// The files a run may hold, with what each is for.
const FILES: [(&str, &str); 12] = [
    (
        "plan.json",
        "the plan's key numbers: generators, layers, deposits, feasibility (Eq.6), collisions",
    ),
    (
        "path.csv",
        "one row per path point: position, tool axis, layer, deposit, wire feed, travel speed, time, dwell, and the simulated preheat, peak and pool",
    ),
    ("generators.csv", "the geodesic generators of the spiral"),
    (
        "thermal.json",
        "the heat model's summary: energy balance, hottest preheat, first point at risk, cells",
    ),
    (
        "layers.csv",
        "one row per revolution: start, duration, preheat max and mean, dwell, risk",
    ),
    (
        "dwells.csv",
        "one row per dwell (each an arc stop and restart): where, when, how long, why",
    ),
    (
        "dwell.json",
        "the dwell plan's summary, the points still at risk and the baselines",
    ),
    (
        "run.rrd",
        "the build in the rerun viewer 0.36: part, spiral, torch, the wall coloured by temperature",
    ),
    (
        "run.mcap",
        "the same for Foxglove: 3-D scene, point cloud with temperatures, plots, event log",
    ),
    (
        "fields.h5",
        "the temperature field for ParaView ≥ 5.12 (VTKHDF) and h5py",
    ),
    (
        "manifest.json",
        "what ran, when, with which scenario, and the list of files",
    ),
    ("part.stl", "the part's mid-surface (the demo)"),
];

impl Sink for ReportSink {
    fn begin(&mut self, _scene: &Scene, _dir: &RunDir) -> Result<()> {
        Ok(())
    }

    fn moment(&mut self, _scene: &Scene, _m: Moment<'_>) -> Result<()> {
        Ok(())
    }

    fn finish(self: Box<Self>, scene: &Scene, dir: &mut RunDir) -> Result<()> {
        let mut plots = Vec::new();
        for (name, what) in PLOTS {
            let path = dir.path().join(name);
            if path.is_file() {
                let png = std::fs::read(&path)
                    .map_err(|e| Error::failure(format!("{}: {e}", path.display())))?;
                plots.push((name, what, png));
            }
        }
        let present = |f: &str| dir.path().join(f).is_file();
        let files: Vec<(&str, &str)> = FILES
            .iter()
            .copied()
            .filter(|(f, _)| present(f) || *f == "manifest.json")
            .collect();
        dir.write("report.html", page(scene, &plots, &files).as_bytes())?;
        Ok(())
    }
}

/// Points over the interpass limit by what they are laid on: each kind has its own remedy, and
/// a dwell between revolutions is the remedy of one of them only.
#[derive(Debug, Default, Clone, Copy)]
struct OverLimit {
    earlier: usize,
    plate: usize,
    just_laid: usize,
}

impl OverLimit {
    fn count(scene: &Scene) -> Self {
        let over = |on: thermal::Support| {
            scene
                .points
                .iter()
                .filter(|p| p.laid_on == on && p.preheat_c > scene.interpass_c)
                .count()
        };
        Self {
            earlier: over(thermal::Support::Deposit),
            plate: over(thermal::Support::Plate),
            just_laid: over(thermal::Support::JustLaid),
        }
    }

    /// The evidence: the revolutions `runs` (`above` of `of`) over the limit, and each kind's
    /// remedy.
    fn text(self, runs: &str, above: usize, of: usize) -> String {
        let which = if above == 1 {
            "revolution"
        } else {
            "revolutions"
        };
        let mut text = format!(
            "{above} of {of} revolutions pass the limit at their hottest preheat ({which} {runs})."
        );
        if self.earlier > 0 {
            text += &format!(
                " {} points over it lie on earlier revolutions: a dwell before them lets what \
                 they are laid on cool (`waamtwin dwell` plans them).",
                self.earlier
            );
        }
        if self.plate > 0 {
            text += &format!(
                " {} points over it lie on the plate, in the first revolution, which its own arc \
                 has warmed: no dwell between revolutions comes before them, and the dwell \
                 planner leaves the plate alone; a lower heat input (wire feed, travel speed), a \
                 larger or a cooled plate would lower it.",
                self.plate
            );
        }
        if self.just_laid > 0 {
            text += &format!(
                " {} points over it lie on metal laid inside the torch's footprint when their \
                 preheat is read (near a closing point, the arc's own heat): no dwell can help \
                 there, only a closing strategy (dwell.json `closing_strategy`; see \
                 docs/PHYSICS.md).",
                self.just_laid
            );
        }
        text
    }
}

/// The verdict in one sentence, and the evidence under it.
fn verdict(scene: &Scene) -> (bool, String, Vec<String>) {
    let risky: Vec<usize> = (0..scene.points.len())
        .filter(|&i| scene.points[i].risk.is_some())
        .collect();
    let above: Vec<usize> = scene
        .layers
        .iter()
        .filter(|l| l.preheat_max_c > scene.interpass_c)
        .map(|l| l.layer)
        .collect();
    let mut evidence = Vec::new();
    let safe = risky.is_empty();
    let headline = match risky.first() {
        None => format!(
            "Safe: no path point breaks a collapse criterion (interpass limit {:.0} °C).",
            scene.interpass_c
        ),
        Some(&i) => {
            let p = &scene.points[i];
            format!(
                "At risk: {} path points break a collapse criterion, the first at point {i} \
                 (layer {}, {}), preheat {:.0} °C against the {:.0} °C limit.",
                risky.len(),
                p.layer,
                p.risk.unwrap_or("?"),
                p.preheat_c,
                scene.interpass_c
            )
        }
    };
    if !above.is_empty() {
        let runs = super::scene::ranges(&above);
        evidence.push(OverLimit::count(scene).text(&runs, above.len(), scene.layers.len()));
    }
    // The process window (CTPP Eq.6): a deposit outside it is one the wire feed cannot lay as
    // planned, whatever the heat does.
    let ([lo, hi], tol) = (scene.window_mm, scene.window_tolerance_mm);
    let outside: Vec<&PointRecord> = scene
        .points
        .iter()
        .filter(|p| p.deposit_mm < lo - tol || p.deposit_mm > hi + tol)
        .collect();
    if !outside.is_empty() {
        let layers: std::collections::BTreeSet<usize> = outside.iter().map(|p| p.layer).collect();
        let (d_lo, d_hi) = outside.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
            (a.min(p.deposit_mm), b.max(p.deposit_mm))
        });
        evidence.push(format!(
            "The plan is not feasible (plan.json `feasible: false`): {} path points in {} \
             revolutions (from layer {}) ask for deposits of {d_lo:.2}–{d_hi:.2} mm, outside the \
             process window {lo:.2}–{hi:.2} mm (CTPP Eq.6). There the wire feed and travel speed \
             cannot lay the deposit the spiral asks for: expect the part to depart from its \
             mid-surface there (plan.json `violations`; path.csv `built_height_mm`, the as-built \
             stack). Near a closing point the revolutions cross converging generators and this is \
             expected; elsewhere, widen the window (`deposit_min_mm`, `deposit_max_mm`) or change \
             `n_points`.",
            outside.len(),
            layers.len(),
            layers.first().copied().unwrap_or(0),
        ));
    }
    let drops: Vec<&PointRecord> = scene.points.iter().filter(|p| p.strikes_drop).collect();
    if let Some(first) = drops.first() {
        evidence.push(format!(
            "The closing zone, from layer {}, is laid as {} drops, each struck after a wait until \
             the ring beneath it is under the limit (the longest {:.1} s): the closing strategy of \
             skeleton arc AM.",
            first.layer,
            drops.len(),
            drops.iter().map(|p| p.dwell_s).fold(0.0, f64::max)
        ));
    }
    let slowed: Vec<&PointRecord> = scene
        .points
        .iter()
        .filter(|p| p.pace != 1.0 && !p.in_drop)
        .collect();
    if !slowed.is_empty() {
        let layers: std::collections::BTreeSet<usize> = slowed.iter().map(|p| p.layer).collect();
        evidence.push(format!(
            "{} revolutions are slowed down with the arc on, up to {:.2} times (wire feed and \
             travel speed together, the deposit as planned), the least power {:.0} W.",
            layers.len(),
            slowed.iter().map(|p| p.pace).fold(1.0, f64::max),
            slowed
                .iter()
                .map(|p| p.power_w)
                .fold(f64::INFINITY, f64::min)
        ));
    }
    (safe, headline, evidence)
}

fn page(scene: &Scene, plots: &[(&str, &str, Vec<u8>)], files: &[(&str, &str)]) -> String {
    let (safe, headline, evidence) = verdict(scene);
    let dwell_total: f64 = scene.points.iter().map(|p| p.dwell_s).sum();
    let stops = scene.arc_stops();
    let revolutions = scene.layers.len();
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>{title}: waamtwin report</title>\n<style>\
         body{{font-family:sans-serif;max-width:1040px;margin:2em auto;color:#222}}\
         .verdict{{padding:1em;border-radius:6px;font-size:1.2em}}\
         .safe{{background:#e3f5e1;border:2px solid #3a9b3a}}\
         .risk{{background:#fbe4e1;border:2px solid #c0392b}}\
         table{{border-collapse:collapse}}td,th{{padding:4px 12px;border-bottom:1px solid #ddd;text-align:left}}\
         img{{max-width:100%;border:1px solid #ccc}}figcaption{{color:#555;margin-bottom:1.5em}}\
         </style></head><body>\n<h1>{title}</h1>\n",
        title = escape(&scene.title)
    );
    let _ = writeln!(
        h,
        "<p class=\"verdict {}\" id=\"verdict\">{}</p>",
        if safe { "safe" } else { "risk" },
        escape(&headline)
    );
    for e in &evidence {
        let _ = writeln!(h, "<p>{}</p>", escape(e));
    }
    h.push_str("<h2>The plan</h2>\n<table>\n");
    let rows = [
        ("revolutions (layers)", revolutions.to_string()),
        ("path points", scene.points.len().to_string()),
        (
            "arc stops (dwells and drops; one arc start and one stop for the spiral besides)",
            match scene.arc_stops_lower_bound {
                Some(b) => format!(
                    "{stops}: {:.1} times the fewest any plan can make ({b}, the lower bound of \
                     docs/PHYSICS.md)",
                    stops as f64 / b.max(1) as f64
                ),
                None => stops.to_string(),
            },
        ),
        ("dwell in all", format!("{dwell_total:.0} s")),
        ("build time", format!("{:.0} s", scene.build_s)),
        (
            "process window (deposit height)",
            format!("{:.2}–{:.2} mm", scene.window_mm[0], scene.window_mm[1]),
        ),
        ("interpass limit", format!("{:.0} °C", scene.interpass_c)),
    ];
    let closing = scene.closed.then(|| {
        let drops: Vec<&PointRecord> = scene.points.iter().filter(|p| p.strikes_drop).collect();
        let text = match drops.first() {
            Some(first) => format!(
                "drops: {} from layer {}, each struck after a wait until the ring beneath it is \
                 under the limit",
                drops.len(),
                first.layer
            ),
            None => "none: the spiral runs on to the closing point".to_string(),
        };
        ("closing strategy", text)
    });
    let sure = scene
        .confidence
        .as_ref()
        .map(|c| ("how sure the plan is", c.clone()));
    for (k, v) in rows.into_iter().chain(closing).chain(sure) {
        let _ = writeln!(h, "<tr><th>{}</th><td>{}</td></tr>", escape(k), escape(&v));
    }
    h.push_str("</table>\n<h2>Plots</h2>\n");
    for (name, what, png) in plots {
        let _ = writeln!(
            h,
            "<figure><img alt=\"{name}\" src=\"data:image/png;base64,{}\">\
             <figcaption>{} ({name})</figcaption></figure>",
            base64(png),
            escape(what)
        );
    }
    h.push_str("<h2>The files of this run</h2>\n<table>\n");
    for (f, what) in files {
        let _ = writeln!(h, "<tr><th>{f}</th><td>{}</td></tr>", escape(what));
    }
    // Tells a headless browser (and its test) whether every inlined plot decoded.
    h.push_str(
        "</table>\n<script>window.addEventListener('load',function(){var ok=true;\
         for(var i of document.images){ok=ok&&i.complete&&i.naturalWidth>0;}\
         document.body.setAttribute('data-images',ok?'ok':'broken');});</script>\n</body></html>\n",
    );
    h
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::OverLimit;

    /// A tube's first revolution warmed by its own arc is not called a closing point's, nor
    /// told to dwell; a dome's layers are told to dwell, its apex a closing strategy.
    #[test]
    fn each_kind_of_point_over_the_limit_gets_its_own_remedy() {
        let plate = OverLimit {
            plate: 6,
            ..OverLimit::default()
        }
        .text("0", 1, 43);
        assert!(
            plate.starts_with(
                "1 of 43 revolutions pass the limit at their hottest preheat (revolution 0)."
            ),
            "{plate}"
        );
        assert!(
            plate.contains("6 points over it lie on the plate"),
            "{plate}"
        );
        assert!(
            !plate.contains("closing") && !plate.contains("waamtwin dwell"),
            "{plate}"
        );
        let dome = OverLimit {
            earlier: 3966,
            just_laid: 25,
            ..OverLimit::default()
        }
        .text("5–50", 46, 51);
        assert!(
            dome.starts_with("46 of 51 revolutions pass the limit"),
            "{dome}"
        );
        assert!(dome.contains("(revolutions 5–50)."), "{dome}");
        assert!(
            dome.contains("3966 points over it lie on earlier revolutions"),
            "{dome}"
        );
        assert!(
            dome.contains("25 points over it lie on metal laid inside"),
            "{dome}"
        );
        assert!(!dome.contains("plate"), "{dome}");
    }

    #[test]
    fn text_is_escaped() {
        assert_eq!(
            super::escape("a<b & \"c\">"),
            "a&lt;b &amp; &quot;c&quot;&gt;"
        );
    }
}

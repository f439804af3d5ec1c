//! The report as one self-contained HTML file: images embedded as `data:` URIs, inline CSS
//! laid out for A4 (`@page`), no scripts and no external resources.

use std::fmt::Write as _;

use crate::metrics::{ObserverGlare, ScheduleRow, SourceStatus, SurfaceResult, UgrStatus};
use crate::render::shade::{FalseColor, LuxScale, viridis};
use crate::report::base64::png_data_uri;

/// An image for the report.
#[derive(Debug, Clone, Copy)]
pub struct ReportImage<'a> {
    /// Caption under the image.
    pub caption: &'a str,
    /// PNG bytes.
    pub png: &'a [u8],
}

/// Everything the report shows.
#[derive(Debug, Clone, Copy)]
pub struct ReportInput<'a> {
    /// The room's name.
    pub title: &'a str,
    /// The room file, as the user named it.
    pub room_file: &'a str,
    /// Plan and perspective views, in order.
    pub images: &'a [ReportImage<'a>],
    /// The false-colour scale of the false-colour views, drawn as a legend after the images.
    pub legend: Option<FalseColor>,
    /// Calculation surfaces.
    pub surfaces: &'a [SurfaceResult],
    /// Glare observers.
    pub observers: &'a [ObserverGlare],
    /// Luminaire schedule.
    pub schedule: &'a [ScheduleRow],
    /// Maintenance factor used.
    pub maintenance_factor: f64,
    /// Accuracy settings used: (setting, value) rows.
    pub accuracy: &'a [(String, String)],
    /// Remarks printed at the end (one paragraph each).
    pub notes: &'a [String],
}

/// Ticks on the false-colour legend.
const LEGEND_TICKS: usize = 6;

/// Page style: A4 portrait, tables that do not split across pages, pass/fail colours.
const STYLE: &str = "@page { size: A4 portrait; margin: 15mm 14mm; }
* { box-sizing: border-box; }
body { font-family: 'DejaVu Sans', Helvetica, Arial, sans-serif; font-size: 9.5pt; color: #111;
  max-width: 182mm; margin: 0 auto; padding: 8mm 0; line-height: 1.35; }
h1 { font-size: 16pt; margin: 0 0 2mm 0; }
h2 { font-size: 12pt; margin: 7mm 0 2mm 0; border-bottom: 1px solid #888; break-after: avoid; }
p.meta { color: #444; margin: 0 0 4mm 0; }
table { border-collapse: collapse; width: 100%; margin: 2mm 0 3mm 0; break-inside: avoid; }
th, td { border: 1px solid #aaa; padding: 1.2mm 1.6mm; vertical-align: top; }
th { background: #eee; text-align: left; font-weight: 600; }
td.n { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
.pass { color: #06601f; font-weight: 600; }
.fail { color: #b00020; font-weight: 700; }
.none { color: #777; }
figure { margin: 0 0 5mm 0; break-inside: avoid; }
figure img { display: block; width: 100%; height: auto; border: 1px solid #ccc; }
figcaption { font-size: 8.5pt; color: #333; margin-top: 1mm; }
.views { display: grid; grid-template-columns: 1fr 1fr; gap: 4mm; }
.views figure:first-child { grid-column: 1 / span 2; }
.legend { display: flex; align-items: center; gap: 3mm; break-inside: avoid; margin-bottom: 4mm; }
.legend .bar { flex: 1; height: 5mm; border: 1px solid #666; }
.legend .ticks { display: flex; justify-content: space-between; font-size: 8pt; }
.legend .scale { flex: 1; }
small { color: #555; }
table.values { font-size: 7.5pt; width: auto; }
table.values td, table.values th { padding: 0.6mm 1mm; }
@media print { body { padding: 0; } }
";

/// The report as HTML text.
pub fn html(input: &ReportInput) -> String {
    let mut out = String::with_capacity(
        4096 + input
            .images
            .iter()
            .map(|i| i.png.len() * 4 / 3 + 256)
            .sum::<usize>(),
    );
    let title = escape(input.title);
    let _ = write!(
        out,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>Lighting report: {title}</title>\n<style>\n{STYLE}</style>\n</head>\n<body>\n"
    );
    let _ = writeln!(out, "<h1>Lighting report: {title}</h1>");
    let _ = writeln!(
        out,
        "<p class=\"meta\">Room file <code>{}</code> · maintenance factor {} · illuminance in lux \
         (maintained values = new values × maintenance factor) · luminance in cd/m²</p>",
        escape(input.room_file),
        fixed(input.maintenance_factor, 2)
    );
    views(&mut out, input);
    surfaces(&mut out, input.surfaces);
    grid_values(&mut out, input.surfaces);
    glare(&mut out, input.observers);
    schedule(&mut out, input.schedule);
    settings(&mut out, input);
    if !input.notes.is_empty() {
        out.push_str("<h2>Notes</h2>\n");
        for note in input.notes {
            let _ = writeln!(out, "<p>{}</p>", escape(note));
        }
    }
    out.push_str("</body>\n</html>\n");
    out
}

fn views(out: &mut String, input: &ReportInput) {
    if input.images.is_empty() {
        return;
    }
    out.push_str("<h2>Views</h2>\n<div class=\"views\">\n");
    for image in input.images {
        let caption = escape(image.caption);
        let _ = writeln!(
            out,
            "<figure><img src=\"{}\" alt=\"{caption}\"><figcaption>{caption}</figcaption></figure>",
            png_data_uri(image.png)
        );
    }
    out.push_str("</div>\n");
    if let Some(scale) = input.legend {
        legend(out, &scale);
    }
}

/// A horizontal viridis bar with lux ticks for the false-colour views.
fn legend(out: &mut String, scale: &FalseColor) {
    let (lo, hi) = scale.range();
    let at = |t: f64| match scale.scale() {
        LuxScale::Linear => lo + t * (hi - lo),
        LuxScale::Log => lo * (hi / lo).powf(t),
    };
    let stops: Vec<String> = (0..=10)
        .map(|k| {
            let t = k as f64 / 10.0;
            let [r, g, b] = viridis(t);
            format!("rgb({r},{g},{b}) {}%", k * 10)
        })
        .collect();
    let ticks: Vec<String> = (0..LEGEND_TICKS)
        .map(|k| format!("<span>{}</span>", lux(at(k as f64 / (LEGEND_TICKS - 1) as f64))))
        .collect();
    let kind = match scale.scale() {
        LuxScale::Linear => "linear",
        LuxScale::Log => "logarithmic",
    };
    let _ = writeln!(
        out,
        "<div class=\"legend\"><span>False colour, new illuminance (lx, {kind} scale)</span>\
         <div class=\"scale\"><div class=\"bar\" style=\"background: linear-gradient(to right, {});\"></div>\
         <div class=\"ticks\">{}</div></div></div>",
        stops.join(", "),
        ticks.join("")
    );
}

fn surfaces(out: &mut String, results: &[SurfaceResult]) {
    out.push_str("<h2>Calculation surfaces</h2>\n");
    if results.is_empty() {
        out.push_str("<p class=\"none\">No calculation surfaces.</p>\n");
        return;
    }
    out.push_str(
        "<table>\n<tr><th>Surface</th><th>Grid</th><th>Ē<sub>m</sub> lx</th><th>target</th>\
         <th>E<sub>min</sub> lx</th><th>E<sub>max</sub> lx</th><th>U0</th><th>target</th>\
         <th>g2</th><th>target</th><th>Result</th></tr>\n",
    );
    for r in results {
        let s = r.summary();
        let mut name = escape(s.name);
        if let Some(task) = r.task {
            let _ = write!(
                name,
                "<br><small>{} ({})</small>",
                escape(task.name),
                escape(task.source)
            );
        }
        let cells: Vec<String> = r
            .grid
            .parts
            .iter()
            .map(|p| {
                format!(
                    "{}×{} cells of {}×{} m",
                    p.cells.counts[0],
                    p.cells.counts[1],
                    fixed(p.cells.cell_m[0], 2),
                    fixed(p.cells.cell_m[1], 2)
                )
            })
            .collect();
        let mut grid = format!("{} points: {}", s.points, cells.join("; "));
        if s.skipped_in_furniture > 0 {
            let _ = write!(grid, " ({} under furniture left out)", s.skipped_in_furniture);
        }
        let (Some(stats), Some(check)) = (r.stats, r.check) else {
            let _ = writeln!(
                out,
                "<tr><td>{name}</td><td>{}</td><td colspan=\"9\" class=\"none\">every point lies under furniture</td></tr>",
                escape(&grid)
            );
            continue;
        };
        let target = |t: Option<f64>, digits: usize| {
            t.map_or("–".to_string(), |v| format!("≥ {}", fixed(v, digits)))
        };
        let _ = writeln!(
            out,
            "<tr><td>{name}</td><td>{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td>\
             <td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td>\
             <td class=\"n\">{}</td><td class=\"n\">{}</td><td>{}</td></tr>",
            escape(&grid),
            marked(lux(stats.e_avg), check.e_avg.pass),
            target(check.e_avg.target, 0),
            lux(stats.e_min),
            lux(stats.e_max),
            marked(fixed(stats.u0, 2), check.u0.pass),
            target(check.u0.target, 2),
            marked(fixed(stats.g2, 2), check.g2.pass),
            target(check.g2.target, 2),
            verdict(s.pass),
        );
    }
    out.push_str("</table>\n");
}

/// Most columns a grid may have for its values to be printed as a table.
pub(crate) const MAX_VALUE_COLUMNS: usize = 20;
/// Most rows a grid may have for its values to be printed as a table.
pub(crate) const MAX_VALUE_ROWS: usize = 40;

/// The maintained illuminance at every point of each single-rectangle grid small enough to
/// print, laid out as seen in plan (first edge to the right, second edge up); points under
/// furniture are shown as `–`.
fn grid_values(out: &mut String, results: &[SurfaceResult]) {
    for r in results {
        let [part] = r.grid.parts.as_slice() else {
            continue;
        };
        let [columns, rows] = part.cells.counts;
        if columns > MAX_VALUE_COLUMNS || rows > MAX_VALUE_ROWS || r.lux.is_empty() {
            continue;
        }
        let mf = r.stats.map_or(1.0, |s| s.maintenance_factor);
        let mut values = vec![vec![None; columns]; rows];
        for (index, &e) in r.grid.indices.iter().zip(&r.lux) {
            values[index.j][index.i] = Some(mf * e);
        }
        let _ = writeln!(
            out,
            "<h2>{}: maintained illuminance at the grid points (lx)</h2>\n<table class=\"values\">",
            escape(&r.grid.name)
        );
        for (j, row) in values.iter().enumerate().rev() {
            let cells: String = row
                .iter()
                .map(|v| match v {
                    Some(e) => format!("<td class=\"n\">{}</td>", lux(*e)),
                    None => "<td class=\"n none\">–</td>".to_string(),
                })
                .collect();
            let _ = writeln!(out, "<tr><th>{}</th>{cells}</tr>", j + 1);
        }
        let numbers: String = (1..=columns).map(|i| format!("<th>{i}</th>")).collect();
        let _ = writeln!(out, "<tr><th></th>{numbers}</tr>\n</table>");
        let _ = writeln!(
            out,
            "<p class=\"meta\">Rows from the far edge down, columns from the origin corner ({}) to the right; cells of {}×{} m.</p>",
            triple(part.origin.to_array(), 2),
            fixed(part.cells.cell_m[0], 2),
            fixed(part.cells.cell_m[1], 2)
        );
    }
}

fn glare(out: &mut String, observers: &[ObserverGlare]) {
    out.push_str("<h2>Glare (UGR, CIE 117)</h2>\n");
    if observers.is_empty() {
        out.push_str("<p class=\"none\">No observers.</p>\n");
        return;
    }
    out.push_str(
        "<table>\n<tr><th>Observer</th><th>Eye (m)</th><th>View</th><th>L<sub>b</sub> cd/m²</th>\
         <th>Luminaires counted</th><th>UGR</th><th>UGR<sub>L</sub></th><th>Result</th></tr>\n",
    );
    for o in observers {
        let counted = o
            .sources
            .iter()
            .filter(|s| s.status == SourceStatus::Counted)
            .count();
        let mut left_out: Vec<String> = Vec::new();
        for status in [
            SourceStatus::Hidden,
            SourceStatus::NoLuminousArea,
            SourceStatus::NotFacing,
        ] {
            let names: Vec<&str> = o
                .sources
                .iter()
                .filter(|s| s.status == status)
                .map(|s| s.name.as_str())
                .collect();
            if !names.is_empty() {
                left_out.push(format!("{}: {}", status.describe(), names.join(", ")));
            }
        }
        let mut counted_cell = counted.to_string();
        if !left_out.is_empty() {
            let _ = write!(
                counted_cell,
                "<br><small>{}</small>",
                escape(&left_out.join("; "))
            );
        }
        let flagged = o
            .sources
            .iter()
            .any(|s| s.status == SourceStatus::Counted && s.term > 0.0 && !s.omega_in_range);
        let value = match (o.status, o.ugr) {
            (UgrStatus::Rated, Some(u)) => {
                let mut v = marked(fixed(u, 1), o.pass);
                if flagged {
                    v.push_str("<br><small>ω outside 0.0003–0.1 sr</small>");
                }
                v
            }
            (UgrStatus::NoBackground, _) => "undefined (L<sub>b</sub> = 0)".to_string(),
            _ => "no glare source".to_string(),
        };
        let _ = writeln!(
            out,
            "<tr><td>{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td>{counted_cell}</td>\
             <td class=\"n\">{value}</td><td class=\"n\">{}</td><td>{}</td></tr>",
            escape(&o.name),
            triple(o.eye, 2),
            triple(o.view, 2),
            fixed(o.background_luminance, 1),
            o.limit.map_or("–".to_string(), |l| format!("≤ {}", fixed(l, 0))),
            verdict(o.pass),
        );
    }
    out.push_str("</table>\n");
}

fn schedule(out: &mut String, rows: &[ScheduleRow]) {
    out.push_str("<h2>Luminaire schedule</h2>\n");
    if rows.is_empty() {
        out.push_str("<p class=\"none\">No luminaires.</p>\n");
        return;
    }
    out.push_str(
        "<table>\n<tr><th>Luminaires</th><th>Photometry</th><th>Luminous area</th><th>Flux lm</th>\
         <th>Dimmer</th><th>Flux as dimmed lm</th><th>Count</th><th>Positions (m)</th></tr>\n",
    );
    for row in rows {
        let positions: Vec<String> = row.positions.iter().map(|p| triple(*p, 2)).collect();
        let _ = writeln!(
            out,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td class=\"n\">{}</td><td class=\"n\">{} %</td>\
             <td class=\"n\">{}</td><td class=\"n\">{}</td><td>{}</td></tr>",
            escape(&row.names.join(", ")),
            row.file.as_deref().map_or("inline curve".to_string(), escape),
            row.luminous
                .as_deref()
                .map_or("<span class=\"none\">unknown</span>".to_string(), escape),
            fixed(row.flux_lm, 0),
            fixed(100.0 * row.dimmer, 1),
            fixed(row.dimmed_flux_lm, 0),
            row.count,
            positions.join("<br>"),
        );
    }
    out.push_str("</table>\n");
}

fn settings(out: &mut String, input: &ReportInput) {
    out.push_str("<h2>Calculation settings</h2>\n<table>\n");
    let _ = writeln!(
        out,
        "<tr><th>Maintenance factor</th><td class=\"n\">{}</td></tr>",
        fixed(input.maintenance_factor, 2)
    );
    for (setting, value) in input.accuracy {
        let _ = writeln!(
            out,
            "<tr><th>{}</th><td>{}</td></tr>",
            escape(setting),
            escape(value)
        );
    }
    out.push_str("</table>\n");
}

/// `text` with the five HTML-special characters escaped.
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// `value` with `digits` decimals.
fn fixed(value: f64, digits: usize) -> String {
    format!("{value:.digits$}")
}

/// Lux for tables: whole numbers from 10 lx up, one decimal below.
fn lux(value: f64) -> String {
    if value.abs() >= 10.0 {
        fixed(value, 0)
    } else {
        fixed(value, 1)
    }
}

/// `[x, y, z]` as `x, y, z`.
fn triple(v: [f64; 3], digits: usize) -> String {
    v.map(|x| fixed(x, digits)).join(", ")
}

/// A value with its pass/fail mark.
fn marked(value: String, pass: Option<bool>) -> String {
    match pass {
        Some(true) => format!("{value} <span class=\"pass\">✓</span>"),
        Some(false) => format!("{value} <span class=\"fail\">✗</span>"),
        None => value,
    }
}

/// The verdict cell.
fn verdict(pass: Option<bool>) -> &'static str {
    match pass {
        Some(true) => "<span class=\"pass\">pass</span>",
        Some(false) => "<span class=\"fail\">fail</span>",
        None => "<span class=\"none\">no target</span>",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaping_and_number_formats() {
        assert_eq!(
            escape("<b>\"A&B's\"</b>"),
            "&lt;b&gt;&quot;A&amp;B&#39;s&quot;&lt;/b&gt;"
        );
        assert_eq!(lux(507.6), "508");
        assert_eq!(lux(7.26), "7.3");
        assert_eq!(triple([1.0, 2.5, 0.126], 2), "1.00, 2.50, 0.13");
        assert_eq!(
            marked("0.61".into(), Some(true)),
            "0.61 <span class=\"pass\">✓</span>"
        );
    }
}

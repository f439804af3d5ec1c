//! `haiko accuracy ROOM [--json]`: runs the accuracy study ([`crate::accuracy`]) and prints its
//! tables as text, or one JSON object with one array per table.

use std::fmt::Write as _;
use std::path::Path;

use crate::accuracy::{AccuracyOptions, AccuracyReport, ErrorStats, FieldErrors, accuracy};
use crate::cli::load_room;
use crate::error::{Error, Result};

/// `max / median` as percentages.
fn pct(e: &ErrorStats) -> String {
    format!("{:>9} {:>9}", percent(e.max_rel), percent(e.median_rel))
}

/// A dimensionless error as a percentage with a sensible precision.
fn percent(x: f64) -> String {
    let p = 100.0 * x;
    if !p.is_finite() {
        "—".into()
    } else if p == 0.0 {
        "0".into()
    } else if p >= 0.1 {
        format!("{p:.2}%")
    } else {
        format!("{p:.1e}%")
    }
}

fn fields(e: &FieldErrors) -> String {
    format!("{}  {}", pct(&e.grid), pct(&e.vertices))
}

/// The whole report as text: a header, how each reference was made, then the seven tables.
pub fn format_report(r: &AccuracyReport) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {} fine vertices, {} coarse patches; work plane {} points, floor samples {} points",
        r.room, r.fine_vertices, r.coarse_patches, r.grid_points, r.floor_points
    );
    let _ = writeln!(
        s,
        "Errors: max = max|E − E_ref| / max|E_ref|; med = median |E − E_ref| / E_ref over points with E_ref ≥ 1 % of its max."
    );
    let _ = writeln!(
        s,
        "Each table varies one knob; the others stay at the room's settings (hybrid mode).\n\nReferences:"
    );
    for reference in &r.references {
        let check = match (
            &reference.checked_against,
            reference.difference,
            reference.smallest_error,
        ) {
            (Some(against), Some(d), Some(e)) => format!(
                "vs {against}: differs by {} (grid) / {} (vertices), smallest errors in the table {} / {} — {}",
                percent(d.grid),
                percent(d.vertices),
                percent(e.grid),
                percent(e.vertices),
                if reference.converged {
                    "converged"
                } else {
                    "NOT converged"
                }
            ),
            _ => "exact by construction".to_string(),
        };
        let _ = writeln!(s, "  {:<18} {}; {}", reference.table, reference.made, check);
    }
    let grid_vertices = "  grid max  grid med  vert max  vert med";

    let _ = writeln!(s, "\n1. SH order N (every light)");
    let _ = writeln!(
        s,
        "{:>3} {:>7} {:>10} {:>9} {:>9} | hybrid{grid_vertices} | paper{grid_vertices}",
        "N", "columns", "bake ms", "edit ms", "paper ms"
    );
    for row in &r.order {
        let _ = writeln!(
            s,
            "{:>3} {:>7} {:>10.1} {:>9.3} {:>9.3} |       {} |      {}",
            row.order,
            row.columns,
            row.bake_ms,
            row.edit_ms,
            row.edit_paper_ms,
            fields(&row.hybrid),
            fields(&row.paper)
        );
    }

    let _ = writeln!(s, "\n2. Coarse (solver) patch size");
    let _ = writeln!(
        s,
        "{:>8} {:>8} {:>10} |{grid_vertices}",
        "size m", "patches", "bake ms"
    );
    for row in &r.coarse {
        let _ = writeln!(
            s,
            "{:>8.3} {:>8} {:>10.1} | {}",
            row.solver_patch_size_m,
            row.patches,
            row.bake_ms,
            fields(&row.errors)
        );
    }

    let _ = writeln!(
        s,
        "\n3. Fine (display) patch size: fine-vertex field vs exact at the vertices (indirect interpolated from coarse \
         patches), and as displayed (linear between vertices) vs exact at floor points between vertices"
    );
    let _ = writeln!(
        s,
        "{:>8} {:>8} {:>9} {:>9} | {:>9} {:>9} | {:>9} {:>9}",
        "size m", "vertices", "build ms", "edit ms", "vert max", "vert med", "floor max", "floor med"
    );
    for row in &r.fine {
        let _ = writeln!(
            s,
            "{:>8.3} {:>8} {:>9.1} {:>9.3} | {} | {}",
            row.patch_size_m,
            row.vertices,
            row.relighter_build_ms,
            row.edit_ms,
            pct(&row.at_vertices),
            pct(&row.between_vertices)
        );
    }

    let _ = writeln!(
        s,
        "\n4. Solver tolerance (certified and true relative radiosity error, worst column)"
    );
    let _ = writeln!(
        s,
        "{:>9} {:>9} {:>5} {:>10} {:>10} |{grid_vertices}",
        "tol", "solve ms", "iter", "certified", "true"
    );
    for row in &r.tolerance {
        let _ = writeln!(
            s,
            "{:>9.0e} {:>9.1} {:>5} {:>10.2e} {:>10.2e} | {}",
            row.tolerance,
            row.solve_ms,
            row.iterations,
            row.certified_error,
            row.true_error,
            fields(&row.errors)
        );
    }

    let _ = writeln!(
        s,
        "\n5. Quadrature of w_l: weight error max|Δw_l|/max|w_l| (l ≤ highest tested order) and the light's \
         paper-mode direct light on the work plane at its order"
    );
    let _ = writeln!(
        s,
        "{:<12} {:<14} {:>9} {:>10} | {:>9} {:>9}",
        "light", "method", "time ms", "w error", "grid max", "grid med"
    );
    for row in &r.quadrature {
        let _ = writeln!(
            s,
            "{:<12} {:<14} {:>9.4} {:>10.2e} | {}",
            row.light,
            row.method,
            row.time_ms,
            row.weight_error,
            pct(&row.illuminance)
        );
    }

    let _ = writeln!(
        s,
        "\n6. Direct light alone: exact (hybrid) vs from the SH series (paper)"
    );
    let _ = writeln!(
        s,
        "{:<12} {:<7} {:>3} {:>9} |{grid_vertices}",
        "light", "mode", "N", "edit ms"
    );
    for row in &r.direct {
        let _ = writeln!(
            s,
            "{:<12} {:<7} {:>3} {:>9.3} | {}",
            row.light,
            row.mode,
            row.order,
            row.edit_ms,
            fields(&row.direct)
        );
    }

    if !r.engine.is_empty() {
        let _ = writeln!(
            s,
            "\n7. Hierarchical engine: one knob at a time from its defaults (exact direct light plus the engine's indirect light)"
        );
        let _ = writeln!(
            s,
            "{:<44} {:>7} {:>9} {:>9} {:>9} |{grid_vertices}",
            "variant", "leaves", "links", "build ms", "solve ms"
        );
        for row in &r.engine {
            let _ = writeln!(
                s,
                "{:<44} {:>7} {:>9} {:>9.1} {:>9.1} | {}",
                row.variant,
                row.leaves,
                row.links,
                row.build_ms,
                row.solve_ms,
                fields(&row.errors)
            );
        }
    }

    if !r.estimate.is_empty() {
        let _ = writeln!(
            s,
            "\n8. The editor's estimate of an edit while its solve runs (light 0; its indirect light at the fine vertices against the edit's solve: largest difference / largest value, and largest difference / the vertex's total illuminance)"
        );
        let _ = writeln!(
            s,
            "{:<12} {:>9} {:>12} | {:>9} {:>11} | {:>14} {:>15}",
            "SH degree", "build ms", "estimate ms", "re-aim", "curve edit", "re-aim, total", "curve, total"
        );
        for row in &r.estimate {
            let order = row.order.map_or("none".to_string(), |n| n.to_string());
            let _ = writeln!(
                s,
                "{:<12} {:>9.1} {:>12.3} | {:>9} {:>11} | {:>14} {:>15}",
                order,
                row.build_ms,
                row.estimate_ms,
                percent(row.reaim),
                percent(row.curve),
                percent(row.reaim_of_total),
                percent(row.curve_of_total)
            );
        }
    }
    s
}

/// Runs `haiko accuracy ROOM [--json]`; progress goes to standard error.
pub fn run(room: &Path, json: bool) -> Result<()> {
    let scene = load_room(room)?;
    let mut progress = |line: &str| eprintln!("accuracy: {line}");
    let report = accuracy(&scene, &AccuracyOptions::default(), &mut progress)?;
    if json {
        let text = serde_json::to_string_pretty(&report).map_err(|e| Error::internal(e.to_string()))?;
        println!("{text}");
    } else {
        print!("{}", format_report(&report));
    }
    Ok(())
}

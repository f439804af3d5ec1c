//! `haiko plan ROOM` and `haiko bake ROOM`: what the bake will simulate and why, and the bake
//! itself with sizes, memory, solver iterations, certified error and timings.

use std::io::{IsTerminal, Write};
use std::path::Path;
use std::time::Instant;

use crate::cli::{load_room, open_session};
use crate::error::{Error, Result, check_finite, printable};
use crate::session::budget::{EngineKind, Estimate, LimitSource, MemoryLimit};
use crate::transport::bake::{Bake, Progress};
use crate::transport::indirect::{EditCosts, IndirectStats};
use crate::transport::plan::{Plan, PlanOptions, plan};

/// Formats a plan with its reasons.
pub(crate) fn format_plan(p: &Plan) -> String {
    let on = |b: bool| if b { "on " } else { "off" };
    let mut s = String::new();
    s.push_str(&format!(
        "visibility       {}  {}\n",
        on(p.visibility.on),
        p.visibility.reason
    ));
    s.push_str(&format!(
        "interreflection  {}  {}\n",
        on(p.interreflection.on),
        p.interreflection.reason
    ));
    s.push_str(&format!(
        "channels         {}    {}\n",
        p.channels, p.channels_reason
    ));
    s.push_str(&format!(
        "direct basis     {}  {}\n",
        on(p.direct_basis.on),
        p.direct_basis.reason
    ));
    s.push_str(&format!(
        "hierarchical     {}  {}\n",
        on(p.hierarchical.on),
        p.hierarchical.reason
    ));
    for note in &p.refinement {
        s.push_str(&format!("refinement       {}\n", printable(note)));
    }
    for l in &p.lights {
        s.push_str(&format!(
            "light {:<10} order {:>2} ({} columns): {}\n    window {}: {}\n    mask: {}\n",
            printable(&l.name),
            l.order,
            l.columns,
            l.order_reason,
            l.window.name(),
            l.window_reason,
            if l.mask_reason.is_empty() {
                "no"
            } else {
                &l.mask_reason
            }
        ));
    }
    if p.hierarchical.on {
        // No basis is baked: the orders above only draw the polar diagram's series.
        s.push_str(&format!(
            "mesh: {} fine vertices, {} coarse patches, {} solver leaves; no SH basis is baked (the orders above draw the polar diagram's series)\n",
            p.fine_vertices, p.coarse_patches, p.leaves
        ));
        s.push_str(
            "expected: the engine's memory by part and its per-edit costs are measured by `haiko bake`\n",
        );
        return s;
    }
    s.push_str(&format!(
        "mesh: {} fine vertices, {} coarse patches; {} basis columns in all\n",
        p.fine_vertices, p.coarse_patches, p.columns
    ));
    s.push_str(&format!(
        "expected: basis {:.2} MB ({} B per coarse patch and column: direct + indirect, f32), form factors {:.2} MB, at most {} visibility rays\n",
        p.basis_bytes as f64 / 1e6,
        8,
        p.form_factor_bytes as f64 / 1e6,
        p.form_factor_rays
    ));
    s
}

/// Runs `haiko plan`.
pub(crate) fn run_plan(room: &Path, json: bool, limit: &MemoryLimit) -> Result<()> {
    let scene = load_room(room)?;
    let p = plan(&scene, PlanOptions::default());
    check_finite(
        "plan: a mounting normal",
        p.lights.iter().flat_map(|l| l.mask.into_iter().flatten()),
    )?;
    let estimate = Estimate::of(&p, true);
    if json {
        let json_error = |e: serde_json::Error| Error::internal(e.to_string());
        let mut doc = serde_json::to_value(&p).map_err(json_error)?;
        doc["notes"] = serde_json::json!(scene.notes);
        doc["budget"] = serde_json::json!({
            "estimate_bytes": estimate.bytes(),
            "form_factor_bytes": estimate.form_factor_bytes,
            "basis_bytes": estimate.basis_bytes,
            "engine_bytes": estimate.engine_bytes,
            "relight_bytes": estimate.relight_bytes,
            "rays": estimate.rays,
            "max_links": (estimate.engine == EngineKind::Hierarchical).then(|| estimate.max_links(limit)),
            "limit_bytes": limit.bytes,
            "limit_from": match limit.source {
                LimitSource::Option => "--max-memory",
                LimitSource::Machine => "half the available memory",
            },
            "within": estimate.bytes() <= limit.bytes,
        });
        println!("{}", serde_json::to_string_pretty(&doc).map_err(json_error)?);
    } else {
        print!("{}", format_plan(&p));
        println!("{}", format_budget(&estimate, limit));
    }
    Ok(())
}

/// One line on the estimate against the limit: what `bake` (and the other commands) will check.
pub(crate) fn format_budget(estimate: &Estimate, limit: &MemoryLimit) -> String {
    let verdict = if estimate.bytes() <= limit.bytes {
        "within"
    } else {
        "ABOVE (the commands that simulate will refuse)"
    };
    let links = if estimate.engine == EngineKind::Hierarchical && estimate.bytes() <= limit.bytes {
        format!(
            ", which leaves room for {:.2e} links",
            estimate.max_links(limit) as f64
        )
    } else {
        String::new()
    };
    format!("budget: {estimate}; {verdict} the limit of {limit}{links}")
}

/// A progress reporter for the command line: a redrawn bar on a terminal, stage lines otherwise.
pub(crate) fn progress_printer() -> impl FnMut(Progress) {
    let tty = std::io::stderr().is_terminal();
    let mut last_stage = "";
    move |p: Progress| {
        let mut err = std::io::stderr();
        if tty {
            let width = 30;
            let filled = (p.done * width).checked_div(p.total).unwrap_or(width);
            let _ = write!(
                err,
                "\r{:<24} [{}{}] {}/{}",
                p.stage,
                "#".repeat(filled),
                " ".repeat(width - filled),
                p.done,
                p.total
            );
            if p.done == p.total {
                let _ = writeln!(err);
            }
        } else if p.stage != last_stage {
            let _ = writeln!(err, "bake: {} …", p.stage);
        }
        last_stage = p.stage;
    }
}

/// Formats what a bake did.
pub(crate) fn format_bake(b: &Bake) -> String {
    let mut s = String::new();
    let t = &b.timings;
    for l in &b.lights {
        let bytes = (l.direct.len() + l.indirect.iter().map(Vec::len).sum::<usize>()) * 4;
        s.push_str(&format!(
            "light {:<10} order {:>2}, {:>4} columns, {:>8.2} MB, {}\n",
            printable(&l.plan.name),
            l.plan.order,
            l.n_columns,
            bytes as f64 / 1e6,
            if l.from_cache {
                "from the cache".to_string()
            } else if l.has_indirect() {
                format!(
                    "solved in ≤ {} GMRES steps, certified relative error ≤ {:.1e}",
                    l.iterations, l.certified_error
                )
            } else {
                "no interreflection".to_string()
            }
        ));
    }
    let n = b.plan.coarse_patches;
    s.push_str(&format!(
        "memory: form factors {:.2} MB ({n}² × 4 B), basis {:.2} MB ({} coarse patches × {} columns × {} channel(s) × 8 B)\n",
        b.form_factor_bytes as f64 / 1e6,
        b.lights.iter().map(|l| (l.direct.len() + l.indirect.iter().map(Vec::len).sum::<usize>()) * 4).sum::<usize>() as f64 / 1e6,
        n,
        b.plan.columns / b.plan.channels.max(1),
        b.plan.channels,
    ));
    // Relight state per fine vertex: per light the direct cache (unit direction 24 B + factor 8 B),
    // its direct lux (8 B) and RGB contribution (24 B); the RGB total (24 B); at most four
    // coarse → fine interpolation terms (16 B each).
    let per_vertex = 64 * b.lights.len() + 24 + 64;
    s.push_str(&format!(
        "relight memory: ≤ {per_vertex} B per fine vertex ({} lights × 64 B + 88 B) × {} vertices = {:.2} MB; basis {} B per coarse patch and column and channel (f32 direct + indirect)\n",
        b.lights.len(),
        b.plan.fine_vertices,
        (per_vertex * b.plan.fine_vertices) as f64 / 1e6,
        8
    ));
    s.push_str(&format!(
        "visibility rays cast for form factors: {}\n",
        b.form_factor_rays
    ));
    s.push_str(&format!(
        "time: plan {:.1} ms, cache read {:.1} ms, form factors {:.1} ms, basis direct {:.1} ms, solve {:.1} ms, cache write {:.1} ms\n",
        t.plan_s * 1e3,
        t.cache_read_s * 1e3,
        t.form_factors_s * 1e3,
        t.basis_direct_s * 1e3,
        t.solve_s * 1e3,
        t.cache_write_s * 1e3
    ));
    s
}

/// What `haiko bake` found of the hierarchical engine: its sizes and times, light 0's measured
/// edits (none in a room without lights) and the wall seconds until the engine was ready.
struct Engine {
    stats: IndirectStats,
    costs: Option<EditCosts>,
    ready_s: f64,
}

/// Runs `haiko bake`: the plan, then the bake (or the hierarchical engine with its measured
/// per-edit costs); `json` prints one JSON document instead.
pub(crate) fn run_bake(room: &Path, json: bool, limit: &MemoryLimit) -> Result<()> {
    let started = Instant::now();
    let scene = load_room(room)?;
    let p = plan(&scene, PlanOptions::default());
    // Refused before the plan is printed: the one line on standard error is all that shows.
    limit.check(room, &Estimate::of(&p, true))?;
    if !json {
        print!("{}", format_plan(&p));
    }
    let notes = scene.notes.clone();
    let session = open_session(scene, true, limit)?;
    // The bake itself: the room read, planned, its engine built and every light solved.
    let ready_s = started.elapsed().as_secs_f64();
    // The session is not needed any more: the measured move frees the engine before it builds
    // the moved room's (HierarchicalIndirect::measure_edits).
    let (scene, b, hierarchical) = session.into_parts();
    let b = b.ok_or_else(|| Error::internal("bake: the session has no bake"))?;
    let plan_s = b.timings.plan_s;
    let engine = match hierarchical {
        Some(h) => {
            let stats = h.stats();
            let costs = if scene.lights.is_empty() {
                None
            } else {
                Some(h.measure_edits(&scene, 0)?)
            };
            Some(Engine {
                stats,
                costs,
                ready_s,
            })
        }
        None => None,
    };
    match (json, engine) {
        (true, engine) => {
            let json_error = |e: serde_json::Error| Error::internal(e.to_string());
            let mut doc = bake_json(&b, plan_s, engine.as_ref());
            doc["notes"] = serde_json::json!(notes);
            println!("{}", serde_json::to_string_pretty(&doc).map_err(json_error)?);
        }
        (false, Some(engine)) => print!("{}", format_hierarchical(&engine)),
        (false, None) => print!("{}", format_bake(&b)),
    }
    Ok(())
}

/// Formats the hierarchical engine's sizes, memory by part, times by stage and per-edit costs.
fn format_hierarchical(engine: &Engine) -> String {
    let (stats, costs) = (&engine.stats, engine.costs.as_ref());
    let e = &stats.engine;
    let mb = |b: usize| b as f64 / 1e6;
    let mut s = format!(
        "hierarchical engine: {} coarse patches → {} leaves, {} nodes, {} links ({} between leaves), {} visibility rays\n",
        e.coarse_patches, e.leaves, e.nodes, e.links, e.near_links, e.rays
    );
    s.push_str(&format!(
        "memory: operator {:.2} MB, node geometry {:.2} MB, lights {:.2} MB, interpolation {:.2} MB; {:.2} MB in all\n",
        mb(e.operator_bytes),
        mb(e.geometry_bytes),
        mb(stats.light_bytes),
        mb(stats.interpolation_bytes),
        mb(stats.total_bytes())
    ));
    s.push_str(&format!(
        "time: refinement {:.1} ms, links {:.1} ms, balancing {:.1} ms ({} sweeps, power conserved to {:.1e}), operator {} ({:.1} ms in the cache), direct caches {:.1} ms, solve {:.1} ms ({} lights from the cache)\n",
        e.refine_s * 1e3,
        e.links_s * 1e3,
        e.balance_s * 1e3,
        e.balance.sweeps,
        e.balance.defect,
        e.operator_origin.describe(),
        e.cache_s * 1e3,
        stats.direct_caches_s * 1e3,
        stats.solve_s * 1e3,
        stats.lights_from_cache
    ));
    s.push_str(&format!(
        "ready after {:.1} s (the room read, planned, its engine built and every light solved; the measured edits below come after)\n",
        engine.ready_s
    ));
    if let Some(c) = costs {
        s.push_str(&format!(
            "per edit of the first light: curve {:.1} ms, then a point's intensity {:.1} ms and again {:.2} ms, re-aim {:.1} ms, dimmer {:.2} ms, 0.1 m move {:.1} ms{}\n",
            c.curve_s * 1e3,
            c.point_s * 1e3,
            c.point_again_s * 1e3,
            c.aim_s * 1e3,
            c.dimmer_s * 1e3,
            c.move_s * 1e3,
            if c.move_rebuilt { " (the move regrades: engine rebuilt)" } else { "" }
        ));
        if let Some(g) = &c.grown {
            s.push_str(&format!(
                "its curve response grown to every control point while idle: {} steps, {:.1} ms in all; then a curve edit {:.2} ms from the response, no solve\n",
                g.steps,
                g.grow_s * 1e3,
                g.curve_s * 1e3,
            ));
        }
        if let Some(p) = &c.aim_prepared {
            s.push_str(&format!(
                "that re-aim prepared first, as the editor does where its aim cursor rests: {:.2} ms, no solve (the preparation {:.1} ms in the background)\n",
                p.aim_s * 1e3,
                p.prepare_s * 1e3,
            ));
        }
        let e = &c.aim_estimate;
        s.push_str(&format!(
            "editor's estimate of that re-aim: {:.2} ms from the light's SH response (built in {:.1} ms), off the solve by {:.2} % of its peak indirect light (without it {:.2} %), {:.3} % of the total illuminance at worst, {:.4} % at the median vertex (without it {:.3} % at worst)\n",
            e.estimate_s * 1e3,
            e.build_s * 1e3,
            e.error * 100.0,
            e.unestimated_error * 100.0,
            e.error_of_total * 100.0,
            e.median_error_of_total * 100.0,
            e.unestimated_error_of_total * 100.0,
        ));
    }
    s
}

/// The JSON document of `haiko bake --json`: the engine, and for the hierarchical one its
/// counts, memory by part (with the total), time by stage and per-edit costs (seconds).
fn bake_json(b: &Bake, plan_s: f64, engine: Option<&Engine>) -> serde_json::Value {
    let Some(Engine {
        stats,
        costs,
        ready_s,
    }) = engine
    else {
        let t = &b.timings;
        return serde_json::json!({
            "engine": "basis",
            "coarse_patches": b.plan.coarse_patches,
            "columns": b.plan.columns,
            "memory_bytes": {
                "form_factors": b.form_factor_bytes,
                "basis": b.lights.iter().map(|l| (l.direct.len() + l.indirect.iter().map(Vec::len).sum::<usize>()) * 4).sum::<usize>(),
            },
            "time_s": {
                "plan": t.plan_s,
                "cache_read": t.cache_read_s,
                "form_factors": t.form_factors_s,
                "basis_direct": t.basis_direct_s,
                "solve": t.solve_s,
                "cache_write": t.cache_write_s,
            },
        });
    };
    let e = &stats.engine;
    let mut doc = serde_json::json!({
        "engine": "hierarchical",
        "coarse_patches": e.coarse_patches,
        "leaves": e.leaves,
        "nodes": e.nodes,
        "links": e.links,
        "near_links": e.near_links,
        "rays": e.rays,
        "balancing": {"sweeps": e.balance.sweeps, "defect": e.balance.defect},
        "operator": e.operator_origin.describe(),
        "lights_from_cache": stats.lights_from_cache,
        "memory_bytes": {
            "operator": e.operator_bytes,
            "node_geometry": e.geometry_bytes,
            "lights": stats.light_bytes,
            "interpolation": stats.interpolation_bytes,
            "total": stats.total_bytes(),
        },
        "time_s": {
            "plan": plan_s,
            "refine": e.refine_s,
            "links": e.links_s,
            "balance": e.balance_s,
            "operator_cache": e.cache_s,
            "direct_caches": stats.direct_caches_s,
            "solve": stats.solve_s,
            "ready": ready_s,
        },
    });
    if let Some(c) = costs {
        doc["edit_s"] = serde_json::json!({
            "curve": c.curve_s,
            "point": c.point_s,
            "point_again": c.point_again_s,
            "aim": c.aim_s,
            "dimmer": c.dimmer_s,
            "move": c.move_s,
            "move_rebuilt": c.move_rebuilt,
            "aim_estimate": c.aim_estimate.estimate_s,
            "estimate_build": c.aim_estimate.build_s,
        });
        if let Some(p) = &c.aim_prepared {
            doc["edit_s"]["aim_prepare"] = serde_json::json!(p.prepare_s);
            doc["edit_s"]["aim_prepared"] = serde_json::json!(p.aim_s);
        }
        if let Some(g) = &c.grown {
            doc["edit_s"]["response_grown"] = serde_json::json!(g.grow_s);
            doc["edit_s"]["response_grown_steps"] = serde_json::json!(g.steps);
            doc["edit_s"]["curve_from_response"] = serde_json::json!(g.curve_s);
        }
        doc["aim_estimate_error"] = serde_json::json!({
            "estimated": c.aim_estimate.error,
            "unestimated": c.aim_estimate.unestimated_error,
            "estimated_of_total": c.aim_estimate.error_of_total,
            "estimated_of_total_median": c.aim_estimate.median_error_of_total,
            "unestimated_of_total": c.aim_estimate.unestimated_error_of_total,
        });
    }
    doc
}

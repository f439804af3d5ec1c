//! `haiko glare ROOM`: the CIE 117 unified glare rating at every observer, with the background
//! luminance and, per luminaire, its luminance, solid angle, position index and term
//! (docs/ROOM_FILE.md, "Glare"), from the session's design numbers. As text or, with `--json`,
//! one JSON document.

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::cli::check::overall;
use crate::cli::{load_room, open_session};
use crate::error::{Error, Result};
use crate::metrics::{ObserverGlare, SourceStatus, UgrStatus};
use crate::session::budget::MemoryLimit;

#[derive(Serialize)]
struct GlareJson<'a> {
    room: String,
    direct_only: bool,
    /// Every observer with a limit passes (`None` without limits).
    pass: Option<bool>,
    observers: &'a [ObserverGlare],
}

/// The ratings as one pretty-printed JSON document.
pub fn to_json(room: &str, direct_only: bool, observers: &[ObserverGlare]) -> Result<String> {
    let doc = GlareJson {
        room: room.to_string(),
        direct_only,
        pass: overall(observers.iter().map(|o| o.pass)),
        observers,
    };
    serde_json::to_string_pretty(&doc).map_err(|e| Error::internal(format!("glare: JSON: {e}")))
}

/// The ratings as text: per observer a heading line, then one row per luminaire.
pub(crate) fn to_text(room: &str, direct_only: bool, observers: &[ObserverGlare]) -> String {
    let mut out = format!(
        "{room}: UGR by CIE 117 (Guth position index){}\n",
        if direct_only {
            ", direct light only: no background luminance"
        } else {
            ""
        }
    );
    if observers.is_empty() {
        out.push_str("no observers\n");
    }
    for o in observers {
        let value = match (o.status, o.ugr) {
            (UgrStatus::Rated, Some(u)) => format!("UGR {u:.1}"),
            (UgrStatus::NoBackground, _) => "UGR undefined (L_b = 0)".to_string(),
            _ => "no glare source".to_string(),
        };
        let verdict = match (o.pass, o.limit) {
            (Some(true), Some(l)) => format!(" ≤ {l:.0} pass"),
            (Some(false), Some(l)) => format!(" > {l:.0} FAIL"),
            _ => String::new(),
        };
        let _ = writeln!(
            out,
            "\n{}: eye [{:.2}, {:.2}, {:.2}] m looking [{:.2}, {:.2}, {:.2}]: {value}{verdict}   L_b {:.2} cd/m² (E_ind {:.1} lx)",
            o.name,
            o.eye[0],
            o.eye[1],
            o.eye[2],
            o.view[0],
            o.view[1],
            o.view[2],
            o.background_luminance,
            o.indirect_lux
        );
        let _ = writeln!(
            out,
            "  {:<12} {:>6} {:>6} {:>6}  {:>9} {:>10} {:>11} {:>6} {:>10}  status",
            "luminaire", "R m", "H m", "T m", "I cd", "L cd/m²", "ω sr", "p", "L²ω/p²"
        );
        for s in &o.sources {
            let name: String = s.name.chars().take(12).collect();
            if s.status == SourceStatus::Counted {
                let _ = writeln!(
                    out,
                    "  {name:<12} {:>6.2} {:>6.2} {:>6.2}  {:>9.1} {:>10.0} {:>11.3e} {:>6.2} {:>10.3e}  counted{}",
                    s.r_m,
                    s.h_m,
                    s.t_m,
                    s.intensity_cd,
                    s.luminance,
                    s.solid_angle_sr,
                    s.position_index,
                    s.term,
                    if s.term > 0.0 && !s.omega_in_range {
                        " (ω outside 0.0003–0.1 sr)"
                    } else {
                        ""
                    }
                );
            } else {
                let _ = writeln!(
                    out,
                    "  {name:<12} {:>6.2} {:>6.2} {:>6.2}  {:>9} {:>10} {:>11} {:>6} {:>10}  {}",
                    s.r_m,
                    s.h_m,
                    s.t_m,
                    "–",
                    "–",
                    "–",
                    "–",
                    "–",
                    s.status.describe()
                );
            }
        }
    }
    out
}

/// Runs the command: loads the room, opens a session (the user's bake cache unless
/// `direct_only`: the background luminance needs the indirect light) and prints the ratings.
pub fn run(room: &Path, json: bool, direct_only: bool, limit: &MemoryLimit) -> Result<()> {
    let scene = load_room(room)?;
    let mut session = open_session(scene, !direct_only, limit)?;
    let observers = session.design_numbers().observers;
    let name = room.display().to_string();
    if json {
        println!("{}", to_json(&name, direct_only, &observers)?);
    } else {
        print!("{}", to_text(&name, direct_only, &observers));
    }
    Ok(())
}

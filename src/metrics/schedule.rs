//! The luminaire schedule: the room's lights grouped by type (the same photometric file or
//! inline curve, dimmer and colour), with their flux, count and positions.

use std::path::Path;

use serde::Serialize;

use crate::scene::{LidSource, Light, Scene};

/// One group of identical luminaires.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScheduleRow {
    /// The lights' names, in file order.
    pub names: Vec<String>,
    /// The photometric file as written relative to the room file, or `None` for an inline curve.
    pub file: Option<String>,
    /// Luminous flux of one luminaire at full output (lm).
    pub flux_lm: f64,
    /// The dimmer of every light in the group.
    pub dimmer: f64,
    /// Flux of one luminaire as dimmed (lm).
    pub dimmed_flux_lm: f64,
    /// Number of luminaires.
    pub count: usize,
    /// Their positions (world, m), in file order.
    pub positions: Vec<[f64; 3]>,
    /// The luminous area, described (`Ø 0.662 m`), or `None` when unknown.
    pub luminous: Option<String>,
    /// Linear RGB colour multipliers.
    pub color: [f64; 3],
}

/// The schedule of `scene`'s lights: one row per group of lights that share the photometric
/// source (file, or an equal inline curve), the dimmer and the colour, in order of first
/// appearance.
pub fn luminaire_schedule(scene: &Scene) -> Vec<ScheduleRow> {
    let room_dir = scene.path.parent().unwrap_or(Path::new(""));
    let mut rows: Vec<(usize, ScheduleRow)> = Vec::new();
    for (i, light) in scene.lights.iter().enumerate() {
        let same = |&(first, _): &(usize, ScheduleRow)| same_type(&scene.lights[first], light);
        if let Some(k) = rows.iter().position(same) {
            let row = &mut rows[k].1;
            row.names.push(light.name.clone());
            row.positions.push(light.position.to_array());
            row.count += 1;
            continue;
        }
        let flux_lm = light.curve.flux_lm();
        rows.push((
            i,
            ScheduleRow {
                names: vec![light.name.clone()],
                file: match &light.lid_source {
                    LidSource::Inline => None,
                    LidSource::File { path, .. } => {
                        Some(path.strip_prefix(room_dir).unwrap_or(path).display().to_string())
                    }
                },
                flux_lm,
                dimmer: light.dimmer,
                dimmed_flux_lm: flux_lm * light.dimmer,
                count: 1,
                positions: vec![light.position.to_array()],
                luminous: light.luminous.map(|l| l.describe()),
                color: light.color,
            },
        ));
    }
    rows.into_iter().map(|(_, row)| row).collect()
}

fn same_type(a: &Light, b: &Light) -> bool {
    let source = match (&a.lid_source, &b.lid_source) {
        (LidSource::File { path: pa, .. }, LidSource::File { path: pb, .. }) => {
            pa == pb && a.curve == b.curve
        }
        (LidSource::Inline, LidSource::Inline) => a.curve == b.curve,
        _ => false,
    };
    source && a.dimmer == b.dimmer && a.color == b.color && a.luminous == b.luminous
}

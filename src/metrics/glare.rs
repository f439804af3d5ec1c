//! Discomfort glare: the CIE 117 Unified Glare Rating at an observer (docs/ROOM_FILE.md,
//! "Glare"),
//!
//! `UGR = 8 log10( (0.25 / L_b) Σ L² ω / p² )`
//!
//! * `L_b` background luminance (cd/m²) = `E_ind / π`, with `E_ind` the indirect illuminance at
//!   the eye on the vertical plane facing the line of sight;
//! * per luminaire `L` its luminance towards the eye (cd/m²) = `I(γ) / A_p(γ)`, the intensity
//!   towards the eye over the luminous area it shows (the C-plane average of both, as Haiko's
//!   luminaires are axially symmetric);
//! * `ω = A_p / r²` the solid angle of the luminous area at the eye (sr);
//! * `p` the Guth position index, in the closed form Levin (1975) fitted to Guth's data: with
//!   `σ` the angle (°) between the line of sight and the direction to the luminaire and `τ` the
//!   angle (°) between the vertical and the plane through the line of sight and the luminaire,
//!   `ln p = σ (35.2 − 0.31889 τ − 1.22 e^(−2τ/9)) 10⁻³ + σ² (21 + 0.26667 τ − 0.002963 τ²) 10⁻⁵`.
//!
//! Limits (as in CIE 117): the line of sight is horizontal; only luminaires above the eye and in
//! front of it count, within the position-index table (`H/R ≤ 1.9`, `T/R ≤ 3`, with R the
//! distance along the line of sight, H above it, T beside it); the formula holds for
//! `3·10⁻⁴ ≤ ω ≤ 0.1` sr, and a luminaire outside that range is counted and flagged. A luminaire
//! hidden from the eye by furniture, or without a known luminous area, is left out and reported.

use glam::DVec3;
use serde::Serialize;

use crate::photometry::{Curve, LuminousShape};
use crate::scene::design::Observer;
use crate::transport::visibility::Visibility;

/// Smallest solid angle (sr) for which CIE 117 gives the formula.
pub(crate) const OMEGA_MIN_SR: f64 = 3e-4;
/// Largest solid angle (sr) for which CIE 117 gives the formula.
pub(crate) const OMEGA_MAX_SR: f64 = 0.1;
/// The position-index table's reach above the line of sight, H/R.
pub(crate) const MAX_H_OVER_R: f64 = 1.9;
/// The position-index table's reach beside the line of sight, T/R.
pub(crate) const MAX_T_OVER_R: f64 = 3.0;

/// The Guth position index of a luminaire in the unit direction `to_source` from the eye, for
/// a unit line of sight `view` and the unit `up` perpendicular to it; `None` when the
/// luminaire is not in front (`to_source · view ≤ 0`).
pub fn position_index(to_source: DVec3, view: DVec3, up: DVec3) -> Option<f64> {
    let cos_sigma = to_source.dot(view);
    if cos_sigma <= 0.0 {
        return None;
    }
    let sigma = cos_sigma.min(1.0).acos();
    let sin_sigma = sigma.sin();
    let tau = if sin_sigma > 0.0 {
        (to_source.dot(up).abs() / sin_sigma).min(1.0).acos().to_degrees()
    } else {
        0.0
    };
    let sigma = sigma.to_degrees();
    let linear = (35.2 - 0.31889 * tau - 1.22 * (-2.0 * tau / 9.0).exp()) * 1e-3;
    let quadratic = (21.0 + 0.26667 * tau - 0.002963 * tau * tau) * 1e-5;
    Some((sigma * (linear + sigma * quadratic)).exp())
}

/// `8 log10((0.25 / L_b) Σ terms)` for terms `L² ω / p²`; `None` when `L_b ≤ 0` or the sum is 0.
pub fn ugr(background_luminance: f64, terms: impl IntoIterator<Item = f64>) -> Option<f64> {
    let sum: f64 = terms.into_iter().sum();
    (background_luminance > 0.0 && sum > 0.0).then(|| 8.0 * (0.25 / background_luminance * sum).log10())
}

/// A luminaire as glare sees it.
#[derive(Debug, Clone, Copy)]
pub struct GlareSource<'a> {
    /// Name for tables.
    pub name: &'a str,
    /// Luminous centre (world, m).
    pub position: DVec3,
    /// Unit aim axis (world).
    pub aim: DVec3,
    /// Intensity curve (cd).
    pub curve: &'a Curve,
    /// Multiplies the curve: dimmer × photopic weight of the light's colour.
    pub scale: f64,
    /// The luminous area facing along the aim, if known.
    pub luminous: Option<&'a LuminousShape>,
}

/// Whether a luminaire counts in an observer's UGR, and if not, why.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SourceStatus {
    /// In the sum.
    Counted,
    /// Behind the observer (R ≤ 0).
    BehindObserver,
    /// At or below eye height (H ≤ 0): outside the CIE 117 position index.
    AtOrBelowEyeLevel,
    /// Beyond the position-index table (H/R > 1.9 or T/R > 3).
    OutsideFieldOfView,
    /// Furniture hides it from the eye.
    Hidden,
    /// Neither the photometric file nor `luminous_size` gives its luminous area.
    NoLuminousArea,
    /// It sends light towards the eye but shows no luminous area there (an opening seen from
    /// behind), so its luminance is undefined.
    NotFacing,
}

impl SourceStatus {
    /// Words for tables.
    pub(crate) fn describe(self) -> &'static str {
        match self {
            SourceStatus::Counted => "counted",
            SourceStatus::BehindObserver => "behind the observer",
            SourceStatus::AtOrBelowEyeLevel => "at or below eye level",
            SourceStatus::OutsideFieldOfView => "outside the field of view (H/R > 1.9 or T/R > 3)",
            SourceStatus::Hidden => "hidden by furniture",
            SourceStatus::NoLuminousArea => "no luminous area (give luminous_size)",
            SourceStatus::NotFacing => "luminous area turned away",
        }
    }
}

/// One luminaire seen by one observer. The photometric values are 0 unless it is counted.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SourceGlare {
    /// The light's name.
    pub name: String,
    /// Whether it counts.
    pub status: SourceStatus,
    /// Distance along the line of sight, m.
    pub r_m: f64,
    /// Height above the line of sight, m.
    pub h_m: f64,
    /// Distance beside the line of sight, m (≥ 0).
    pub t_m: f64,
    /// Intensity towards the eye (dimmed), cd.
    pub intensity_cd: f64,
    /// Luminous area shown to the eye, m².
    pub projected_area_m2: f64,
    /// Luminance towards the eye L, cd/m².
    pub luminance: f64,
    /// Solid angle ω at the eye, sr.
    pub solid_angle_sr: f64,
    /// Guth position index p.
    pub position_index: f64,
    /// `L² ω / p²`.
    pub term: f64,
    /// True when ω lies in the CIE 117 range [3·10⁻⁴, 0.1] sr.
    pub omega_in_range: bool,
}

/// Why an observer has no UGR value, or that it has one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum UgrStatus {
    /// The UGR was computed.
    Rated,
    /// No counted luminaire sends light to the eye: no discomfort glare.
    NoGlareSource,
    /// The background luminance is 0 (no reflected light reaches the eye): UGR is undefined.
    NoBackground,
}

/// The glare rating at one observer.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ObserverGlare {
    /// The observer's name.
    pub name: String,
    /// Eye (world, m).
    pub eye: [f64; 3],
    /// Unit horizontal line of sight (world).
    pub view: [f64; 3],
    /// Indirect illuminance at the eye on the plane facing the line of sight, lx.
    pub indirect_lux: f64,
    /// Background luminance L_b = E_ind / π, cd/m².
    pub background_luminance: f64,
    /// The UGR, when defined.
    pub ugr: Option<f64>,
    /// Why there is or is not a value.
    pub status: UgrStatus,
    /// The UGR limit this observer is judged by.
    pub limit: Option<f64>,
    /// `ugr ≤ limit` (a position without glare source passes); `None` without a limit or
    /// without a defined UGR.
    pub pass: Option<bool>,
    /// Every luminaire, counted or not.
    pub sources: Vec<SourceGlare>,
}

/// The glare rating at `observer` from `sources`, with the indirect illuminance at the eye
/// `indirect_lux` (lx), furniture in `occluders` (`None` = nothing can hide a luminaire) and the
/// UGR `limit` to judge by.
pub fn observer_glare(
    observer: &Observer,
    sources: &[GlareSource],
    indirect_lux: f64,
    occluders: Option<&dyn Visibility>,
    limit: Option<f64>,
) -> ObserverGlare {
    let sources: Vec<SourceGlare> = sources
        .iter()
        .map(|s| source_glare(observer, s, occluders))
        .collect();
    let background_luminance = indirect_lux.max(0.0) / std::f64::consts::PI;
    let counted = || sources.iter().filter(|s| s.status == SourceStatus::Counted);
    let lit = counted().any(|s| s.term > 0.0);
    let (ugr_value, status) = if !lit {
        (None, UgrStatus::NoGlareSource)
    } else if background_luminance <= 0.0 {
        (None, UgrStatus::NoBackground)
    } else {
        (
            ugr(background_luminance, counted().map(|s| s.term)),
            UgrStatus::Rated,
        )
    };
    let pass = match (status, limit) {
        (_, None) | (UgrStatus::NoBackground, _) => None,
        (UgrStatus::NoGlareSource, Some(_)) => Some(true),
        (UgrStatus::Rated, Some(l)) => ugr_value.map(|u| u <= l),
    };
    ObserverGlare {
        name: observer.name.clone(),
        eye: observer.eye.to_array(),
        view: observer.view.to_array(),
        indirect_lux,
        background_luminance,
        ugr: ugr_value,
        status,
        limit,
        pass,
        sources,
    }
}

/// One luminaire at one observer.
fn source_glare(
    observer: &Observer,
    source: &GlareSource,
    occluders: Option<&dyn Visibility>,
) -> SourceGlare {
    let view = observer.view;
    let side = view.cross(DVec3::Z);
    let d = source.position - observer.eye;
    let (r_m, h_m, t_m) = (d.dot(view), d.z, d.dot(side).abs());
    let mut out = SourceGlare {
        name: source.name.to_string(),
        status: SourceStatus::Counted,
        r_m,
        h_m,
        t_m,
        intensity_cd: 0.0,
        projected_area_m2: 0.0,
        luminance: 0.0,
        solid_angle_sr: 0.0,
        position_index: 0.0,
        term: 0.0,
        omega_in_range: false,
    };
    let status = if r_m <= 0.0 {
        Some(SourceStatus::BehindObserver)
    } else if h_m <= 0.0 {
        Some(SourceStatus::AtOrBelowEyeLevel)
    } else if h_m / r_m > MAX_H_OVER_R || t_m / r_m > MAX_T_OVER_R {
        Some(SourceStatus::OutsideFieldOfView)
    } else if occluders.is_some_and(|o| !o.visible(observer.eye, source.position)) {
        Some(SourceStatus::Hidden)
    } else if source.luminous.is_none() {
        Some(SourceStatus::NoLuminousArea)
    } else {
        None
    };
    if let Some(status) = status {
        out.status = status;
        return out;
    }
    let (Some(shape), Some(p)) = (source.luminous, position_index(d.normalize(), view, DVec3::Z)) else {
        unreachable!("checked above: a luminous area, and R > 0")
    };
    let distance = d.length();
    let to_eye = -d / distance;
    let gamma = source.aim.dot(to_eye).clamp(-1.0, 1.0).acos();
    let intensity = source.scale * source.curve.eval_rad(gamma);
    let area = shape.mean_projected_area_m2(gamma);
    out.intensity_cd = intensity;
    out.position_index = p;
    if area <= 0.0 {
        if intensity > 0.0 {
            out.status = SourceStatus::NotFacing;
        }
        return out;
    }
    out.projected_area_m2 = area;
    out.luminance = intensity / area;
    out.solid_angle_sr = area / (distance * distance);
    out.term = out.luminance * out.luminance * out.solid_angle_sr / (p * p);
    out.omega_in_range = (OMEGA_MIN_SR..=OMEGA_MAX_SR).contains(&out.solid_angle_sr);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::visibility::Unoccluded;

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * b.abs()
    }

    #[test]
    fn position_index_by_hand() {
        // Straight ahead: σ = 0 → p = 1.
        assert_eq!(position_index(DVec3::Y, DVec3::Y, DVec3::Z), Some(1.0));
        // H/R = 0.5, T = 0: σ = atan 0.5 = 26.5651°, τ = 0:
        // ln p = 26.5651 · (35.2 − 1.22) · 10⁻³ + 26.5651² · 21 · 10⁻⁵ = 0.902682 + 0.148199
        // = 1.050881 → p = 2.8601.
        let p = position_index(DVec3::new(0.0, 1.0, 0.5).normalize(), DVec3::Y, DVec3::Z).unwrap();
        assert!(close(p, 2.8601, 1e-4), "{p}");
        // Beside the line of sight at eye level (H = 0, T/R = 1): σ = 45°, τ = 90°:
        // ln p = 45 · (35.2 − 28.7001 − 1.22 e⁻²⁰) · 10⁻³ + 45² · (21 + 24.0003 − 24.0003) · 10⁻⁵
        // = 0.292495 + 0.425250 = 0.717745 → p = 2.0498.
        let p = position_index(DVec3::new(1.0, 1.0, 0.0).normalize(), DVec3::Y, DVec3::Z).unwrap();
        assert!(close(p, 2.0498, 1e-4), "{p}");
        // Left and right mirror; behind has none.
        let left = position_index(DVec3::new(-0.3, 1.0, 0.4).normalize(), DVec3::Y, DVec3::Z);
        let right = position_index(DVec3::new(0.3, 1.0, 0.4).normalize(), DVec3::Y, DVec3::Z);
        assert!(close(left.unwrap(), right.unwrap(), 1e-14));
        assert_eq!(position_index(DVec3::NEG_Y, DVec3::Y, DVec3::Z), None);
    }

    /// A hand-computed CIE 117 example: a seated observer (eye 1.2 m) looking along +y at two
    /// 0.6 × 0.6 m flat panels 3.0 m high, 3 m ahead, one on the line of sight and one 1.5 m to
    /// the side, each with a uniform 500 cd below the horizontal; indirect illuminance at the
    /// eye 100 lx.
    #[test]
    fn ugr_of_two_panels_by_hand() {
        let curve = Curve::new(&[(0.0, 500.0), (90.0, 500.0)]).unwrap();
        let panel = LuminousShape::Rectangle {
            length_m: 0.6,
            width_m: 0.6,
            side_heights_m: [0.0; 4],
        };
        let source = |name, x| GlareSource {
            name,
            position: DVec3::new(x, 3.0, 3.0),
            aim: DVec3::NEG_Z,
            curve: &curve,
            scale: 1.0,
            luminous: Some(&panel),
        };
        let observer = Observer {
            name: "seat".into(),
            eye: DVec3::new(0.0, 0.0, 1.2),
            view: DVec3::Y,
            ugr_limit: None,
        };
        let g = observer_glare(
            &observer,
            &[source("ahead", 0.0), source("side", 1.5)],
            100.0,
            None,
            Some(19.0),
        );

        // L_b = 100 / π = 31.8310 cd/m².
        assert!(close(g.background_luminance, 31.8310, 1e-5));
        // Panel "ahead": R = 3, H = 1.8, T = 0; r = √(9 + 3.24) = 3.498571 m.
        //   γ at the luminaire: cos γ = 1.8 / 3.498571 = 0.514496; I = 500 cd.
        //   A_p = 0.36 · 0.514496 = 0.185219 m²; L = 500 / 0.185219 = 2699.51 cd/m².
        //   ω = 0.185219 / 12.24 = 0.0151323 sr.
        //   σ = atan(1.8 / 3) = 30.9638°, τ = 0:
        //   ln p = 30.9638 · 0.03398 + 30.9638² · 21·10⁻⁵ = 1.052149 + 0.201338 = 1.253487,
        //   p = 3.502534.
        //   L² ω / p² = 2699.51² · 0.0151322 / 3.502534² = 110274.3 / 12.26775 = 8988.96.
        let a = &g.sources[0];
        assert_eq!(a.status, SourceStatus::Counted);
        assert!(close(a.projected_area_m2, 0.185219, 1e-5));
        assert!(close(a.luminance, 2699.51, 1e-5));
        assert!(close(a.solid_angle_sr, 0.0151323, 1e-5));
        assert!(close(a.position_index, 3.502534, 1e-6));
        assert!(close(a.term, 8988.96, 1e-5));
        assert!(a.omega_in_range);
        // Panel "side": R = 3, H = 1.8, T = 1.5; r = √(2.25 + 9 + 3.24) = 3.806573 m.
        //   cos γ = 1.8 / 3.806573 = 0.472866; A_p = 0.36 · 0.472866 = 0.170232 m²;
        //   L = 500 / 0.170232 = 2937.17 cd/m²; ω = 0.170232 / 14.49 = 0.0117482 sr.
        //   σ = acos(3 / 3.806573) = 37.9907°, τ = atan(1.5 / 1.8) = 39.8056°:
        //   ln p = 37.9907 · (35.2 − 12.69360 − 1.22 e^(−8.84568)) · 10⁻³
        //        + 37.9907² · (21 + 10.61495 − 4.69482) · 10⁻⁵
        //        = 37.9907 · 0.0225062 + 1443.29 · 0.000269201 = 0.855028 + 0.388537 = 1.243565,
        //   p = 3.467954.
        //   L² ω / p² = 2937.17² · 0.0117482 / 3.467954² = 101351.6 / 12.02670 = 8427.22.
        let b = &g.sources[1];
        assert!(close(b.luminance, 2937.17, 1e-5));
        assert!(close(b.solid_angle_sr, 0.0117482, 1e-5));
        assert!(close(b.position_index, 3.467954, 1e-6));
        assert!(close(b.term, 8427.22, 1e-5));
        // UGR = 8 log10(0.25 / 31.8310 · (8988.96 + 8427.22)) = 8 log10(136.786) = 8 · 2.136043
        //     = 17.0883.
        let u = g.ugr.unwrap();
        assert!((u - 17.0883).abs() < 1e-4, "{u}");
        assert_eq!((g.status, g.pass), (UgrStatus::Rated, Some(true)));
        // The reported components give the same UGR (what `haiko glare --json` prints).
        let again = 8.0
            * (0.25 / g.background_luminance
                * g.sources
                    .iter()
                    .map(|s| {
                        s.luminance * s.luminance * s.solid_angle_sr / (s.position_index * s.position_index)
                    })
                    .sum::<f64>())
            .log10();
        assert!((again - u).abs() < 1e-9);
    }

    #[test]
    fn doubling_every_light_and_the_background_raises_ugr_by_8_log10_2() {
        // L² ω scales with the square of the light, L_b linearly: ΔUGR = 8 log10 2 = 2.408.
        let curve = Curve::new(&[(0.0, 800.0), (90.0, 0.0)]).unwrap();
        let disc = LuminousShape::Ellipse {
            length_m: 0.3,
            width_m: 0.3,
            side_height_m: 0.0,
        };
        let at = |scale| GlareSource {
            name: "d",
            position: DVec3::new(0.5, 4.0, 2.8),
            aim: DVec3::NEG_Z,
            curve: &curve,
            scale,
            luminous: Some(&disc),
        };
        let o = Observer {
            name: "o".into(),
            eye: DVec3::new(0.0, 0.0, 1.2),
            view: DVec3::Y,
            ugr_limit: None,
        };
        let one = observer_glare(&o, &[at(1.0)], 50.0, None, None).ugr.unwrap();
        let two = observer_glare(&o, &[at(2.0)], 100.0, None, None).ugr.unwrap();
        assert!((two - one - 8.0 * 2f64.log10()).abs() < 1e-12);
    }

    #[test]
    fn luminaires_that_do_not_count_say_why() {
        let curve = Curve::new(&[(0.0, 500.0), (90.0, 500.0)]).unwrap();
        let panel = LuminousShape::Rectangle {
            length_m: 0.6,
            width_m: 0.6,
            side_heights_m: [0.0; 4],
        };
        let o = Observer {
            name: "o".into(),
            eye: DVec3::new(2.0, 0.0, 1.2),
            view: DVec3::Y,
            ugr_limit: None,
        };
        let src = |name, position, luminous| GlareSource {
            name,
            position,
            aim: DVec3::NEG_Z,
            curve: &curve,
            scale: 1.0,
            luminous,
        };
        struct Wall;
        impl Visibility for Wall {
            fn visible(&self, _: DVec3, to: DVec3) -> bool {
                to.x < 5.0
            }
        }
        let sources = [
            src("behind", DVec3::new(2.0, -1.0, 2.8), Some(&panel)),
            src("low", DVec3::new(2.0, 3.0, 1.0), Some(&panel)),
            src("overhead", DVec3::new(2.0, 0.5, 2.8), Some(&panel)),
            src("hidden", DVec3::new(6.0, 3.0, 2.8), Some(&panel)),
            src("bare", DVec3::new(2.0, 3.0, 2.8), None),
        ];
        let g = observer_glare(&o, &sources, 100.0, Some(&Wall), Some(19.0));
        let statuses: Vec<SourceStatus> = g.sources.iter().map(|s| s.status).collect();
        assert_eq!(
            statuses,
            vec![
                SourceStatus::BehindObserver,
                SourceStatus::AtOrBelowEyeLevel,
                SourceStatus::OutsideFieldOfView, // H/R = 1.6 / 0.5 = 3.2 > 1.9
                SourceStatus::Hidden,
                SourceStatus::NoLuminousArea,
            ]
        );
        // Nothing counted: no glare source, which passes any limit.
        assert_eq!(
            (g.ugr, g.status, g.pass),
            (None, UgrStatus::NoGlareSource, Some(true))
        );
        // A counted panel without reflected light: UGR undefined.
        let lit = [src("ahead", DVec3::new(2.0, 3.0, 2.8), Some(&panel))];
        let dark = observer_glare(&o, &lit, 0.0, Some(&Unoccluded), Some(19.0));
        assert_eq!(
            (dark.ugr, dark.status, dark.pass),
            (None, UgrStatus::NoBackground, None)
        );
    }
}

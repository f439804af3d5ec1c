//! Luminous areas: the shape of a luminaire's light-emitting part, as the IES LM-63-2019
//! luminous-opening shapes (width, length, height with signs) and the EULUMDAT luminous area
//! (fields 16–21) describe it, and the area it shows from a direction. Glare ratings need it for
//! the luminance `L = I / A_p` (docs/ROOM_FILE.md, "Glare").
//!
//! Local frame of a luminaire: x along the C0 plane (the photometric horizontal), y along C90,
//! z along the aim axis (γ = 0). The direction from the luminaire towards a viewer is
//! `u = (sinγ cosC, sinγ sinC, cosγ)`. Lengths are metres. A face counts from both sides only
//! where the file says so (a vertical disc); an opening that faces along the aim is seen only
//! from the aim's side (`u_z > 0`).

use glam::DVec3;

/// One of the two horizontal axes of the local frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HorizontalAxis {
    /// Along the C0–C180 plane (local x).
    C0,
    /// Along the C90–C270 plane (local y).
    C90,
}

/// The luminous part of a luminaire (metres, local frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LuminousShape {
    /// A rectangular opening `length × width` facing along the aim, with luminous sides of the
    /// given heights on the C0, C90, C180 and C270 sides (0 for a flat opening). LM-63 width > 0,
    /// length > 0, height ≥ 0; EULUMDAT luminous width > 0.
    Rectangle {
        /// Along C0–C180 (x), m.
        length_m: f64,
        /// Along C90–C270 (y), m.
        width_m: f64,
        /// Heights of the luminous sides facing C0, C90, C180, C270, m.
        side_heights_m: [f64; 4],
    },
    /// An elliptical opening (circular when both diameters agree) facing along the aim, with a
    /// luminous side of `side_height_m` (a vertical cylinder; 0 for a flat disc). LM-63 width
    /// < 0, length < 0, height ≥ 0; EULUMDAT luminous width 0.
    Ellipse {
        /// Diameter along C0–C180 (x), m.
        length_m: f64,
        /// Diameter along C90–C270 (y), m.
        width_m: f64,
        /// Height of the luminous side, m.
        side_height_m: f64,
    },
    /// A sphere or ellipsoid (LM-63: all three negative). Diameters along x, y and z.
    Ellipsoid {
        /// Diameter along C0–C180 (x), m.
        length_m: f64,
        /// Diameter along C90–C270 (y), m.
        width_m: f64,
        /// Diameter along the aim axis (z), m.
        height_m: f64,
    },
    /// A horizontal (elliptical) cylinder, luminous all round and at its ends. LM-63 width < 0,
    /// length > 0, height < 0 (axis along C0) or width > 0, length < 0, height < 0 (along C90).
    HorizontalCylinder {
        /// The axis the cylinder lies along.
        axis: HorizontalAxis,
        /// Length along the axis, m.
        length_m: f64,
        /// Horizontal diameter across the axis, m.
        across_m: f64,
        /// Vertical diameter (along z), m.
        height_m: f64,
    },
    /// A vertical (elliptical) disc facing the given horizontal axis, luminous on both faces.
    /// LM-63 width < 0, length 0, height < 0 (facing C0) or width 0, length < 0, height < 0
    /// (facing C90).
    VerticalEllipse {
        /// The axis the disc's normal lies along.
        facing: HorizontalAxis,
        /// Horizontal diameter, m.
        across_m: f64,
        /// Vertical diameter, m.
        height_m: f64,
    },
}

/// The largest luminous dimension (length, width, height, diameter) Haiko accepts, metres: larger
/// than any luminaire, and small enough that projected areas and glare terms stay finite
/// (docs/DECISIONS.md, "Bad input").
pub(crate) const MAX_LUMINOUS_SIZE_M: f64 = 100.0;

/// C-planes sampled when averaging a projected area over C (midpoints of 0.5° intervals, so the
/// kinks of `|cos C|` at 90° and 270° fall on interval ends).
const C_SAMPLES: usize = 720;

impl LuminousShape {
    /// The shape an IES LM-63 file's `width length height` describe (LM-63-2019 Table 1), in
    /// metres (`to_m` converts the file's unit). `Ok(None)` for a point source (all zero);
    /// `Err` with a description for a sign pattern the table does not have.
    pub(crate) fn from_ies(width: f64, length: f64, height: f64, to_m: f64) -> Result<Option<Self>, String> {
        use std::cmp::Ordering::{Equal, Greater, Less};
        let sign = |v: f64| v.partial_cmp(&0.0).unwrap_or(Equal);
        let (w, l, h) = (width.abs() * to_m, length.abs() * to_m, height.abs() * to_m);
        let shape = match (sign(width), sign(length), sign(height)) {
            (Equal, Equal, Equal) => return Ok(None),
            (Greater, Greater, Equal | Greater) => LuminousShape::Rectangle {
                length_m: l,
                width_m: w,
                side_heights_m: [h; 4],
            },
            (Less, Less, Equal | Greater) => LuminousShape::Ellipse {
                length_m: l,
                width_m: w,
                side_height_m: h,
            },
            (Less, Less, Less) => LuminousShape::Ellipsoid {
                length_m: l,
                width_m: w,
                height_m: h,
            },
            (Less, Greater, Less) => LuminousShape::HorizontalCylinder {
                axis: HorizontalAxis::C0,
                length_m: l,
                across_m: w,
                height_m: h,
            },
            (Greater, Less, Less) => LuminousShape::HorizontalCylinder {
                axis: HorizontalAxis::C90,
                length_m: w,
                across_m: l,
                height_m: h,
            },
            (Less, Equal, Less) => LuminousShape::VerticalEllipse {
                facing: HorizontalAxis::C0,
                across_m: w,
                height_m: h,
            },
            (Equal, Less, Less) => LuminousShape::VerticalEllipse {
                facing: HorizontalAxis::C90,
                across_m: l,
                height_m: h,
            },
            _ => {
                return Err(format!(
                    "the luminous dimensions width {width}, length {length}, height {height} match no \
                     LM-63 luminous-opening shape"
                ));
            }
        };
        Ok(Some(shape))
    }

    /// The IES LM-63 `width length height` (m) that [`Self::from_ies`] reads back as this
    /// shape; `None` for a rectangle whose sides have different heights (LM-63 has one height).
    pub fn to_ies(&self) -> Option<[f64; 3]> {
        Some(match *self {
            LuminousShape::Rectangle {
                length_m,
                width_m,
                side_heights_m: [h, h1, h2, h3],
            } => {
                if [h1, h2, h3] != [h; 3] {
                    return None;
                }
                [width_m, length_m, h]
            }
            LuminousShape::Ellipse {
                length_m,
                width_m,
                side_height_m,
            } => [-width_m, -length_m, side_height_m],
            LuminousShape::Ellipsoid {
                length_m,
                width_m,
                height_m,
            } => [-width_m, -length_m, -height_m],
            LuminousShape::HorizontalCylinder {
                axis: HorizontalAxis::C0,
                length_m,
                across_m,
                height_m,
            } => [-across_m, length_m, -height_m],
            LuminousShape::HorizontalCylinder {
                axis: HorizontalAxis::C90,
                length_m,
                across_m,
                height_m,
            } => [length_m, -across_m, -height_m],
            LuminousShape::VerticalEllipse {
                facing: HorizontalAxis::C0,
                across_m,
                height_m,
            } => [-across_m, 0.0, -height_m],
            LuminousShape::VerticalEllipse {
                facing: HorizontalAxis::C90,
                across_m,
                height_m,
            } => [0.0, -across_m, -height_m],
        })
    }

    /// The shape a EULUMDAT file's luminous area describes (fields 16–21, millimetres): length
    /// (or diameter) and width (0 = circular), and the luminous heights on the C0, C90, C180 and
    /// C270 sides. `None` when the length is 0 (no luminous area given). A circular area with
    /// luminous sides uses the mean of the four heights.
    pub(crate) fn from_eulumdat(length_mm: f64, width_mm: f64, heights_mm: [f64; 4]) -> Option<Self> {
        let mm = 1e-3;
        if length_mm <= 0.0 {
            return None;
        }
        let heights = heights_mm.map(|h| h * mm);
        Some(if width_mm > 0.0 {
            LuminousShape::Rectangle {
                length_m: length_mm * mm,
                width_m: width_mm * mm,
                side_heights_m: heights,
            }
        } else {
            LuminousShape::Ellipse {
                length_m: length_mm * mm,
                width_m: length_mm * mm,
                side_height_m: heights.iter().sum::<f64>() / 4.0,
            }
        })
    }

    /// Area (m²) the luminous part shows to a viewer in the unit local direction `u` (from the
    /// luminaire towards the viewer; x = C0, y = C90, z = aim axis).
    pub fn projected_area_m2(&self, u: DVec3) -> f64 {
        use std::f64::consts::FRAC_PI_4;
        match *self {
            LuminousShape::Rectangle {
                length_m,
                width_m,
                side_heights_m: [h0, h90, h180, h270],
            } => {
                length_m * width_m * u.z.max(0.0)
                    + width_m * (h0 * u.x.max(0.0) + h180 * (-u.x).max(0.0))
                    + length_m * (h90 * u.y.max(0.0) + h270 * (-u.y).max(0.0))
            }
            LuminousShape::Ellipse {
                length_m,
                width_m,
                side_height_m,
            } => {
                // The side's silhouette is as wide as the ellipse across the horizontal part of u.
                let across = ((length_m * u.y).powi(2) + (width_m * u.x).powi(2)).sqrt();
                FRAC_PI_4 * length_m * width_m * u.z.max(0.0) + side_height_m * across
            }
            LuminousShape::Ellipsoid {
                length_m,
                width_m,
                height_m,
            } => {
                FRAC_PI_4
                    * ((width_m * height_m * u.x).powi(2)
                        + (length_m * height_m * u.y).powi(2)
                        + (length_m * width_m * u.z).powi(2))
                    .sqrt()
            }
            LuminousShape::HorizontalCylinder {
                axis,
                length_m,
                across_m,
                height_m,
            } => {
                let (along, side) = match axis {
                    HorizontalAxis::C0 => (u.x, u.y),
                    HorizontalAxis::C90 => (u.y, u.x),
                };
                let silhouette = ((across_m * u.z).powi(2) + (height_m * side).powi(2)).sqrt();
                length_m * silhouette + FRAC_PI_4 * across_m * height_m * along.abs()
            }
            LuminousShape::VerticalEllipse {
                facing,
                across_m,
                height_m,
            } => {
                let normal = match facing {
                    HorizontalAxis::C0 => u.x,
                    HorizontalAxis::C90 => u.y,
                };
                FRAC_PI_4 * across_m * height_m * normal.abs()
            }
        }
    }

    /// The projected area (m²) at γ (radians from the aim axis) averaged over all C-planes.
    /// Haiko's luminaires are axially symmetric (the curve is the C-plane average and no C0
    /// direction is placed in the room), so the luminance `I(γ) / A_p(γ)` uses this average.
    pub(crate) fn mean_projected_area_m2(&self, gamma_rad: f64) -> f64 {
        let (sin_g, cos_g) = gamma_rad.sin_cos();
        let step = std::f64::consts::TAU / C_SAMPLES as f64;
        let sum: f64 = (0..C_SAMPLES)
            .map(|k| {
                let (sin_c, cos_c) = ((k as f64 + 0.5) * step).sin_cos();
                self.projected_area_m2(DVec3::new(sin_g * cos_c, sin_g * sin_c, cos_g))
            })
            .sum();
        sum / C_SAMPLES as f64
    }

    /// A short description for tables: `0.60 × 0.60 m`, `Ø 0.66 m`, …
    pub(crate) fn describe(&self) -> String {
        match *self {
            LuminousShape::Rectangle {
                length_m,
                width_m,
                side_heights_m,
            } => {
                let sides = side_heights_m.iter().copied().fold(0.0, f64::max);
                if sides > 0.0 {
                    format!("{length_m:.3} × {width_m:.3} m, sides up to {sides:.3} m")
                } else {
                    format!("{length_m:.3} × {width_m:.3} m")
                }
            }
            LuminousShape::Ellipse {
                length_m,
                width_m,
                side_height_m,
            } => {
                let face = if length_m == width_m {
                    format!("Ø {length_m:.3} m")
                } else {
                    format!("ellipse {length_m:.3} × {width_m:.3} m")
                };
                if side_height_m > 0.0 {
                    format!("{face}, side {side_height_m:.3} m")
                } else {
                    face
                }
            }
            LuminousShape::Ellipsoid {
                length_m,
                width_m,
                height_m,
            } => format!("ellipsoid {length_m:.3} × {width_m:.3} × {height_m:.3} m"),
            LuminousShape::HorizontalCylinder {
                length_m,
                across_m,
                height_m,
                ..
            } => format!("horizontal cylinder {length_m:.3} m, {across_m:.3} × {height_m:.3} m"),
            LuminousShape::VerticalEllipse {
                across_m, height_m, ..
            } => format!("vertical disc {across_m:.3} × {height_m:.3} m"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1e-12)
    }

    /// Every shape LM-63 can describe is written as dimensions that read back as itself; a
    /// rectangle with unequal side heights has no LM-63 form.
    #[test]
    fn ies_dimensions_read_back_as_the_shape() {
        let shapes = [
            LuminousShape::Rectangle {
                length_m: 1.2,
                width_m: 0.3,
                side_heights_m: [0.05; 4],
            },
            LuminousShape::Ellipse {
                length_m: 0.662,
                width_m: 0.662,
                side_height_m: 0.0,
            },
            LuminousShape::Ellipsoid {
                length_m: 0.3,
                width_m: 0.2,
                height_m: 0.1,
            },
            LuminousShape::HorizontalCylinder {
                axis: HorizontalAxis::C0,
                length_m: 1.5,
                across_m: 0.05,
                height_m: 0.06,
            },
            LuminousShape::HorizontalCylinder {
                axis: HorizontalAxis::C90,
                length_m: 1.5,
                across_m: 0.05,
                height_m: 0.06,
            },
            LuminousShape::VerticalEllipse {
                facing: HorizontalAxis::C0,
                across_m: 0.4,
                height_m: 0.3,
            },
            LuminousShape::VerticalEllipse {
                facing: HorizontalAxis::C90,
                across_m: 0.4,
                height_m: 0.3,
            },
        ];
        for shape in shapes {
            let [w, l, h] = shape.to_ies().unwrap();
            assert_eq!(
                LuminousShape::from_ies(w, l, h, 1.0),
                Ok(Some(shape)),
                "{shape:?}"
            );
        }
        let uneven = LuminousShape::Rectangle {
            length_m: 1.0,
            width_m: 0.5,
            side_heights_m: [0.1, 0.0, 0.1, 0.0],
        };
        assert_eq!(uneven.to_ies(), None);
    }

    #[test]
    fn ies_sign_patterns_follow_lm63_table_1() {
        let ft = 0.3048;
        assert_eq!(LuminousShape::from_ies(0.0, 0.0, 0.0, 1.0), Ok(None));
        assert_eq!(
            LuminousShape::from_ies(2.0, 4.0, 0.0, ft),
            Ok(Some(LuminousShape::Rectangle {
                length_m: 4.0 * ft,
                width_m: 2.0 * ft,
                side_heights_m: [0.0; 4]
            }))
        );
        assert_eq!(
            LuminousShape::from_ies(-0.2, -0.2, 0.1, 1.0),
            Ok(Some(LuminousShape::Ellipse {
                length_m: 0.2,
                width_m: 0.2,
                side_height_m: 0.1
            }))
        );
        assert_eq!(
            LuminousShape::from_ies(-0.3, -0.3, -0.3, 1.0),
            Ok(Some(LuminousShape::Ellipsoid {
                length_m: 0.3,
                width_m: 0.3,
                height_m: 0.3
            }))
        );
        assert_eq!(
            LuminousShape::from_ies(-0.05, 1.2, -0.05, 1.0),
            Ok(Some(LuminousShape::HorizontalCylinder {
                axis: HorizontalAxis::C0,
                length_m: 1.2,
                across_m: 0.05,
                height_m: 0.05
            }))
        );
        assert_eq!(
            LuminousShape::from_ies(1.2, -0.05, -0.05, 1.0),
            Ok(Some(LuminousShape::HorizontalCylinder {
                axis: HorizontalAxis::C90,
                length_m: 1.2,
                across_m: 0.05,
                height_m: 0.05
            }))
        );
        assert_eq!(
            LuminousShape::from_ies(0.0, -0.2, -0.1, 1.0),
            Ok(Some(LuminousShape::VerticalEllipse {
                facing: HorizontalAxis::C90,
                across_m: 0.2,
                height_m: 0.1
            }))
        );
        let err = LuminousShape::from_ies(1.0, 0.0, 0.0, 1.0).unwrap_err();
        assert!(err.contains("width 1, length 0, height 0"), "{err}");
    }

    #[test]
    fn eulumdat_area_is_a_rectangle_or_a_disc() {
        assert_eq!(
            LuminousShape::from_eulumdat(662.0, 0.0, [0.0; 4]),
            Some(LuminousShape::Ellipse {
                length_m: 0.662,
                width_m: 0.662,
                side_height_m: 0.0
            })
        );
        assert_eq!(
            LuminousShape::from_eulumdat(1480.0, 63.0, [10.0, 20.0, 10.0, 20.0]),
            Some(LuminousShape::Rectangle {
                length_m: 1.48,
                width_m: 0.063,
                side_heights_m: [0.01, 0.02, 0.01, 0.02]
            })
        );
        assert_eq!(LuminousShape::from_eulumdat(0.0, 0.0, [0.0; 4]), None);
    }

    #[test]
    fn flat_opening_shows_area_times_cos_gamma() {
        // A 0.6 × 0.3 m flat panel at γ = 60°: 0.18 m² × cos 60° = 0.09 m², in every C-plane.
        let panel = LuminousShape::Rectangle {
            length_m: 0.6,
            width_m: 0.3,
            side_heights_m: [0.0; 4],
        };
        assert!(close(panel.mean_projected_area_m2(PI / 3.0), 0.09, 1e-12));
        // Seen from behind (γ > 90°) the opening is hidden.
        assert_eq!(panel.mean_projected_area_m2(2.0), 0.0);
        // A disc Ø 0.662 m straight below: π/4 · 0.662² = 0.344196 m².
        let disc = LuminousShape::Ellipse {
            length_m: 0.662,
            width_m: 0.662,
            side_height_m: 0.0,
        };
        assert!(close(
            disc.mean_projected_area_m2(0.0),
            FRAC_PI_4 * 0.662 * 0.662,
            1e-12
        ));
    }

    #[test]
    fn luminous_sides_average_over_c_to_two_over_pi() {
        // Box 0.6 × 0.3 m with 0.1 m luminous sides at γ = 90°: the sides show
        // H (W |cos C| + L |sin C|), whose mean over C is (2/π) H (W + L) = (2/π) 0.1 · 0.9.
        let boxy = LuminousShape::Rectangle {
            length_m: 0.6,
            width_m: 0.3,
            side_heights_m: [0.1; 4],
        };
        let expected = 2.0 / PI * 0.1 * 0.9;
        assert!(close(boxy.mean_projected_area_m2(FRAC_PI_2), expected, 1e-5));
        // A vertical cylinder Ø 0.2 m, side 0.1 m, at γ = 90°: D · H = 0.02 m² in every plane.
        let can = LuminousShape::Ellipse {
            length_m: 0.2,
            width_m: 0.2,
            side_height_m: 0.1,
        };
        assert!(close(can.mean_projected_area_m2(FRAC_PI_2), 0.02, 1e-9));
    }

    #[test]
    fn sphere_shows_its_disc_everywhere_and_cylinder_its_silhouette() {
        let ball = LuminousShape::Ellipsoid {
            length_m: 0.3,
            width_m: 0.3,
            height_m: 0.3,
        };
        for g in [0.0, 0.7, 2.5] {
            assert!(close(ball.mean_projected_area_m2(g), FRAC_PI_4 * 0.09, 1e-12));
        }
        // Tube 1.2 m × Ø 0.05 m along C0, seen straight from below: 1.2 · 0.05 = 0.06 m²;
        // seen along its axis (u = x): the end disc π/4 · 0.05².
        let tube = LuminousShape::HorizontalCylinder {
            axis: HorizontalAxis::C0,
            length_m: 1.2,
            across_m: 0.05,
            height_m: 0.05,
        };
        assert!(close(tube.projected_area_m2(DVec3::Z), 0.06, 1e-12));
        assert!(close(tube.projected_area_m2(DVec3::X), FRAC_PI_4 * 0.0025, 1e-12));
    }
}

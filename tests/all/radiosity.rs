//! Form factors, the certified interreflection solve and coarse → fine interpolation, against
//! closed forms (docs/METHOD.md §8), conservation (closed-room row sums, the furnace) and a dense
//! direct solve.

use std::f64::consts::PI;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use haiko::Error;
use haiko::scene::{Patch, PatchMesh};
use haiko::transport::formfactor::{
    FormFactorBuilder, FormFactorOptions, FormFactors, TargetPatch, differential, point_to_polygon,
};
use haiko::transport::interpolate::{InterpolationWeights, interpolate};
use haiko::transport::radiosity::{PatchColumns, SolveOptions, Transfer, solve, solve_from};
use haiko::transport::visibility::{Unoccluded, Visibility};

// ---------------------------------------------------------------- helpers

/// Surface indices of [`box_room`].
const FLOOR: u32 = 0;
const WALL_X0: u32 = 2;

/// An axis-aligned box room (0,0,0)–`size` meshed into quads facing inwards, `divisions` cells
/// along x, y, z. Grid lines sit at `L·(k/d)^stretch` (stretch 1 = uniform). Vertices are
/// per surface (floor, ceiling, wall-x0, wall-x1, wall-y0, wall-y1 = surfaces 0..6).
fn box_room(size: DVec3, divisions: [usize; 3], stretch: f64) -> PatchMesh {
    let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
    // (origin, u axis, v axis, divisions along u, v); u × v is the inward normal.
    let faces = [
        (DVec3::ZERO, x * size.x, y * size.y, divisions[0], divisions[1]),
        (z * size.z, y * size.y, x * size.x, divisions[1], divisions[0]),
        (DVec3::ZERO, y * size.y, z * size.z, divisions[1], divisions[2]),
        (x * size.x, z * size.z, y * size.y, divisions[2], divisions[1]),
        (DVec3::ZERO, z * size.z, x * size.x, divisions[2], divisions[0]),
        (y * size.y, x * size.x, z * size.z, divisions[0], divisions[2]),
    ];
    let mut mesh = PatchMesh::default();
    for (surface, &(origin, u, v, du, dv)) in faces.iter().enumerate() {
        let normal = u.cross(v).normalize();
        let base = mesh.positions.len() as u32;
        let t = |k: usize, d: usize| (k as f64 / d as f64).powf(stretch);
        for b in 0..=dv {
            for a in 0..=du {
                mesh.positions.push(origin + u * t(a, du) + v * t(b, dv));
                mesh.normals.push(normal);
                mesh.vertex_surface.push(surface as u32);
            }
        }
        for b in 0..dv {
            for a in 0..du {
                let id = |a: usize, b: usize| base + (b * (du + 1) + a) as u32;
                let vertices = [id(a, b), id(a + 1, b), id(a + 1, b + 1), id(a, b + 1)];
                let corners = vertices.map(|i| mesh.positions[i as usize]);
                let edge_u = corners[1] - corners[0];
                let edge_v = corners[3] - corners[0];
                mesh.patches.push(Patch {
                    vertices,
                    n_vertices: 4,
                    surface: surface as u32,
                    normal,
                    area: edge_u.cross(edge_v).length(),
                    centroid: (corners[0] + corners[1] + corners[2] + corners[3]) / 4.0,
                });
            }
        }
    }
    mesh
}

/// SplitMix64: a reproducible stream of uniform numbers in [0, 1).
struct Rng(u64);

impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
    fn between(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    /// `n` numbers drawn uniformly from [lo, hi).
    fn values(&mut self, n: usize, lo: f64, hi: f64) -> Vec<f64> {
        (0..n).map(|_| self.between(lo, hi)).collect()
    }
}

/// Solves `a·x = b` for each right-hand side (Gaussian elimination with partial pivoting).
fn dense_solve(mut a: Vec<Vec<f64>>, mut rhs: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    let n = a.len();
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap();
        a.swap(col, pivot);
        for r in rhs.iter_mut() {
            r.swap(col, pivot);
        }
        for row in col + 1..n {
            let factor = a[row][col] / a[col][col];
            if factor == 0.0 {
                continue;
            }
            for c in col..n {
                a[row][c] -= factor * a[col][c];
            }
            for r in rhs.iter_mut() {
                r[row] -= factor * r[col];
            }
        }
    }
    for r in rhs.iter_mut() {
        for row in (0..n).rev() {
            let tail: f64 = (row + 1..n).map(|c| a[row][c] * r[c]).sum();
            r[row] = (r[row] - tail) / a[row][row];
        }
    }
    rhs
}

/// The exact radiosity `B` of `(I − diag(ρ)F) B = ρE` for each column, from the stored F.
fn direct_radiosity(ff: &FormFactors, rho: &[f64], emission: &PatchColumns) -> Vec<Vec<f64>> {
    let n = ff.n_patches();
    let a: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| f64::from(u8::from(i == j)) - rho[i] * ff.get(i, j))
                .collect()
        })
        .collect();
    let rhs = (0..emission.n_columns)
        .map(|k| (0..n).map(|i| rho[i] * emission.get(i, k)).collect())
        .collect();
    dense_solve(a, rhs)
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

fn norm_inf(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn exact_everywhere() -> FormFactorOptions {
    FormFactorOptions {
        near_field_ratio: f64::INFINITY,
        ..FormFactorOptions::default()
    }
}

/// The 3 × 2 × 2.5 m test room, 148 coarse patches.
fn small_room() -> PatchMesh {
    box_room(DVec3::new(3.0, 2.0, 2.5), [6, 4, 5], 1.0)
}

// ---------------------------------------------------------------- form factors vs closed forms

#[test]
fn coaxial_disc_as_256_gon() {
    let (r, h, sides) = (1.0f64, 2.0f64, 256usize);
    let polygon: Vec<DVec3> = (0..sides)
        .map(|k| {
            let phi = 2.0 * PI * k as f64 / sides as f64;
            DVec3::new(r * phi.cos(), r * phi.sin(), h)
        })
        .collect();
    let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &polygon);
    // Exact for the inscribed regular N-gon (apothem a): integrating h²/(h²+ρ²)²/π in polar
    // coordinates sector by sector gives (N/π)·(a/√(a²+h²))·atan(tan(π/N)·a/√(a²+h²)).
    let a = r * (PI / sides as f64).cos();
    let k = a / (a * a + h * h).sqrt();
    let polygon_exact = sides as f64 / PI * k * ((PI / sides as f64).tan() * k).atan();
    assert!((f - polygon_exact).abs() < 1e-12, "{f} vs {polygon_exact}");
    // The disc R²/(h²+R²) = 0.2; the 256-gon misses the segments between chord and arc:
    // ΔF ≈ (dF/dR)·R·(1 − cos(π/N))·2/3 = 0.32·7.5e-5·2/3 ≈ 1.6e-5, so the tolerance is 2e-5.
    let disc = r * r / (h * h + r * r);
    assert!((disc - 0.2f64).abs() < 1e-15);
    assert!(
        disc - f > 0.0 && disc - f < 2e-5,
        "polygonisation error {}",
        disc - f
    );
}

#[test]
fn parallel_rectangle_with_corner_above_the_point() {
    let (a, b, h) = (2.0f64, 3.0f64, 1.5f64);
    let rect = [
        DVec3::new(0.0, 0.0, h),
        DVec3::new(a, 0.0, h),
        DVec3::new(a, b, h),
        DVec3::new(0.0, b, h),
    ];
    let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &rect);
    let (x, y) = (a / h, b / h);
    let closed = (x / (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan()
        + y / (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan())
        / (2.0 * PI);
    assert!((closed - 0.1880837353).abs() < 1e-10);
    assert!((f - 0.1880837353).abs() < 1e-9, "{f}");
    // Winding does not matter.
    let reversed: Vec<DVec3> = rect.iter().rev().copied().collect();
    assert!((point_to_polygon(DVec3::ZERO, DVec3::Z, &reversed) - f).abs() < 1e-15);
}

/// Perpendicular rectangle in the plane y = d, x ∈ [−w, w], z ∈ [0, h], seen from the origin
/// facing +z: two mirrored halves of `(1/2π)[atan(W/D) − D/√(D²+H²)·atan(W/√(D²+H²))]`.
fn perpendicular_closed_form(w: f64, h: f64, d: f64) -> f64 {
    let s = (d * d + h * h).sqrt();
    2.0 * ((w / d).atan() - d / s * (w / s).atan()) / (2.0 * PI)
}

#[test]
fn perpendicular_rectangle_two_mirrored_halves() {
    let (w, h, d) = (1.0, 2.0, 1.0);
    let rect = [
        DVec3::new(-w, d, 0.0),
        DVec3::new(w, d, 0.0),
        DVec3::new(w, d, h),
        DVec3::new(-w, d, h),
    ];
    let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &rect);
    assert!((perpendicular_closed_form(w, h, d) - 0.1901358824).abs() < 1e-10);
    assert!((f - 0.1901358824).abs() < 1e-9, "{f}");
}

#[test]
fn polygon_partly_behind_the_point_is_clipped() {
    // The same wall extended 3 m below the receiver's plane: only the part above counts.
    let (w, h, d) = (1.0, 2.0, 1.0);
    let rect = [
        DVec3::new(-w, d, -3.0),
        DVec3::new(w, d, -3.0),
        DVec3::new(w, d, h),
        DVec3::new(-w, d, h),
    ];
    let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &rect);
    assert!((f - 0.1901358824).abs() < 1e-9, "{f}");
    // A tilted receiver normal clips along a slanted line: compare with a polygon pre-clipped by
    // hand. Normal (0, −1, 1)/√2: the plane z = y keeps z ≥ y, i.e. z ≥ 1 on the wall y = 1.
    let n = DVec3::new(0.0, -1.0, 1.0).normalize();
    let pre_clipped = [
        DVec3::new(-w, d, 1.0),
        DVec3::new(w, d, 1.0),
        DVec3::new(w, d, h),
        DVec3::new(-w, d, h),
    ];
    let clipped_here = point_to_polygon(DVec3::ZERO, n, &rect);
    let clipped_by_hand = point_to_polygon(DVec3::ZERO, n, &pre_clipped);
    assert!(clipped_by_hand > 0.01);
    assert!((clipped_here - clipped_by_hand).abs() < 1e-14);
    // Wholly behind: nothing.
    let behind = rect.map(|q| q - DVec3::Z * 10.0);
    assert_eq!(point_to_polygon(DVec3::ZERO, DVec3::Z, &behind), 0.0);
}

#[test]
fn differential_formula_matches_exact_far_away_to_second_order() {
    let n = DVec3::new(0.2, 0.1, 1.0).normalize();
    let direction = DVec3::new(0.3, -0.2, 1.0).normalize();
    let side = 1.0;
    let mut previous: Option<f64> = None;
    for r in [4.0, 8.0, 16.0, 32.0] {
        let centroid = direction * r;
        let normal = (-direction + DVec3::new(0.25, 0.0, 0.0)).normalize();
        let (t1, t2) = normal.any_orthonormal_pair();
        let half = side / 2.0;
        // Counter-clockwise seen from the normal side: t1 × t2 = normal.
        let square = [(-half, -half), (half, -half), (half, half), (-half, half)]
            .map(|(a, b)| centroid + t1 * a + t2 * b);
        let exact = point_to_polygon(DVec3::ZERO, n, &square);
        let far = differential(DVec3::ZERO, n, centroid, normal, side * side);
        let relative = (far - exact).abs() / exact;
        let bound = (side / r).powi(2);
        assert!(
            relative <= bound,
            "r = {r}: relative difference {relative} > (s/r)² = {bound}"
        );
        if let Some(prev) = previous {
            let ratio = relative / prev;
            assert!(
                (0.2..0.3).contains(&ratio),
                "r = {r}: error ratio {ratio}, expected ≈ 1/4"
            );
        }
        previous = Some(relative);
    }
}

// ---------------------------------------------------------------- the form-factor matrix

#[test]
fn closed_box_rows_sum_to_one() {
    let mesh = small_room();
    let n = mesh.patches.len();
    assert_eq!(n, 148);
    let builder = FormFactorBuilder::new(&mesh, &Unoccluded, exact_everywhere());
    for i in 0..n {
        let sum: f64 = builder.row(i).iter().sum();
        assert!((sum - 1.0).abs() < 1e-9, "row {i}: {sum}");
    }
    let ff = builder.build();
    assert_eq!(ff.bytes(), 4 * n * n);
    assert_eq!(ff.rays_cast(), 0);
    assert_eq!(builder.rays_cast(), 0);
    // f32 storage: each entry rounds by ≤ 6e-8 relative.
    for (i, s) in ff.row_sums().iter().enumerate() {
        assert!((s - 1.0).abs() < 1e-6, "stored row {i}: {s}");
    }
    // Same plane, same facing: zero (floor patches do not see each other).
    let floor: Vec<usize> = (0..n).filter(|&i| mesh.patches[i].surface == FLOOR).collect();
    for &i in &floor {
        for &j in &floor {
            assert_eq!(ff.get(i, j), 0.0);
        }
    }
    // With the near/far rule (exact below 3 patch sizes, differential beyond) the rows are no
    // longer exact: measured max |Σ_j F_ij − 1| = 2.4e-3 here (2.8e-3 on a 2304-patch
    // 6 × 6 × 3 m box), asserted < 1 %.
    let ruled = FormFactors::build(&mesh, &Unoccluded, FormFactorOptions::default());
    let worst = ruled
        .row_sums()
        .iter()
        .map(|s| (s - 1.0).abs())
        .fold(0.0, f64::max);
    eprintln!("near/far rule: max |row sum − 1| = {worst:.3e}");
    assert!(worst < 1e-2, "{worst}");
}

/// Counts rays and blocks every segment that crosses the plane x = `wall_x`.
struct PlaneOccluder {
    wall_x: f64,
    rays: AtomicU64,
}

impl Visibility for PlaneOccluder {
    fn visible(&self, from: DVec3, to: DVec3) -> bool {
        self.rays.fetch_add(1, Ordering::Relaxed);
        (from.x - self.wall_x) * (to.x - self.wall_x) > 0.0
    }
}

#[test]
fn visibility_is_the_visible_fraction_of_sample_rays() {
    // 2 m cube, 3 cells a side: the middle column of floor patches spans x ∈ [2/3, 4/3], and an
    // opaque plane at x = 1 splits its 2×2 sample points evenly.
    let mesh = box_room(DVec3::splat(2.0), [3, 3, 3], 1.0);
    let options = FormFactorOptions {
        near_field_ratio: f64::INFINITY,
        visibility_samples_per_edge: 2,
    };
    let open = FormFactors::build(&mesh, &Unoccluded, options);
    let occluder = PlaneOccluder {
        wall_x: 1.0,
        rays: AtomicU64::new(0),
    };
    let blocked = FormFactors::build(&mesh, &occluder, options);
    assert!(blocked.rays_cast() > 0);
    assert_eq!(blocked.rays_cast(), occluder.rays.load(Ordering::Relaxed));
    let n = mesh.patches.len();
    // Rays are cast only for pairs with a non-zero geometric form factor, 4 per pair.
    let nonzero_pairs = (0..n)
        .flat_map(|i| (0..n).map(move |j| (i, j)))
        .filter(|&(i, j)| open.get(i, j) > 0.0)
        .count();
    assert_eq!(blocked.rays_cast(), 4 * nonzero_pairs as u64);
    let mut straddling_pairs = 0;
    for i in (0..n).filter(|&i| mesh.patches[i].surface == WALL_X0) {
        for j in 0..n {
            let c = mesh.patches[j].centroid;
            let expected = if c.x < 0.9 {
                open.get(i, j) // entirely on the receiver's side
            } else if (c.x - 1.0).abs() < 1e-9 {
                straddling_pairs += 1;
                open.get(i, j) * 0.5 // straddles the plane: 2 of 4 samples visible
            } else {
                0.0 // entirely behind the plane
            };
            assert!(
                (blocked.get(i, j) - expected).abs() <= 1e-7 * expected.max(1e-9),
                "({i}, {j})"
            );
        }
    }
    // 9 receivers on wall x = 0 × 12 middle-column patches (floor, ceiling, two y walls).
    assert_eq!(straddling_pairs, 9 * 12);
}

#[test]
fn triangle_targets_use_their_own_polygon_and_samples() {
    // A triangle above the point: half of the 2 × 2 m square with a corner above p, split along
    // its diagonal through that corner (the halves are mirror images, so each carries half).
    let mut mesh = PatchMesh::default();
    let h = 1.5;
    mesh.positions = vec![
        DVec3::new(0.0, 0.0, h),
        DVec3::new(0.0, 2.0, h),
        DVec3::new(2.0, 2.0, h),
    ];
    mesh.normals = vec![-DVec3::Z; 3];
    mesh.vertex_surface = vec![0; 3];
    let triangle = Patch {
        vertices: [0, 1, 2, 0],
        n_vertices: 3,
        surface: 0,
        normal: -DVec3::Z,
        area: 2.0,
        centroid: DVec3::new(2.0 / 3.0, 4.0 / 3.0, h),
    };
    let target = TargetPatch::new(&mesh, &triangle);
    let f = target.form_factor_from(DVec3::ZERO, DVec3::Z, f64::INFINITY);
    let x = 2.0 / h;
    let square = 2.0 * x / (1.0 + x * x).sqrt() * (x / (1.0 + x * x).sqrt()).atan() / (2.0 * PI);
    assert!((f - square / 2.0).abs() < 1e-12, "{f} vs {}", square / 2.0);
    // s² samples, all inside the triangle, centred on its centroid.
    let samples = target.sample_points(4);
    assert_eq!(samples.len(), 16);
    let mean = samples.iter().copied().sum::<DVec3>() / 16.0;
    assert!((mean.truncate() - triangle.centroid.truncate()).length() < 1e-12);
    for q in samples {
        assert!(q.x >= 0.0 && q.y >= q.x && q.y <= 2.0, "{q}");
    }
    // Seen from behind (above the triangle) it emits nothing towards the point.
    assert_eq!(
        target.form_factor_from(DVec3::new(0.5, 1.5, 3.0), -DVec3::Z, f64::INFINITY),
        0.0
    );
}

// ---------------------------------------------------------------- the solve

#[test]
fn furnace_uniform_reflectance_and_emission() {
    let mesh = small_room();
    let n = mesh.patches.len();
    let ff = FormFactors::build(&mesh, &Unoccluded, exact_everywhere());
    for rho in [0.5, 0.95] {
        let options = SolveOptions {
            tolerance: 1e-6,
            ..SolveOptions::default()
        };
        // Two columns: E = 1 lx and E = −3 lx (a negative basis emitter is just as valid).
        let emission = PatchColumns::from_columns(n, &[vec![1.0; n], vec![-3.0; n]]);
        let solution = solve(&ff, &vec![rho; n], &emission, &options).unwrap();
        for (k, e) in [1.0, -3.0].into_iter().enumerate() {
            let expected = e / (1.0 - rho);
            let report = solution.columns[k];
            assert!(report.converged);
            assert!(
                report.iterations < 40,
                "ρ = {rho}: {} iterations",
                report.iterations
            );
            for i in 0..n {
                let h = solution.irradiance.get(i, k);
                assert!(
                    (h - expected).abs() <= 1e-6 * expected.abs(),
                    "ρ = {rho}, patch {i}: {h} vs {expected}"
                );
            }
        }
    }
}

#[test]
fn iterations_stay_in_the_tens_for_a_floor_lit_box() {
    // Uniform ρ, light on the floor only (not an eigenvector of F): a real Krylov problem.
    let mesh = small_room();
    let n = mesh.patches.len();
    let ff = FormFactors::build(&mesh, &Unoccluded, FormFactorOptions::default());
    let floor_light: Vec<f64> = mesh
        .patches
        .iter()
        .map(|p| f64::from(u8::from(p.surface == FLOOR)) * 100.0)
        .collect();
    let emission = PatchColumns::from_columns(n, &[floor_light]);
    let options = SolveOptions {
        tolerance: 1e-6,
        ..SolveOptions::default()
    };
    for rho in [0.5, 0.8, 0.95] {
        let rho_v = vec![rho; n];
        let solution = solve(&ff, &rho_v, &emission, &options).unwrap();
        let report = solution.columns[0];
        eprintln!(
            "ρ = {rho}: {} GMRES iterations, certified bound {:.2e} of ‖B‖∞",
            report.iterations,
            report.error_bound / report.radiosity_norm
        );
        assert!(report.converged);
        assert!(report.iterations < 40, "ρ = {rho}: {}", report.iterations);
        let exact = direct_radiosity(&ff, &rho_v, &emission);
        let error = max_abs_diff(&solution.radiosity.column(0), &exact[0]);
        assert!(error <= report.error_bound);
    }
}

#[test]
fn certified_bound_holds_against_a_dense_direct_solve() {
    let mesh = small_room();
    let n = mesh.patches.len();
    let ff = FormFactors::build(&mesh, &Unoccluded, FormFactorOptions::default());
    let mut rng = Rng(7);
    let mut rho = rng.values(n, 0.05, 0.95);
    rho[17] = 0.95;
    rho[90] = 0.0;
    let columns: Vec<Vec<f64>> = (0..6)
        .map(|k| {
            (0..n)
                .map(|_| {
                    if k == 0 {
                        rng.between(0.0, 500.0)
                    } else {
                        rng.between(-100.0, 100.0)
                    }
                })
                .collect()
        })
        .collect();
    let emission = PatchColumns::from_columns(n, &columns);
    let exact = direct_radiosity(&ff, &rho, &emission);
    for tol in [1e-3, 1e-6] {
        let options = SolveOptions {
            tolerance: tol,
            ..SolveOptions::default()
        };
        let solution = solve(&ff, &rho, &emission, &options).unwrap();
        assert!(solution.contraction < 1.0 && solution.contraction >= 0.95 * 0.99);
        for (k, b_exact) in exact.iter().enumerate() {
            let report = solution.columns[k];
            let b = solution.radiosity.column(k);
            let error = max_abs_diff(&b, b_exact);
            let scale = norm_inf(b_exact);
            assert!(report.converged, "tol {tol} column {k}");
            assert!(
                error <= report.error_bound,
                "tol {tol} column {k}: {error} > bound {}",
                report.error_bound
            );
            assert!(
                error <= tol * scale,
                "tol {tol} column {k}: error {error} vs {}",
                tol * scale
            );
            // H = E + F·B inherits the error through F (rows sum to max_row_sum).
            let h_exact: Vec<f64> = (0..n)
                .map(|i| emission.get(i, k) + (0..n).map(|j| ff.get(i, j) * b_exact[j]).sum::<f64>())
                .collect();
            let h_error = max_abs_diff(&solution.irradiance.column(k), &h_exact);
            assert!(
                h_error <= solution.max_row_sum * tol * scale * (1.0 + 1e-9) + 1e-12 * norm_inf(&h_exact)
            );
            eprintln!(
                "tol {tol:.0e} column {k}: {} iterations, true error {:.2e} ‖B‖∞",
                report.iterations,
                error / scale
            );
        }
    }
}

#[test]
fn zero_reflectance_returns_the_emission_bitwise() {
    let mesh = small_room();
    let n = mesh.patches.len();
    let ff = FormFactors::build(&mesh, &Unoccluded, FormFactorOptions::default());
    let mut rng = Rng(3);
    let columns: Vec<Vec<f64>> = (0..3).map(|_| rng.values(n, -10.0, 10.0)).collect();
    let emission = PatchColumns::from_columns(n, &columns);
    let solution = solve(&ff, &vec![0.0; n], &emission, &SolveOptions::default()).unwrap();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&solution.irradiance.values), bits(&emission.values));
    assert!(solution.radiosity.values.iter().all(|&b| b == 0.0));
    assert!(solution.columns.iter().all(|c| c.iterations == 0));
}

#[test]
fn a_zero_column_stays_exactly_zero() {
    let mesh = small_room();
    let n = mesh.patches.len();
    let ff = FormFactors::build(&mesh, &Unoccluded, FormFactorOptions::default());
    let emission = PatchColumns::from_columns(n, &[vec![5.0; n], vec![0.0; n]]);
    let solution = solve(&ff, &vec![0.7; n], &emission, &SolveOptions::default()).unwrap();
    assert!(solution.irradiance.column(1).iter().all(|&h| h == 0.0));
    assert_eq!(solution.columns[1].iterations, 0);
    assert!(solution.irradiance.column(0).iter().all(|&h| h > 5.0));
}

#[test]
fn reflectance_at_or_above_the_limit_is_rejected() {
    let mesh = box_room(DVec3::splat(2.0), [2, 2, 2], 1.0);
    let n = mesh.patches.len();
    let ff = FormFactors::build(&mesh, &Unoccluded, FormFactorOptions::default());
    let emission = PatchColumns::from_columns(n, &[vec![1.0; n]]);
    for bad in [0.98, 0.99, 1.0, -0.1, f64::NAN] {
        let mut rho = vec![0.5; n];
        rho[3] = bad;
        let err = solve(&ff, &rho, &emission, &SolveOptions::default()).unwrap_err();
        assert_eq!(err.exit_code(), 2, "{bad}");
        let message = err.to_string();
        assert!(
            message.contains("patch 3") && message.contains("0.98"),
            "{message}"
        );
        assert!(matches!(err, Error::Input(_)));
    }
    assert!(solve(&ff, &vec![0.979; n], &emission, &SolveOptions::default()).is_ok());
}

#[test]
fn solve_is_linear_in_the_emission() {
    let mesh = small_room();
    let n = mesh.patches.len();
    let ff = FormFactors::build(&mesh, &Unoccluded, FormFactorOptions::default());
    let mut rng = Rng(11);
    let rho = rng.values(n, 0.1, 0.9);
    let e1 = rng.values(n, -50.0, 50.0);
    let e2 = rng.values(n, 0.0, 80.0);
    let (a, b) = (2.5, -0.75);
    let combined: Vec<f64> = e1.iter().zip(&e2).map(|(x, y)| a * x + b * y).collect();
    let emission = PatchColumns::from_columns(n, &[e1, e2, combined]);
    let options = SolveOptions {
        tolerance: 1e-8,
        ..SolveOptions::default()
    };
    let solution = solve(&ff, &rho, &emission, &options).unwrap();
    let (h1, h2, h3) = (
        solution.irradiance.column(0),
        solution.irradiance.column(1),
        solution.irradiance.column(2),
    );
    let c = &solution.columns;
    // Each H carries at most max_row_sum × its certified radiosity bound.
    let allowed = solution.max_row_sum
        * (c[2].error_bound + a.abs() * c[0].error_bound + b.abs() * c[1].error_bound)
        + 1e-12 * norm_inf(&h3);
    let blended: Vec<f64> = h1.iter().zip(&h2).map(|(x, y)| a * x + b * y).collect();
    let deviation = max_abs_diff(&h3, &blended);
    assert!(deviation <= allowed, "{deviation} > {allowed}");
    assert!(allowed < 1e-6 * norm_inf(&h3));
}

/// A warm start (`solve_from`) from the radiosity of a nearby emission reaches the cold solve's
/// answer for the new emission within the two certified bounds, in fewer iterations; a starting
/// radiosity of the wrong shape is an internal error.
#[test]
fn warm_start_reaches_the_cold_solution_in_fewer_iterations() {
    let mesh = small_room();
    let n = mesh.patches.len();
    let ff = FormFactors::build(&mesh, &Unoccluded, FormFactorOptions::default());
    let mut rng = Rng(23);
    let rho = rng.values(n, 0.5, 0.9);
    let e = rng.values(n, 0.0, 100.0);
    // The edit: one patch 10 % brighter.
    let mut edited = e.clone();
    edited[0] *= 1.1;
    let options = SolveOptions {
        tolerance: 1e-8,
        ..SolveOptions::default()
    };
    let before = solve(&ff, &rho, &PatchColumns::from_columns(n, &[e]), &options).unwrap();
    let emission = PatchColumns::from_columns(n, &[edited]);
    let cold = solve(&ff, &rho, &emission, &options).unwrap();
    let warm = solve_from(&ff, &rho, &emission, Some(&before.radiosity), &options).unwrap();
    let allowed = cold.max_row_sum * (cold.columns[0].error_bound + warm.columns[0].error_bound)
        + 1e-12 * norm_inf(&cold.irradiance.column(0));
    let deviation = max_abs_diff(&warm.irradiance.column(0), &cold.irradiance.column(0));
    assert!(deviation <= allowed, "{deviation} > {allowed}");
    assert!(
        warm.columns[0].iterations < cold.columns[0].iterations,
        "warm {} vs cold {}",
        warm.columns[0].iterations,
        cold.columns[0].iterations
    );
    let wrong = PatchColumns::from_columns(n - 1, &[vec![0.0; n - 1]]);
    let err = solve_from(&ff, &rho, &emission, Some(&wrong), &options).unwrap_err();
    assert_eq!(err.exit_code(), 1, "{err}");
}

/// The irradiance a solve returns is `E + F·B` of the radiosity it returns — taken from the
/// product of its last check, not formed again — for two columns solved together, and for a
/// warm start already within the tolerance (certified without a step).
#[test]
fn the_irradiance_is_the_emission_plus_the_gathered_radiosity() {
    let mesh = small_room();
    let n = mesh.patches.len();
    let ff = FormFactors::build(&mesh, &Unoccluded, FormFactorOptions::default());
    let mut rng = Rng(7);
    let rho = rng.values(n, 0.3, 0.8);
    let columns: Vec<Vec<f64>> = (0..2).map(|_| rng.values(n, 0.0, 50.0)).collect();
    let emission = PatchColumns::from_columns(n, &columns);
    let options = SolveOptions {
        tolerance: 1e-6,
        ..SolveOptions::default()
    };
    let check = |solution: &haiko::transport::radiosity::Solution| {
        let gathered = Transfer::apply_block(&ff, &solution.radiosity.values, 2);
        for (i, h) in solution.irradiance.values.iter().enumerate() {
            let expected = emission.values[i] + gathered[i];
            assert!(
                (h - expected).abs() <= 1e-12 * expected.abs(),
                "entry {i}: {h} vs {expected}"
            );
        }
    };
    let cold = solve(&ff, &rho, &emission, &options).unwrap();
    assert!(
        cold.columns.iter().all(|c| c.iterations > 0),
        "{:?}",
        cold.columns
    );
    check(&cold);
    let warm = solve_from(&ff, &rho, &emission, Some(&cold.radiosity), &options).unwrap();
    assert!(
        warm.columns.iter().all(|c| c.iterations == 0),
        "{:?}",
        warm.columns
    );
    assert_eq!(
        warm.radiosity, cold.radiosity,
        "a start within the tolerance is kept"
    );
    check(&warm);
}

// ---------------------------------------------------------------- interpolation

/// Moves every vertex that is interior to its (planar, axis-aligned) surface by up to ±`amount`
/// within the surface's plane, making the quads general (non-parallelogram), and recomputes
/// each patch's area and area centroid.
fn jitter_interior_vertices(mut mesh: PatchMesh, size: DVec3, amount: f64, rng: &mut Rng) -> PatchMesh {
    for v in 0..mesh.n_vertices() {
        let q = mesh.positions[v];
        let normal = mesh.normals[v];
        let interior = (0..3).all(|a| normal[a] != 0.0 || (q[a] > 1e-9 && q[a] < size[a] - 1e-9));
        if interior {
            let shift = DVec3::new(
                rng.between(-amount, amount),
                rng.between(-amount, amount),
                rng.between(-amount, amount),
            );
            mesh.positions[v] = q + shift - normal * normal.dot(shift);
        }
    }
    for patch in &mut mesh.patches {
        let c = patch.vertices.map(|i| mesh.positions[i as usize]);
        let triangles = [(c[0], c[1], c[2]), (c[0], c[2], c[3])];
        let areas = triangles.map(|(a, b, d)| (b - a).cross(d - a).length() / 2.0);
        patch.area = areas[0] + areas[1];
        patch.centroid = triangles
            .iter()
            .zip(areas)
            .map(|(&(a, b, d), area)| (a + b + d) / 3.0 * area)
            .sum::<DVec3>()
            / patch.area;
    }
    mesh
}

#[test]
fn linear_fields_are_reproduced_at_every_fine_vertex() {
    let size = DVec3::new(3.0, 2.0, 2.5);
    let field = |p: DVec3| 2.0 + 0.7 * p.x - 1.3 * p.y + 0.4 * p.z;
    let fine = box_room(size, [13, 9, 11], 1.0);
    // A non-uniform coarse grid whose lines do not align with the fine one, and the same grid
    // with its interior vertices jittered (general quads: inverse-bilinear location).
    let stretched = box_room(size, [5, 4, 3], 1.4);
    let jittered = jitter_interior_vertices(stretched.clone(), size, 0.1, &mut Rng(9));
    for coarse in [stretched, jittered] {
        let values: Vec<f64> = coarse.patches.iter().map(|p| field(p.centroid)).collect();
        let result = interpolate(&coarse, &fine, &values);
        assert_eq!(result.len(), fine.n_vertices());
        for (v, &value) in result.iter().enumerate() {
            let expected = field(fine.positions[v]);
            assert!(
                (value - expected).abs() < 1e-10,
                "vertex {v} at {}: {value} vs {expected}",
                fine.positions[v]
            );
        }
    }
}

#[test]
fn values_never_leak_across_a_floor_wall_edge() {
    let size = DVec3::new(3.0, 2.0, 2.5);
    let coarse = box_room(size, [4, 3, 3], 1.0);
    let fine = box_room(size, [12, 8, 10], 1.0);
    let values: Vec<f64> = coarse
        .patches
        .iter()
        .map(|p| f64::from(u8::from(p.surface == FLOOR)))
        .collect();
    let weights = InterpolationWeights::new(&coarse, &fine);
    let result = weights.apply(&values);
    let mut wall_edge_vertices = 0;
    for (v, &value) in result.iter().enumerate() {
        let on_floor = fine.vertex_surface[v] == FLOOR;
        let expected = if on_floor { 1.0 } else { 0.0 };
        assert!(
            (value - expected).abs() < 1e-12,
            "vertex {v} (surface {}): {value}",
            fine.vertex_surface[v]
        );
        if !on_floor && fine.positions[v].z == 0.0 {
            wall_edge_vertices += 1;
        }
        let terms = weights.fine_vertex_terms(v);
        assert!(!terms.is_empty() && terms.len() <= 4);
        assert!((terms.iter().map(|t| t.1).sum::<f64>() - 1.0).abs() < 1e-12);
    }
    // The bottom rows of the four walls (13 + 9 vertices along x and y walls) touch the floor
    // edge and were checked to be 0 above.
    assert_eq!(wall_edge_vertices, 2 * (13 + 9));
}

#[test]
fn column_blend_equals_one_column_at_a_time() {
    let size = DVec3::new(3.0, 2.0, 2.5);
    let coarse = box_room(size, [4, 3, 3], 1.2);
    let fine = box_room(size, [9, 7, 8], 1.0);
    let weights = InterpolationWeights::new(&coarse, &fine);
    let mut rng = Rng(5);
    let n = coarse.patches.len();
    let columns: Vec<Vec<f64>> = (0..3).map(|_| rng.values(n, -1.0, 1.0)).collect();
    let block = PatchColumns::from_columns(n, &columns);
    let together = weights.apply_columns(&block.values, 3);
    assert_eq!(together.len(), fine.n_vertices() * 3);
    for (k, column) in columns.iter().enumerate() {
        let alone = weights.apply(column);
        for (v, &x) in alone.iter().enumerate() {
            assert!((together[v * 3 + k] - x).abs() < 1e-14);
        }
    }
}

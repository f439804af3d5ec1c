//! The certified interreflection solve for many right-hand sides at once (docs/METHOD.md §5).
//!
//! Unknown: `H`, the irradiance (lux) incident on each coarse patch, for `K` emitters at once:
//! `H = E + F·diag(ρ)·H`, with `E` the direct irradiance of each emitter (lux; may be negative
//! for SH basis emitters, never clamped). Internally the solve is on the radiosity (exitance,
//! lm/m²) `B = ρH`: `(I − diag(ρ)F) B = ρE`, then `H = E + F·B`.
//!
//! Method: restarted GMRES, one Krylov space per column, all columns advancing in lock-step so
//! that each step is one pass over `F` for the whole block (rows in parallel with rayon) and
//! the per-column Arnoldi work runs in parallel over columns. Collocation `F` is not symmetric,
//! so CG does not apply; GMRES needs ~10–20 steps where Jacobi needs hundreds at ρ ≈ 0.95.
//!
//! Stopping rule per column (docs/METHOD.md §5): with `q = max_i ρ_i Σ_j F_ij` (`= ρ_max` in a closed
//! room), `‖(I − diag(ρ)F)⁻¹‖∞ ≤ 1/(1 − q)`, so the true residual `r = ρE − (I − diag(ρ)F)B̃`
//! certifies `‖B̃ − B‖∞ ≤ ‖r‖∞/(1 − q)`. A column stops once `‖r‖∞ ≤ tol·(1 − q)·s(B̃)`,
//! i.e. once its error is at most `tol` relative to its scale `s(B̃) = min(‖B̃‖∞,
//! ‖ρ∘(F B̃)‖∞)`: the largest radiosity, or the largest interreflected radiosity when that is
//! smaller — the hot spot of a lamp a centimetre from a ceiling is a million times the rest of
//! the room, and `tol` of it would leave the room's interreflected light unsolved
//! (docs/DECISIONS.md "The solve's scale").

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::transport::formfactor::FormFactors;
use crate::transport::hierarchy::Operator;

/// A form-factor operator the solve iterates with: the dense matrix or the hierarchical
/// operator. `F_ij` is the irradiance at patch `i` per unit radiosity of patch `j`.
pub trait Transfer: Sync {
    /// Number of patches `n`.
    fn n_patches(&self) -> usize;
    /// `F·X` for a patch-major block `X` of `width` columns.
    fn apply_block(&self, block: &[f64], width: usize) -> Vec<f64>;
    /// `Σ_j F_ij` per patch.
    fn row_sums(&self) -> Vec<f64>;
}

impl Transfer for FormFactors {
    fn n_patches(&self) -> usize {
        FormFactors::n_patches(self)
    }
    fn apply_block(&self, block: &[f64], width: usize) -> Vec<f64> {
        multiply_block(self, block, width)
    }
    fn row_sums(&self) -> Vec<f64> {
        FormFactors::row_sums(self)
    }
}

impl Transfer for Operator {
    fn n_patches(&self) -> usize {
        self.n_leaves()
    }
    fn apply_block(&self, block: &[f64], width: usize) -> Vec<f64> {
        Operator::apply_block(self, block, width)
    }
    fn row_sums(&self) -> Vec<f64> {
        Operator::row_sums(self)
    }
}

/// Reflectances at or above this are rejected: the solve becomes ill-conditioned and a closed
/// room at ρ = 1 is singular.
pub const MAX_REFLECTANCE: f64 = 0.98;

/// Values per patch for `K` columns (emitters), **patch-major**: the `K` values of patch `i`
/// are contiguous at `values[i·K .. (i+1)·K]`. Units are those of the quantity stored (lux for
/// irradiance, lm/m² for radiosity).
#[derive(Debug, Clone, PartialEq)]
pub struct PatchColumns {
    /// Number of patches `n`.
    pub n_patches: usize,
    /// Number of columns `K`.
    pub n_columns: usize,
    /// `n·K` values, patch-major.
    pub values: Vec<f64>,
}

impl PatchColumns {
    /// All zeros.
    pub fn zeros(n_patches: usize, n_columns: usize) -> Self {
        PatchColumns {
            n_patches,
            n_columns,
            values: vec![0.0; n_patches * n_columns],
        }
    }

    /// Value of patch `i`, column `k`.
    pub fn get(&self, i: usize, k: usize) -> f64 {
        self.values[i * self.n_columns + k]
    }

    /// Column `k` as a vector over patches.
    pub fn column(&self, k: usize) -> Vec<f64> {
        (0..self.n_patches).map(|i| self.get(i, k)).collect()
    }

    /// Builds the block from columns, each of length `n_patches` (entries a shorter column lacks
    /// are zero; extra entries are ignored).
    pub fn from_columns(n_patches: usize, columns: &[Vec<f64>]) -> Self {
        let k = columns.len();
        let mut block = PatchColumns::zeros(n_patches, k);
        for (c, column) in columns.iter().enumerate() {
            for (i, &v) in column.iter().enumerate().take(n_patches) {
                block.values[i * k + c] = v;
            }
        }
        block
    }
}

/// Knobs of the solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveOptions {
    /// Certified relative error per column (`‖B̃ − B‖∞ ≤ tol·‖B̃‖∞`). Default 1e-3.
    pub tolerance: f64,
    /// GMRES restart length (Krylov vectors kept per column). Default 30.
    pub restart: usize,
    /// Cap on GMRES steps per column; a column that hits it is reported unconverged (its bound is
    /// still valid). Default 500.
    pub max_iterations: usize,
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions {
            tolerance: 1e-3,
            restart: 30,
            max_iterations: 500,
        }
    }
}

/// What the solve did for one column.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColumnReport {
    /// GMRES steps (block matrix–vector products with `F`, excluding the residual checks).
    pub iterations: usize,
    /// `‖r‖∞` of the final radiosity, recomputed from scratch (lm/m²).
    pub residual: f64,
    /// The scale the error is relative to (lm/m²): `‖B̃‖∞` of the final radiosity, at most its
    /// largest interreflected radiosity `‖ρ∘(F B̃)‖∞` (module doc).
    pub radiosity_norm: f64,
    /// Certified bound on the true error `‖B̃ − B‖∞ = ‖r‖∞/(1 − q)` (lm/m²). The irradiance
    /// error is at most `max_row_sum ×` this.
    pub error_bound: f64,
    /// True when `error_bound ≤ tol·radiosity_norm`.
    pub converged: bool,
}

/// The solution for all columns.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// Total irradiance `H = E + F·B` on each patch (lux), patch-major like the input.
    pub irradiance: PatchColumns,
    /// Radiosity `B` leaving each patch (lm/m²), patch-major.
    pub radiosity: PatchColumns,
    /// Per-column iterations, residual and certified bound.
    pub columns: Vec<ColumnReport>,
    /// `q = max_i ρ_i Σ_j F_ij` used in the bound (`ρ_max` in a closed room).
    pub contraction: f64,
    /// `max_i Σ_j F_ij`.
    pub max_row_sum: f64,
}

/// Solves `H = E + F·diag(ρ)·H` for every column of `emission` (grey: one reflectance per
/// patch, in `[0, 0.98)`).
///
/// Errors: a reflectance outside `[0, 0.98)` (or not a number) is bad input naming the patch;
/// sizes that do not match `form_factors` or rows of `F` so large that no bound exists
/// (`q ≥ 1`) are internal errors. All-zero reflectance returns `H = E` (bitwise) with 0
/// iterations; an all-zero column stays exactly zero.
pub fn solve<T: Transfer + ?Sized>(
    form_factors: &T,
    reflectance: &[f64],
    emission: &PatchColumns,
    options: &SolveOptions,
) -> Result<Solution> {
    solve_from(form_factors, reflectance, emission, None, options)
}

/// [`solve`] starting from a previous radiosity `initial` (same shape as `emission`; a warm start
/// after a small change of the emission needs only a few steps) instead of the first bounce. The
/// stopping rule and its certificate are the same.
pub fn solve_from<T: Transfer + ?Sized>(
    form_factors: &T,
    reflectance: &[f64],
    emission: &PatchColumns,
    initial: Option<&PatchColumns>,
    options: &SolveOptions,
) -> Result<Solution> {
    let n = form_factors.n_patches();
    if let Some(x0) = initial
        && (x0.n_patches != n || x0.n_columns != emission.n_columns)
    {
        return Err(Error::internal(format!(
            "interreflection: a {}×{} starting radiosity for a {}×{} right-hand side",
            x0.n_patches, x0.n_columns, n, emission.n_columns
        )));
    }
    check_inputs(n, reflectance, emission)?;
    let k = emission.n_columns;
    let row_sums = form_factors.row_sums();
    let max_row_sum = row_sums.iter().copied().fold(0.0, f64::max);
    let contraction = reflectance
        .iter()
        .zip(&row_sums)
        .map(|(r, s)| r * s)
        .fold(0.0, f64::max);
    if contraction >= 1.0 {
        return Err(Error::internal(format!(
            "interreflection: ρ·(form-factor row sum) reaches {contraction:.4} ≥ 1, the solve cannot be \
             certified; surfaces that overlap (OBJ faces lying on one another, facing the same \
             way) do this"
        )));
    }
    let params = Params {
        reflectance,
        threshold: options.tolerance * (1.0 - contraction),
        contraction,
        restart: options.restart.max(1),
        max_iterations: options.max_iterations,
    };
    // Columns advance in lock-step within groups whose Krylov bases fit the memory budget (one
    // group in the bundled rooms; the 48 lights of a 133 547-leaf floor in seven).
    let per_column = n * 8 * (params.restart + 4);
    let group = (SOLVE_BUDGET_BYTES / per_column.max(1)).clamp(1, k.max(1));
    let mut radiosity = PatchColumns::zeros(n, k);
    let mut irradiance = emission.clone();
    let mut reports = Vec::with_capacity(k);
    for first in (0..k).step_by(group) {
        let columns = solve_group(
            form_factors,
            emission,
            initial,
            first..(first + group).min(k),
            &params,
        );
        for (c, column) in (first..).zip(&columns) {
            for (i, &b) in column.x.iter().enumerate() {
                radiosity.values[i * k + c] = b;
            }
            reports.push(column.report);
        }
        add_indirect(&columns, first, &mut irradiance);
    }
    Ok(Solution {
        irradiance,
        radiosity,
        columns: reports,
        contraction,
        max_row_sum,
    })
}

/// Most bytes the GMRES state of the columns solved together may take.
const SOLVE_BUDGET_BYTES: usize = 256 << 20;

/// Runs GMRES for the emission columns `range` in lock-step (one block product with `F` per
/// step) until each is done.
fn solve_group<T: Transfer + ?Sized>(
    form_factors: &T,
    emission: &PatchColumns,
    initial: Option<&PatchColumns>,
    range: std::ops::Range<usize>,
    params: &Params,
) -> Vec<ColumnGmres> {
    let n = emission.n_patches;
    let mut columns: Vec<ColumnGmres> = range
        .map(|c| {
            let rhs: Vec<f64> = (0..n)
                .map(|i| params.reflectance[i] * emission.get(i, c))
                .collect();
            ColumnGmres::new(rhs, initial.map(|x0| x0.column(c)))
        })
        .collect();
    loop {
        let mut active: Vec<&mut ColumnGmres> = columns.iter_mut().filter(|c| !c.is_done()).collect();
        if active.is_empty() {
            break;
        }
        let width = active.len();
        let mut block = vec![0.0; n * width];
        for (a, column) in active.iter().enumerate() {
            for (i, &v) in column.pending().iter().enumerate() {
                block[i * width + a] = v;
            }
        }
        let product = form_factors.apply_block(&block, width);
        active.par_iter_mut().enumerate().for_each(|(a, column)| {
            let f_times_v: Vec<f64> = (0..n).map(|i| product[i * width + a]).collect();
            column.absorb(f_times_v, params);
        });
    }
    columns
}

fn check_inputs(n: usize, reflectance: &[f64], emission: &PatchColumns) -> Result<()> {
    if reflectance.len() != n || emission.n_patches != n || emission.values.len() != n * emission.n_columns {
        return Err(Error::internal(format!(
            "interreflection: {n} patches in F but {} reflectances and a {}×{} right-hand side ({} values)",
            reflectance.len(),
            emission.n_patches,
            emission.n_columns,
            emission.values.len()
        )));
    }
    if let Some((i, rho)) = reflectance
        .iter()
        .enumerate()
        .find(|(_, r)| !(0.0..MAX_REFLECTANCE).contains(*r))
    {
        return Err(Error::input(
            "",
            format!("patch {i}"),
            format!(
                "reflectance {rho} is outside 0 ≤ ρ < {MAX_REFLECTANCE} (near 1 the interreflection solve is singular)"
            ),
        ));
    }
    Ok(())
}

/// Adds `F·B` of the solved `columns` (columns `first..` of `irradiance`, which holds `E`) to
/// `irradiance`: `H = E + F·B`, from the product each column's last check already formed for its
/// final radiosity (no product of its own). A column with a zero right-hand side (done at once,
/// no product) keeps `H = E` bitwise.
fn add_indirect(columns: &[ColumnGmres], first: usize, irradiance: &mut PatchColumns) {
    let k = irradiance.n_columns;
    for (a, column) in columns.iter().enumerate() {
        for (i, v) in column.f_times_x.iter().flatten().enumerate() {
            irradiance.values[i * k + first + a] += v;
        }
    }
}

/// Rows of `F` (receivers) handled together, so each row of the block is loaded once per tile.
const ROW_TILE: usize = 16;
/// Columns of the block handled together, so a tile's accumulators stay in L1 and the block's
/// slice of these columns in L2.
const COLUMN_CHUNK: usize = 64;

/// `F·X` for a patch-major block `X` of `width` columns: tiles of rows in parallel (rayon),
/// each streaming the block once per column chunk.
fn multiply_block(form_factors: &FormFactors, block: &[f64], width: usize) -> Vec<f64> {
    let n = form_factors.n_patches();
    let mut out = vec![0.0; n * width];
    if width == 0 {
        return out;
    }
    out.par_chunks_mut(width * ROW_TILE)
        .enumerate()
        .for_each(|(tile, out_tile)| {
            let rows: Vec<&[f32]> = (0..out_tile.len() / width)
                .map(|r| form_factors.row(tile * ROW_TILE + r))
                .collect();
            for c0 in (0..width).step_by(COLUMN_CHUNK) {
                let c1 = (c0 + COLUMN_CHUNK).min(width);
                for j in 0..n {
                    let x = &block[j * width + c0..j * width + c1];
                    for (r, row) in rows.iter().enumerate() {
                        let f = row[j];
                        if f == 0.0 {
                            continue;
                        }
                        let f = f64::from(f);
                        for (a, &xv) in out_tile[r * width + c0..r * width + c1].iter_mut().zip(x) {
                            *a += f * xv;
                        }
                    }
                }
            }
        });
    out
}

/// Shared, read-only parameters of the per-column iteration.
struct Params<'a> {
    reflectance: &'a [f64],
    /// `tol·(1 − q)`: stop when `‖r‖∞ ≤ threshold·s(B̃)` (module doc).
    threshold: f64,
    contraction: f64,
    restart: usize,
    max_iterations: usize,
}

/// Which product with `F` a column waits for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    /// `F·x` to form the true residual (start of a cycle and the certification check).
    Residual,
    /// `F·v_j` for the next Arnoldi vector.
    Arnoldi,
    /// Certified (or out of iterations).
    Done,
}

/// Restarted GMRES for one column of `(I − diag(ρ)F) x = b`.
struct ColumnGmres {
    b: Vec<f64>,
    x: Vec<f64>,
    /// Orthonormal Krylov basis of the current cycle.
    basis: Vec<Vec<f64>>,
    /// Columns of the rotated (upper-triangular) Hessenberg matrix.
    triangle: Vec<Vec<f64>>,
    /// Givens rotations `(cos, sin)`.
    rotations: Vec<(f64, f64)>,
    /// Rotated `β e₁`; `|g[j]|` after step `j` is the 2-norm of the residual.
    g: Vec<f64>,
    stage: Stage,
    report: ColumnReport,
    /// Once done: `F·x` of the final radiosity, formed by the check that certified it (`None`
    /// for a zero right-hand side, done without a product).
    f_times_x: Option<Vec<f64>>,
    /// `‖ρ∘(F x)‖∞` at the last check (infinite before the first): the cap on the scale the
    /// steps between checks estimate against.
    indirect_cap: f64,
}

impl ColumnGmres {
    /// Starts from `x0`, else the first bounce `x₀ = b`; a zero right-hand side is done at once
    /// (`x = 0`).
    fn new(b: Vec<f64>, x0: Option<Vec<f64>>) -> Self {
        let zero = b.iter().all(|&v| v == 0.0);
        let x = if zero {
            vec![0.0; b.len()]
        } else {
            x0.unwrap_or_else(|| b.clone())
        };
        ColumnGmres {
            b,
            x,
            basis: Vec::new(),
            triangle: Vec::new(),
            rotations: Vec::new(),
            g: Vec::new(),
            stage: if zero { Stage::Done } else { Stage::Residual },
            report: ColumnReport {
                iterations: 0,
                residual: 0.0,
                radiosity_norm: 0.0,
                error_bound: 0.0,
                converged: true,
            },
            f_times_x: None,
            indirect_cap: f64::INFINITY,
        }
    }

    fn is_done(&self) -> bool {
        self.stage == Stage::Done
    }

    /// The vector this column needs multiplied by `F` next.
    fn pending(&self) -> &[f64] {
        match self.stage {
            Stage::Arnoldi => self.basis.last().map_or(&self.x, |v| v),
            Stage::Residual | Stage::Done => &self.x,
        }
    }

    /// Takes `F·pending()` and advances.
    fn absorb(&mut self, f_times_v: Vec<f64>, params: &Params) {
        match self.stage {
            Stage::Residual => self.check_and_restart(f_times_v, params),
            Stage::Arnoldi => self.arnoldi_step(&f_times_v, params),
            Stage::Done => {}
        }
    }

    /// `A v = v − ρ∘(F v)`.
    fn apply(v: &[f64], f_times_v: &[f64], reflectance: &[f64]) -> Vec<f64> {
        v.iter()
            .zip(f_times_v)
            .zip(reflectance)
            .map(|((&v, &fv), &r)| v - r * fv)
            .collect()
    }

    fn check_and_restart(&mut self, f_times_x: Vec<f64>, params: &Params) {
        let ax = Self::apply(&self.x, &f_times_x, params.reflectance);
        let residual: Vec<f64> = self.b.iter().zip(&ax).map(|(b, a)| b - a).collect();
        let residual_inf = norm_inf(&residual);
        let reflected = f_times_x
            .iter()
            .zip(params.reflectance)
            .fold(0.0f64, |m, (fx, r)| m.max((r * fx).abs()));
        if reflected > 0.0 {
            self.indirect_cap = reflected;
        }
        let scale = norm_inf(&self.x).min(self.indirect_cap);
        let converged = residual_inf <= params.threshold * scale;
        if converged || self.report.iterations >= params.max_iterations {
            self.report.residual = residual_inf;
            self.report.radiosity_norm = scale;
            self.report.error_bound = residual_inf / (1.0 - params.contraction);
            self.report.converged = converged;
            self.stage = Stage::Done;
            self.f_times_x = Some(f_times_x);
            self.basis = Vec::new();
            return;
        }
        let beta = norm_2(&residual);
        self.basis.clear();
        self.basis.push(residual.iter().map(|r| r / beta).collect());
        self.triangle.clear();
        self.rotations.clear();
        self.g.clear();
        self.g.push(beta);
        self.stage = Stage::Arnoldi;
    }

    fn arnoldi_step(&mut self, f_times_v: &[f64], params: &Params) {
        let Some(v) = self.basis.last() else {
            self.stage = Stage::Residual;
            return;
        };
        let mut w = Self::apply(v, f_times_v, params.reflectance);
        let w_norm_before = norm_2(&w);
        // Modified Gram–Schmidt.
        let mut h: Vec<f64> = Vec::with_capacity(self.basis.len() + 1);
        for q in &self.basis {
            let hij = dot(&w, q);
            for (wi, qi) in w.iter_mut().zip(q) {
                *wi -= hij * qi;
            }
            h.push(hij);
        }
        let h_next = norm_2(&w);
        h.push(h_next);
        self.report.iterations += 1;
        let j = self.rotations.len();
        for (i, &(c, s)) in self.rotations.iter().enumerate() {
            let (a, b) = (h[i], h[i + 1]);
            h[i] = c * a + s * b;
            h[i + 1] = -s * a + c * b;
        }
        let denom = h[j].hypot(h[j + 1]);
        let (c, s) = if denom == 0.0 {
            (1.0, 0.0)
        } else {
            (h[j] / denom, h[j + 1] / denom)
        };
        h[j] = denom;
        h[j + 1] = 0.0;
        self.rotations.push((c, s));
        let gj = self.g[j];
        self.g[j] = c * gj;
        self.g.push(-s * gj);
        h.truncate(j + 1);
        self.triangle.push(h);

        let breakdown = h_next <= 1e-14 * w_norm_before;
        let residual_2 = self.g[j + 1].abs();
        let cycle_full = self.rotations.len() >= params.restart;
        let out_of_steps = self.report.iterations >= params.max_iterations;
        if breakdown || cycle_full || out_of_steps || self.estimate_converged(residual_2, params) {
            self.finish_cycle();
            self.stage = Stage::Residual;
        } else {
            self.basis.push(w.iter().map(|wi| wi / h_next).collect());
        }
    }

    /// `y` solving the rotated triangle `R y = g[..m]`.
    fn cycle_coefficients(&self) -> Vec<f64> {
        let m = self.triangle.len();
        let mut y = vec![0.0; m];
        for i in (0..m).rev() {
            let tail: f64 = (i + 1..m).map(|l| self.triangle[l][i] * y[l]).sum();
            let diag = self.triangle[i][i];
            y[i] = if diag == 0.0 {
                0.0
            } else {
                (self.g[i] - tail) / diag
            };
        }
        y
    }

    /// The 2-norm residual estimate bounds the ∞-norm; compare it against the current iterate's
    /// scale (its ∞-norm, formed only once a cheap upper bound of that norm already passes,
    /// capped as at the last check).
    fn estimate_converged(&self, residual_2: f64, params: &Params) -> bool {
        let y = self.cycle_coefficients();
        let upper = (norm_inf(&self.x) + y.iter().map(|v| v.abs()).sum::<f64>()).min(self.indirect_cap);
        if residual_2 > params.threshold * upper {
            return false;
        }
        residual_2 <= params.threshold * norm_inf(&self.candidate(&y)).min(self.indirect_cap)
    }

    fn candidate(&self, y: &[f64]) -> Vec<f64> {
        let mut x = self.x.clone();
        for (q, &yl) in self.basis.iter().zip(y) {
            for (xi, qi) in x.iter_mut().zip(q) {
                *xi += yl * qi;
            }
        }
        x
    }

    fn finish_cycle(&mut self) {
        let y = self.cycle_coefficients();
        self.x = self.candidate(&y);
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm_2(v: &[f64]) -> f64 {
    dot(v, v).sqrt()
}

/// `max |v_i|`, NaN when any entry is NaN (`f64::max` alone would drop it, and a NaN residual
/// would pass for a certified one).
fn norm_inf(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m: f64, x| {
        if m.is_nan() || x.is_nan() {
            f64::NAN
        } else {
            m.max(x.abs())
        }
    })
}

#[cfg(test)]
mod tests {
    use super::norm_inf;

    #[test]
    fn the_max_norm_keeps_a_nan_wherever_it_is() {
        assert_eq!(norm_inf(&[1.0, -3.0, 2.0]), 3.0);
        for v in [[f64::NAN, 1.0, 2.0], [1.0, f64::NAN, 2.0], [1.0, 2.0, f64::NAN]] {
            assert!(norm_inf(&v).is_nan(), "{v:?}");
        }
    }
}

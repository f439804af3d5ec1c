//! `haiko lid FILE|ROOM#LIGHT`: the curve report of [`crate::accuracy::lid`] as text tables or
//! JSON.

use crate::accuracy::lid::{LID_TARGET_REL_L2, LidReport, load_curve, report};
use crate::error::{Error, Result, check_finite, printable};
use crate::photometry::Window;

/// Formats the report as text tables.
pub(crate) fn format_text(source: &str, r: &LidReport) -> String {
    let target = LID_TARGET_REL_L2 * 100.0;
    let error = r.order_rel_l2_error * 100.0;
    let order = if r.order_rel_l2_error <= LID_TARGET_REL_L2 {
        format!(
            "chosen order {} (relative L2 {error:.1} % ≤ {target:.0} %)",
            r.order
        )
    } else {
        format!(
            "order capped at {}: relative L2 {error:.1} % misses the {target:.0} % target (a hard-edged curve)",
            r.order
        )
    };
    let mut s = format!(
        "{}\nflux {:.1} lm   peak {:.1} cd   asymmetry {:.3}   {order}\n\n",
        printable(source),
        r.flux_lm,
        r.peak_cd,
        r.asymmetry,
    );
    s.push_str(
        "order  window   rel L2    max |err| cd   min cd     overshoot  exact µs  rect µs   edit µs\n",
    );
    for row in &r.orders {
        s.push_str(&format!(
            "{:>5}  {:<7} {:>8.4}  {:>13.2}  {:>9.2}  {:>9.4}  {:>8.2}  {:>7.2}  {:>8.3}\n",
            row.order,
            row.window,
            row.rel_l2_error,
            row.max_abs_error_cd,
            row.min_cd,
            row.overshoot,
            row.fit_exact_us,
            row.fit_rectangle_us,
            row.edit_us
        ));
    }
    s
}

/// Runs the command.
pub fn run(source: &str, order: Option<usize>, window: Option<Window>, json: bool) -> Result<()> {
    if order.is_some_and(|n| n > 150) {
        return Err(Error::input("--order", "", "orders above 150 are not supported"));
    }
    let (curve, asymmetry) = load_curve(source)?;
    let r = report(&curve, asymmetry, order, window);
    check_finite(
        "lid: a result",
        [r.flux_lm, r.peak_cd, r.asymmetry, r.order_rel_l2_error]
            .into_iter()
            .chain(
                r.orders
                    .iter()
                    .flat_map(|row| [row.rel_l2_error, row.max_abs_error_cd, row.min_cd, row.overshoot]),
            ),
    )?;
    if json {
        println!(
            "{}",
            serde_json::to_string(&r).map_err(|e| Error::internal(e.to_string()))?
        );
    } else {
        print!("{}", format_text(source, &r));
    }
    Ok(())
}

//! Reads an IES file into a string, parses it with Haiko's library and prints the curve's flux
//! and its first zonal (Legendre) weights: `haiko-consumer FILE.ies`.

use std::path::PathBuf;

use haiko::photometry::{ZonalWeights, parse_ies};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = PathBuf::from(std::env::args().nth(1).ok_or("usage: haiko-consumer FILE.ies")?);
    let text = std::fs::read_to_string(&path)?;
    let file = parse_ies(&path, &text)?;
    let weights = ZonalWeights::exact(&file.curve, 4);
    println!("flux_lm {}", file.curve.flux_lm());
    println!("w0_cd {}", weights.w[0]);
    Ok(())
}

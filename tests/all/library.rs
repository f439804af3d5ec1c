//! Haiko as a library (docs/ARCHITECTURE.md, "Library"): a program that depends on it with
//! `default-features = false` builds without the terminal and command-line crates, parses an IES
//! file from a string and gets its flux. The program is `tests/consumer/`; this test builds and
//! runs it from a temporary copy that uses Haiko's own `Cargo.lock`.

use std::path::{Path, PathBuf};
use std::process::Command;

use haiko::photometry::read_lid_file;

/// The consumer crate copied to `dir`, its dependency on Haiko pointing at this repository.
fn consumer_in(dir: &Path) -> PathBuf {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let source = repo.join("tests/consumer");
    let manifest = std::fs::read_to_string(source.join("Cargo.toml"))
        .unwrap()
        .replace(
            "path = \"../..\"",
            &format!("path = {:?}", repo.display().to_string()),
        );
    std::fs::create_dir_all(dir.join("src")).unwrap();
    std::fs::write(dir.join("Cargo.toml"), manifest).unwrap();
    std::fs::copy(source.join("src/main.rs"), dir.join("src/main.rs")).unwrap();
    std::fs::copy(repo.join("Cargo.lock"), dir.join("Cargo.lock")).unwrap();
    dir.join("Cargo.toml")
}

fn cargo(args: &[&str]) -> String {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let output = Command::new(cargo).args(args).output().expect("cargo runs");
    assert!(
        output.status.success(),
        "cargo {args:?} failed:\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout).unwrap()
}

#[test]
fn a_consumer_without_default_features_parses_an_ies_string_and_pulls_no_terminal_crates() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = consumer_in(dir.path());
    let manifest = manifest.to_str().unwrap();

    let tree = cargo(&[
        "tree",
        "--manifest-path",
        manifest,
        "-e",
        "normal",
        "--prefix",
        "none",
    ]);
    assert!(tree.starts_with("haiko-consumer"), "{tree}");
    assert!(tree.contains("haiko v"), "the consumer depends on haiko: {tree}");
    for crate_name in ["ratatui", "crossterm", "ratatui-image", "clap"] {
        assert!(
            !tree.lines().any(|l| l.split(' ').next() == Some(crate_name)),
            "{crate_name} is in the consumer's tree:\n{tree}"
        );
    }

    // Its own target directory: the outer `cargo test` holds the lock of the main one.
    let target = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/consumer");
    let ies = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ies/cosine_downlight.ies");
    let printed = cargo(&[
        "run",
        "--quiet",
        "--manifest-path",
        manifest,
        "--target-dir",
        target.to_str().unwrap(),
        "--",
        ies.to_str().unwrap(),
    ]);
    let value = |key: &str| -> f64 {
        let line = printed.lines().find(|l| l.starts_with(key)).expect(key);
        line[key.len()..].trim().parse().unwrap()
    };
    // A Lambertian downlight of 1000 cd peak: Φ = π · 1000 lm, less the chord error of the
    // 5° linear interpolation (below 0.1 %).
    let flux = value("flux_lm");
    assert!(
        (flux / (std::f64::consts::PI * 1000.0) - 1.0).abs() < 1e-3,
        "{flux}"
    );
    // The same numbers as the library in this process (same code, same file).
    let file = read_lid_file(&ies).unwrap();
    assert_eq!(flux, file.curve.flux_lm());
    let w0 = haiko::photometry::ZonalWeights::exact(&file.curve, 4).w[0];
    assert_eq!(value("w0_cd"), w0);
}

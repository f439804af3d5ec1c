//! `haiko render ROOM --terminal … --cells 160x48 --font 10x20 --json`: the bytes the editor
//! would send for one full and one interactive preview frame. The paper room and the office in
//! sixel: the interactive frame fits the 64 KiB budget, the full frame 100 KiB; the files hold
//! exactly the reported bytes, and each is one sixel image the size of the preview.

use std::path::Path;
use std::process::{Command, Output};

fn haiko(cache: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_haiko"))
        .args(args)
        .env("HAIKO_CACHE_DIR", cache)
        .output()
        .expect("the binary runs")
}

/// Runs `render --terminal PROTOCOL --json -o DIR/ROOM-PROTOCOL` and returns the JSON and the
/// two files' bytes (full, interactive).
fn frames(dir: &Path, room: &str, protocol: &str) -> (serde_json::Value, Vec<u8>, Vec<u8>) {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let room_path = repo.join("rooms").join(format!("{room}.toml"));
    let out = dir.join(format!("{room}-{protocol}"));
    let output = haiko(
        &dir.join("cache"),
        &[
            "render",
            room_path.to_str().unwrap(),
            "--terminal",
            protocol,
            "--cells",
            "160x48",
            "--font",
            "10x20",
            "--json",
            "-o",
            out.to_str().unwrap(),
        ],
    );
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let read = |suffix: &str| std::fs::read(format!("{}{suffix}", out.display())).unwrap();
    (json, read(".full"), read(".interactive"))
}

fn bytes(json: &serde_json::Value, frame: &str) -> usize {
    json[frame]["bytes"].as_u64().unwrap() as usize
}

/// The raster attributes (`"1;1;W;H`) of every sixel image in `data`.
fn sixel_rasters(data: &[u8]) -> Vec<String> {
    let text = String::from_utf8_lossy(data);
    text.split("\x1bP")
        .skip(1)
        .map(|image| {
            let start = image.find("\"1;1;").expect("raster attributes");
            let rest = &image[start + 1..];
            rest[..rest.find(|c: char| c != ';' && !c.is_ascii_digit()).unwrap()].to_string()
        })
        .collect()
}

#[test]
fn sixel_frames_of_the_paper_room_and_the_office_fit_their_budgets() {
    let dir = tempfile::tempdir().unwrap();
    for room in ["paper", "office"] {
        let (json, full, interactive) = frames(dir.path(), room, "sixel");
        // 160 × 48 cells: the editor's layout leaves the preview 94 × 32 cells, 940 × 640 px.
        assert_eq!(json["preview_cells"], serde_json::json!([94, 32]), "{json}");
        assert_eq!(json["full_px"], serde_json::json!([940, 640]), "{json}");
        assert_eq!(json["budget_bytes"], 65536);
        assert_eq!(
            (bytes(&json, "full"), bytes(&json, "interactive")),
            (full.len(), interactive.len())
        );
        assert!(full.len() <= 100 * 1024, "{room}: full frame {} B", full.len());
        assert!(
            interactive.len() <= 64 * 1024,
            "{room}: interactive frame {} B",
            interactive.len()
        );
        // The full frame is rendered at full size; the interactive one at 1/d, enlarged by the
        // encoder to cover the same cells: both are one 940 × 640 sixel image.
        assert_eq!(json["full"]["divisor"], 1);
        assert_eq!(
            (json["full"]["width"].as_u64(), json["full"]["height"].as_u64()),
            (Some(940), Some(640))
        );
        let d = json["interactive"]["divisor"].as_u64().unwrap();
        assert_eq!(
            (
                json["interactive"]["width"].as_u64(),
                json["interactive"]["height"].as_u64()
            ),
            (Some(940u64.div_ceil(d)), Some(640u64.div_ceil(d)))
        );
        assert_eq!(sixel_rasters(&full), ["1;1;940;640"]);
        assert_eq!(sixel_rasters(&interactive), ["1;1;940;640"]);
        assert!(full.ends_with(b"\x1b\\") || full.windows(2).any(|w| w == b"\x1b\\"));
    }
}

#[test]
fn kitty_iterm2_and_half_block_frames_carry_their_protocol() {
    let dir = tempfile::tempdir().unwrap();
    let has = |data: &[u8], needle: &str| data.windows(needle.len()).any(|w| w == needle.as_bytes());
    let (json, full, interactive) = frames(dir.path(), "paper", "kitty");
    assert_eq!(json["terminal"], "kitty");
    // One image id, transmitted as PNG (f=100), shown by Unicode placeholders.
    for frame in [&full, &interactive] {
        assert!(has(frame, "\x1b_G") && has(frame, "f=100"), "{json}");
        assert!(has(frame, "\u{10EEEE}"));
    }
    let (_, full, _) = frames(dir.path(), "paper", "iterm2");
    assert!(has(&full, "\x1b]1337;File=inline=1;"));
    assert!(has(&full, "width=94;height=32;preserveAspectRatio=0"));
    let (json, full, _) = frames(dir.path(), "paper", "halfblocks");
    // Half-blocks: every preview cell is one ▀ or ▄ with its two colours.
    let text = String::from_utf8_lossy(&full);
    let blocks = text.chars().filter(|&c| c == '▀' || c == '▄').count();
    assert!(blocks > 94 * 32 / 2, "{blocks}");
    assert_eq!(bytes(&json, "full"), full.len());
}

#[test]
fn bad_cells_and_fonts_are_refused_with_the_flag_named() {
    let dir = tempfile::tempdir().unwrap();
    let room = Path::new(env!("CARGO_MANIFEST_DIR")).join("rooms/paper.toml");
    for (flag, value, says) in [
        ("--cells", "160", "is not WIDTHxHEIGHT"),
        ("--cells", "0x48", "is not WIDTHxHEIGHT"),
        ("--font", "10xtwenty", "is not WIDTHxHEIGHT"),
        ("--cells", "20x10", "leave no room for the preview"),
    ] {
        let output = haiko(
            &dir.path().join("cache"),
            &[
                "render",
                room.to_str().unwrap(),
                "--terminal",
                "sixel",
                flag,
                value,
            ],
        );
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{flag} {value}: {stderr}");
        assert!(
            stderr.contains(flag) && stderr.contains(says),
            "{flag} {value}: {stderr}"
        );
    }
}

//! `haiko render ROOM --terminal PROTOCOL --cells 160x48 --font 10x20 [--json] [-o OUT]`: the
//! bytes the editor would send for one full and one interactive preview frame
//! (`tui::frame_cost`), their sizes and encode times; with `-o` the frames are written to
//! `OUT.full` and `OUT.interactive`.

use std::path::{Path, PathBuf};

use clap::ValueEnum;

use crate::cli::{load_room, open_session};
use crate::error::{Error, Result};
use crate::session::budget::MemoryLimit;
use crate::session::frame::MAX_SIDE_PX;
use crate::tui::frame_budget::DEFAULT_BUDGET;
use crate::tui::frame_cost::{FrameCost, FrameCosts, measure, preview_cells};
use crate::tui::multiplexer::Protocol;

/// `--terminal` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TerminalArg {
    /// DEC sixel (our encoder).
    Sixel,
    /// kitty graphics (PNG, Unicode placeholders).
    Kitty,
    /// iTerm2 inline images (PNG).
    Iterm2,
    /// Unicode half-blocks.
    Halfblocks,
}

impl From<TerminalArg> for Protocol {
    fn from(t: TerminalArg) -> Self {
        match t {
            TerminalArg::Sixel => Protocol::Sixel,
            TerminalArg::Kitty => Protocol::Kitty,
            TerminalArg::Iterm2 => Protocol::Iterm2,
            TerminalArg::Halfblocks => Protocol::Halfblocks,
        }
    }
}

/// Parses `WxH` (`160x48`, `10×20`) for `flag`.
///
/// Errors (bad input, naming `flag`): not two positive numbers below 65536.
pub fn parse_pair(flag: &str, text: &str) -> Result<(u16, u16)> {
    let bad = || {
        Error::input(
            flag,
            "",
            format!("`{text}` is not WIDTHxHEIGHT with two whole numbers from 1, e.g. 160x48"),
        )
    };
    let (w, h) = text.split_once(['x', 'X', '×']).ok_or_else(bad)?;
    let number = |s: &str| s.trim().parse::<u16>().ok().filter(|&n| n > 0).ok_or_else(bad);
    Ok((number(w)?, number(h)?))
}

/// Runs the command (see the module docs).
///
/// Errors: the room (bad input), `--cells`/`--font` (bad input), writing the frames (bad
/// input), rendering (internal).
pub fn run(
    room: &Path,
    terminal: TerminalArg,
    cells: &str,
    font: &str,
    output: Option<&Path>,
    json: bool,
    limit: &MemoryLimit,
) -> Result<()> {
    let cells = parse_pair("--cells", cells)?;
    let font = parse_pair("--font", font)?;
    let preview = preview_cells(cells)?;
    let preview_px = (
        u32::from(preview.width) * u32::from(font.0),
        u32::from(preview.height) * u32::from(font.1),
    );
    if Protocol::from(terminal) != Protocol::Halfblocks && preview_px.0.max(preview_px.1) > MAX_SIDE_PX {
        return Err(Error::input(
            "--font",
            "",
            format!(
                "{}x{} px cells make the {}x{}-cell preview {}x{} pixels, more than {MAX_SIDE_PX} a side",
                font.0, font.1, preview.width, preview.height, preview_px.0, preview_px.1
            ),
        ));
    }
    let scene = load_room(room)?;
    let mut session = open_session(scene.clone(), true, limit)?;
    session.relight();
    let costs = measure(&mut session, &scene, terminal.into(), cells, font, DEFAULT_BUDGET)?;
    let files = match output {
        Some(out) => {
            let write = |suffix: &str, frame: &FrameCost| -> Result<PathBuf> {
                let mut name = out.as_os_str().to_owned();
                name.push(suffix);
                let path = PathBuf::from(name);
                std::fs::write(&path, &frame.bytes)
                    .map_err(|e| Error::input(&path, "", format!("cannot write the frame: {e}")))?;
                Ok(path)
            };
            Some((
                write(".full", &costs.full)?,
                write(".interactive", &costs.interactive)?,
            ))
        }
        None => None,
    };
    let protocol = Protocol::from(terminal).label();
    if json {
        let frame = |f: &FrameCost, file: Option<&PathBuf>| {
            serde_json::json!({
                "width": f.size_px.0,
                "height": f.size_px.1,
                "divisor": f.plan.divisor(),
                "dithered": f.plan == crate::tui::frame_budget::FramePlan::Full { dither: true },
                "bytes": f.bytes.len(),
                "encode_ms": f.encode_ms,
                "file": file.map(|p| p.display().to_string()),
            })
        };
        let doc = serde_json::json!({
            "room": room.display().to_string(),
            "terminal": protocol,
            "cells": [cells.0, cells.1],
            "font": [font.0, font.1],
            "preview_cells": [costs.preview_cells.width, costs.preview_cells.height],
            "full_px": [costs.full_px.0, costs.full_px.1],
            "budget_bytes": costs.budget,
            "full": frame(&costs.full, files.as_ref().map(|f| &f.0)),
            "interactive": frame(&costs.interactive, files.as_ref().map(|f| &f.1)),
        });
        let text =
            serde_json::to_string_pretty(&doc).map_err(|e| Error::internal(format!("render: JSON: {e}")))?;
        println!("{text}");
    } else {
        print_table(room, protocol, &costs);
    }
    Ok(())
}

fn print_table(room: &Path, protocol: &str, costs: &FrameCosts) {
    println!(
        "{}: {protocol} preview of {}×{} cells ({}×{} px), interactive budget {:.1} KiB",
        room.display(),
        costs.preview_cells.width,
        costs.preview_cells.height,
        costs.full_px.0,
        costs.full_px.1,
        costs.budget as f64 / 1024.0
    );
    for (name, f) in [("full", &costs.full), ("interactive", &costs.interactive)] {
        println!(
            "{name:<12} 1/{} {}×{} px  {:>8.1} KiB  encode {:.1} ms",
            f.plan.divisor(),
            f.size_px.0,
            f.size_px.1,
            f.bytes.len() as f64 / 1024.0,
            f.encode_ms
        );
    }
}

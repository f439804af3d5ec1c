//! `haiko report ROOM -o report.html`: the client report (docs/ROOM_FILE.md, "Design numbers")
//! of the room as its file describes it, made through a session ([`crate::report::build`]).

use std::path::Path;

use crate::cli::open_session;
use crate::error::{Error, Result};
use crate::report::{ReportOptions, report_html};
use crate::scene;
use crate::session::frame::check_size;

/// Runs the command: loads and bakes the room (or reads the bake cache), renders the views and
/// writes the HTML file `output`.
pub fn run(room: &Path, output: &Path, width: u32, height: u32) -> Result<()> {
    let scene = scene::load(room)?;
    check_size(width, height, ["--width", "--height"])?;
    let mut session = open_session(scene, true)?;
    let options = ReportOptions {
        width_px: width,
        height_px: height,
    };
    let text = report_html(&mut session, &room.display().to_string(), &options)?;
    std::fs::write(output, &text)
        .map_err(|e| Error::input(output, "", format!("cannot write the report: {e}")))?;
    println!(
        "{}: report written to {} ({} kB)",
        room.display(),
        output.display(),
        text.len().div_ceil(1024)
    );
    Ok(())
}

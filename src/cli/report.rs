//! `haiko report ROOM -o report.html`: the client report (docs/ROOM_FILE.md, "Design numbers")
//! of the room as its file describes it, made through a session ([`crate::report::build`]).

use std::path::Path;

use crate::cli::{load_room, open_session};
use crate::error::{Result, printable};
use crate::fsio;
use crate::report::{ReportOptions, report_html};
use crate::session::budget::MemoryLimit;
use crate::session::frame::check_size;

/// Runs the command: loads and bakes the room (or reads the bake cache), renders the views and
/// writes the HTML file `output`.
pub fn run(room: &Path, output: &Path, width: u32, height: u32, limit: &MemoryLimit) -> Result<()> {
    let scene = load_room(room)?;
    check_size(width, height, ["--width", "--height"])?;
    // Every file the room named has been read: none of them may be the output.
    fsio::check_not_an_input(output, &[room])?;
    let mut session = open_session(scene, true, limit)?;
    let options = ReportOptions {
        width_px: width,
        height_px: height,
    };
    let text = report_html(&mut session, &room.display().to_string(), &options)?;
    fsio::write_atomic(output, text.as_bytes())?;
    println!(
        "{}: report written to {} ({} kB)",
        printable(&room.display().to_string()),
        printable(&output.display().to_string()),
        text.len().div_ceil(1024)
    );
    Ok(())
}

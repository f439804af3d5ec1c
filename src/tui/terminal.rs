//! The real terminal: entering and leaving full-screen mode (raw mode, alternate screen, mouse
//! capture), restored on quit, on error and on panic; synchronized drawing; the input reader
//! thread.

use std::io::{Write, stdout};
use std::sync::mpsc::Sender;
use std::thread;

use ratatui::crossterm::event::{self, DisableMouseCapture, EnableMouseCapture};
use ratatui::crossterm::execute;
use ratatui::crossterm::terminal::{BeginSynchronizedUpdate, Clear, ClearType, EndSynchronizedUpdate};
use ratatui::{DefaultTerminal, Frame};

use crate::error::{Error, Result};
use crate::tui::preview::ImageSetup;
use crate::tui::signals;
use crate::tui::workers::AppEvent;

/// Which inline image protocol the preview uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Graphics {
    /// Ask the terminal, fall back to half-blocks.
    Auto,
    /// DEC sixel.
    Sixel,
    /// kitty graphics protocol.
    Kitty,
    /// iTerm2 inline images.
    Iterm2,
    /// Unicode half-blocks (works everywhere).
    Halfblocks,
}

/// The terminal in full-screen mode and the graphics protocol it speaks. Dropping it restores
/// the terminal.
pub struct TerminalSession {
    terminal: DefaultTerminal,
    setup: ImageSetup,
}

impl TerminalSession {
    /// Takes the terminal: raw mode, alternate screen and a panic hook that restores both
    /// (ratatui) and writes [`signals::RESTORE`] (mouse off, cursor on, a cut-off image
    /// ended), the graphics query ([`ImageSetup::detect`], before any event is read), then
    /// mouse capture.
    ///
    /// Errors (internal): the terminal refused (e.g. stdout is not a terminal).
    pub fn enter(graphics: Graphics) -> Result<TerminalSession> {
        let terminal = ratatui::try_init().map_err(|e| {
            ratatui::restore();
            Error::internal(format!("cannot take the terminal: {e}"))
        })?;
        let previous_hook = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let _ = stdout().write_all(signals::RESTORE.as_bytes());
            let _ = stdout().flush();
            previous_hook(info);
        }));
        let session = TerminalSession {
            terminal,
            setup: ImageSetup::detect(graphics),
        };
        execute!(stdout(), EnableMouseCapture)
            .map_err(|e| Error::internal(format!("cannot enable the mouse: {e}")))?;
        Ok(session)
    }

    /// The graphics protocol and cell size in use.
    pub fn setup(&self) -> &ImageSetup {
        &self.setup
    }

    /// Suspends the editor (Ctrl-Z): the terminal is given back as the shell had it, the
    /// process stops (SIGTSTP); once the shell continues it, the terminal is taken again and
    /// the whole screen is drawn anew.
    ///
    /// Errors (internal): the terminal could not be restored or taken again.
    pub fn suspend(&mut self) -> Result<()> {
        let failed = |e: std::io::Error| Error::internal(format!("suspending: {e}"));
        execute!(stdout(), DisableMouseCapture).map_err(failed)?;
        self.terminal.show_cursor().map_err(failed)?;
        ratatui::restore();
        signals::stop_self().map_err(failed)?;
        // A new terminal has empty buffers: the next draw writes every cell. (Terminal::clear
        // would ask for the cursor position, whose answer the input thread takes.)
        self.terminal = ratatui::try_init().map_err(failed)?;
        execute!(stdout(), Clear(ClearType::All), EnableMouseCapture).map_err(failed)
    }

    /// The terminal's size in cells (columns, rows).
    ///
    /// Errors (internal): the terminal cannot tell.
    pub fn size(&self) -> Result<(u16, u16)> {
        let size = self
            .terminal
            .size()
            .map_err(|e| Error::internal(format!("cannot read the terminal size: {e}")))?;
        Ok((size.width, size.height))
    }

    /// Forgets what the screen shows: the next [`TerminalSession::draw`] writes every cell that
    /// is not blank, images included (no clear, so no flash).
    pub fn forget_screen(&mut self) {
        self.terminal.swap_buffers();
    }

    /// Draws one frame inside a synchronized update, so the terminal shows it at once.
    ///
    /// Errors (internal): writing to the terminal failed.
    pub fn draw(&mut self, render: impl FnOnce(&mut Frame<'_>)) -> Result<()> {
        let failed = |e: std::io::Error| Error::internal(format!("cannot draw: {e}"));
        execute!(stdout(), BeginSynchronizedUpdate).map_err(failed)?;
        let drawn = self.terminal.draw(render).map(|_| ()).map_err(failed);
        execute!(stdout(), EndSynchronizedUpdate).map_err(failed)?;
        stdout().flush().map_err(failed)?;
        drawn
    }
}

impl Drop for TerminalSession {
    fn drop(&mut self) {
        let _ = execute!(stdout(), DisableMouseCapture);
        ratatui::restore();
    }
}

/// Starts the thread that reads terminal events and forwards them to the app's channel; it
/// ends when the app drops the receiver (after the next event) or reading fails.
pub fn spawn_input_reader(events: Sender<AppEvent>) {
    thread::spawn(move || {
        loop {
            let event = match event::read() {
                Ok(event) => AppEvent::Input(event),
                Err(e) => {
                    let _ = events.send(AppEvent::InputFailed(e.to_string()));
                    return;
                }
            };
            if events.send(event).is_err() {
                return;
            }
        }
    });
}

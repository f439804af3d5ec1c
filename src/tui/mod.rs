//! The terminal editor, in the Elm architecture (docs/ARCHITECTURE.md): [`model::Model`] holds
//! the state, [`msg::Msg`] the events and engine results, [`update::update`] the only state
//! transition (pure, tested without a terminal; edits are [`crate::session::Command`]s),
//! [`view::view`] draws the state. [`app::run`] owns the loop and carries out the
//! [`msg::Effect`]s; [`workers`] holds the engine (a [`crate::session::Session`]), bake and
//! encode threads; [`preview`] the terminal image protocol; [`terminal`] the screen itself.

pub mod app;
pub mod camera_nav;
pub mod edits;
pub mod history;
pub mod keys;
pub mod luminaires;
pub mod model;
pub mod msg;
pub mod panel;
pub mod polar;
pub mod preview;
pub mod save;
pub mod terminal;
pub mod update;
pub mod view;
pub mod workers;

pub use model::{LightEdit, Mode, Model, WindowChoice};
pub use msg::{Effect, Msg};
pub use save::save_room;
pub use terminal::Graphics;
pub use update::update;
pub use view::{PreviewArea, preview_rect, view};

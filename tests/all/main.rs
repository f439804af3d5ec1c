//! One integration-test binary for the whole crate (fast to build): each area is a module.

mod direct;
mod editor_design;
mod layering;
mod library;
mod lidfiles;
mod montecarlo;
mod numbers;
mod photometry;
mod scene;
mod session;

fn main() {}
mod accuracy;
mod badinput;
mod bake;
mod cli;
mod design;
mod design_e2e;
mod radiosity;
mod render;
mod render_pixels;
mod render_rooms;
mod render_views;
mod save;
mod terminal_e2e;
mod terminal_frames;
mod tui;
mod tui_e2e;

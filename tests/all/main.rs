//! One integration-test binary for the whole crate (fast to build): each area is a module.

mod direct;
mod layering;
mod lidfiles;
mod photometry;
mod scene;
mod session;

fn main() {}
mod accuracy;
mod bake;
mod cli;
mod design;
mod radiosity;
mod render;
mod render_pixels;
mod render_rooms;
mod render_views;
mod tui;
mod tui_e2e;

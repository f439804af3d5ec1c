//! One integration-test binary for the whole crate (fast to build): each area is a module.

mod direct;
mod lidfiles;
mod scene;
mod photometry;

fn main() {}
mod radiosity;
mod render;
mod render_rooms;

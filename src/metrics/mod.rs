//! Design numbers from the lit room: work-plane grids and their statistics.

pub mod grid;

//! Flattening band columns (docs/DECISIONS.md "Terminal graphics"): in a smooth gradient a
//! boundary between two neighbouring colours crosses each six-row band on a slant, and every
//! slanted crossing costs several sixels per colour. Where all colours of one column of a band
//! are neighbours on the palette grid (at most one step apart on every axis), the column is
//! painted in its most common colour: the boundary moves by at most three rows and no pixel
//! changes by more than one grid step (one percent of luma at full quality), while the band
//! needs one run per colour. Columns holding any larger difference (an edge, a marker) are
//! left exact.

use rayon::prelude::*;

use super::bands::BANDS_PER_TASK;
use super::palette::Indexed;

/// True when grid cells `a` and `b` are at most one step apart on every axis.
fn neighbours(a: [i32; 3], b: [i32; 3]) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() <= 1)
}

/// Marks in `uniform` the columns of `band` (whole rows of `width` pixels) that hold one colour.
pub fn uniform_columns(band: &[u8], width: usize, uniform: &mut Vec<bool>) {
    uniform.clear();
    uniform.resize(width, true);
    let (first, rest) = band.split_at(width);
    for row in rest.chunks_exact(width) {
        for ((same, a), b) in uniform.iter_mut().zip(first).zip(row) {
            *same &= a == b;
        }
    }
}

/// Flattens the band columns of `image` whose colours are all neighbours.
pub fn flatten_columns(image: &mut Indexed) {
    let (width, colours) = (image.width, image.palette.len());
    let mut near = vec![false; colours * colours];
    for a in 0..colours {
        for b in 0..colours {
            near[a * colours + b] = neighbours(image.cells[a], image.cells[b]);
        }
    }
    image
        .indices
        .par_chunks_mut(6 * BANDS_PER_TASK * width)
        .for_each(|bands| flatten_bands(bands, width, &near, colours));
}

/// Flattens the bands in `bands` (whole rows of `width` pixels).
fn flatten_bands(bands: &mut [u8], width: usize, near: &[bool], colours: usize) {
    let mut uniform = Vec::with_capacity(width);
    for band in bands.chunks_mut(6 * width) {
        let rows = band.len() / width;
        uniform_columns(band, width, &mut uniform);
        for x in (0..width).filter(|&x| !uniform[x]) {
            // The column's distinct colours and how often each occurs.
            let mut distinct = [(0u8, 0u8); 6];
            let mut n = 0;
            for r in 0..rows {
                let c = band[r * width + x];
                match distinct[..n].iter_mut().find(|d| d.0 == c) {
                    Some(d) => d.1 += 1,
                    None => {
                        distinct[n] = (c, 1);
                        n += 1;
                    }
                }
            }
            let distinct = &distinct[..n];
            let all_near = distinct.iter().enumerate().all(|(i, &(a, _))| {
                distinct[i + 1..]
                    .iter()
                    .all(|&(b, _)| near[usize::from(a) * colours + usize::from(b)])
            });
            if !all_near {
                continue;
            }
            // The most common colour; on a tie the lower index (the more used one overall).
            let most = distinct
                .iter()
                .max_by_key(|&&(c, count)| (count, std::cmp::Reverse(c)))
                .map_or(band[x], |d| d.0);
            for r in 0..rows {
                band[r * width + x] = most;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A palette image of `columns` (each a list of rows) with cells on the luma axis only.
    fn image(columns: &[&[u8]], cells: &[[i32; 3]]) -> Indexed {
        let height = columns[0].len();
        let width = columns.len();
        let mut indices = vec![0; width * height];
        for (x, column) in columns.iter().enumerate() {
            for (y, &c) in column.iter().enumerate() {
                indices[y * width + x] = c;
            }
        }
        Indexed {
            width,
            height,
            palette: cells.iter().map(|_| [0, 0, 0]).collect(),
            cells: cells.to_vec(),
            indices,
        }
    }

    #[test]
    fn a_slanted_one_step_boundary_becomes_straight_in_each_band() {
        // Colours 0 and 1 one luma step apart, 2 two steps from 0.
        let cells = [[40, 0, 0], [41, 0, 0], [42, 0, 0]];
        let mut im = image(
            &[&[0, 0, 0, 0, 0, 1], &[0, 0, 1, 1, 1, 1], &[1, 1, 1, 1, 1, 1]],
            &cells,
        );
        flatten_columns(&mut im);
        assert_eq!(
            im.indices,
            vec![0, 1, 1, 0, 1, 1, 0, 1, 1, 0, 1, 1, 0, 1, 1, 0, 1, 1]
        );
    }

    #[test]
    fn larger_steps_edges_and_three_levels_stay_exact() {
        let cells = [[40, 0, 0], [41, 0, 0], [42, 0, 0], [41, 2, 0]];
        // 0 and 2 are two steps apart; 0, 1, 2 hold a two-step pair; 1 and 3 differ in chroma by 2.
        let columns: [&[u8]; 3] = [&[0, 0, 0, 2, 2, 2], &[0, 0, 1, 1, 2, 2], &[1, 1, 1, 3, 3, 3]];
        let mut im = image(&columns, &cells);
        let before = im.indices.clone();
        flatten_columns(&mut im);
        assert_eq!(im.indices, before);
    }

    #[test]
    fn bands_are_six_rows_and_the_last_may_be_shorter() {
        let cells = [[10, 0, 0], [11, 1, -1]];
        // Eight rows: a band of six (mostly 1) and a band of two (a tie: the lower index).
        let mut im = image(&[&[0, 1, 1, 1, 1, 1, 1, 0]], &cells);
        flatten_columns(&mut im);
        assert_eq!(im.indices, vec![1, 1, 1, 1, 1, 1, 0, 0]);
    }
}

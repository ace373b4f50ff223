//! Image grids for the report's gallery.

use std::path::Path;

use image::{Rgb, RgbImage};

/// Lays out equally sized RGB images in rows of `columns`, separated by a
/// 4-pixel white gutter, and writes a PNG.
pub fn write_grid(path: &Path, images: &[RgbImage], columns: usize) -> Result<(), String> {
    let Some(first) = images.first() else {
        return Err(format!("{}: no images", path.display()));
    };
    let (w, h) = first.dimensions();
    let gap = 4u32;
    let cols = columns.max(1).min(images.len()) as u32;
    let rows = images.len().div_ceil(cols as usize) as u32;
    let mut grid = RgbImage::from_pixel(
        cols * w + (cols - 1) * gap,
        rows * h + (rows - 1) * gap,
        Rgb([255, 255, 255]),
    );
    for (i, img) in images.iter().enumerate() {
        let (c, r) = (i as u32 % cols, i as u32 / cols);
        image::imageops::replace(
            &mut grid,
            img,
            (c * (w + gap)) as i64,
            (r * (h + gap)) as i64,
        );
    }
    grid.save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| format!("{}: {e}", path.display()))
}

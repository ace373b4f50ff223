//! Labelled contact sheets: a title line over a grid of images, each with
//! a caption under it, for `hybrid series` and the report's gallery (text
//! set by [`crate::text`]).

use std::path::Path;

use image::{Rgb, RgbImage};

use crate::text::{draw_centred, font, line_height, text_width, SMALLEST_PX};

const BACKGROUND: Rgb<u8> = Rgb([255, 255, 255]);
const GAP: u32 = 8;

/// Pixel height of captions and of the title.
const CAPTION_PX: f32 = 15.0;
const TITLE_PX: f32 = 18.0;

/// A contact sheet: `tiles` in rows of `columns`, each with its caption
/// under it, and a title line over them (none when empty). Every tile gets
/// a cell as large as the largest, and as wide as the widest caption at
/// the smallest text size, so that captions never run into their
/// neighbours; a tile sits at the top of its cell, centred.
pub fn sheet(
    title: &str,
    tiles: &[(RgbImage, String)],
    columns: usize,
) -> Result<RgbImage, String> {
    if tiles.is_empty() {
        return Err("a contact sheet needs at least one image".into());
    }
    let font = font();
    let widest_caption = tiles
        .iter()
        .map(|(_, text)| text_width(&font, SMALLEST_PX, text).ceil() as u32)
        .max()
        .unwrap_or(0);
    let w = tiles
        .iter()
        .map(|(t, _)| t.width())
        .max()
        .unwrap_or(1)
        .max(widest_caption);
    let h = tiles.iter().map(|(t, _)| t.height()).max().unwrap_or(1);
    let cols = columns.max(1).min(tiles.len()) as u32;
    let rows = tiles.len().div_ceil(cols as usize) as u32;
    let caption = line_height(&font, CAPTION_PX);
    let title_band = if title.is_empty() {
        0
    } else {
        line_height(&font, TITLE_PX) + GAP
    };
    let width = cols * w + (cols + 1) * GAP;
    let height = GAP + title_band + rows * (h + caption) + rows * GAP;
    let mut out = RgbImage::from_pixel(width, height, BACKGROUND);
    if !title.is_empty() {
        draw_centred(&mut out, &font, TITLE_PX, title, GAP, width - 2 * GAP, GAP);
    }
    for (i, (img, text)) in tiles.iter().enumerate() {
        let (c, r) = (i as u32 % cols, i as u32 / cols);
        let x = GAP + c * (w + GAP);
        let y = GAP + title_band + r * (h + caption + GAP);
        image::imageops::replace(&mut out, img, (x + (w - img.width()) / 2) as i64, y as i64);
        draw_centred(&mut out, &font, CAPTION_PX, text, x, w, y + h + 2);
    }
    Ok(out)
}

/// [`sheet`], written as a PNG.
pub fn write_sheet(
    path: &Path,
    title: &str,
    tiles: &[(RgbImage, String)],
    columns: usize,
) -> Result<(), String> {
    sheet(title, tiles, columns)?
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| format!("{}: cannot write the contact sheet: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ink_in(img: &RgbImage, x0: u32, y0: u32, x1: u32, y1: u32) -> usize {
        (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y).0[0] < 128)
            .count()
    }

    #[test]
    fn captions_and_title_are_drawn_in_their_bands_and_longer_text_covers_more() {
        let tile = RgbImage::from_pixel(120, 40, Rgb([255, 255, 255]));
        let tiles = vec![
            (tile.clone(), "m = 1".to_string()),
            (tile, "m = 12345".to_string()),
        ];
        let img = sheet("a title", &tiles, 2).unwrap();
        let font = font();
        let title_band = line_height(&font, TITLE_PX) + GAP;
        let caption = line_height(&font, CAPTION_PX);
        assert_eq!(img.width(), 2 * 120 + 3 * GAP);
        assert_eq!(img.height(), GAP + title_band + 40 + caption + GAP);
        let title_ink = ink_in(&img, 0, 0, img.width(), GAP + title_band);
        let y = GAP + title_band + 40;
        let short = ink_in(&img, GAP, y, GAP + 120, y + caption);
        let long = ink_in(&img, 2 * GAP + 120, y, 2 * GAP + 240, y + caption);
        println!("ink: title {title_ink}, short caption {short}, long caption {long}");
        assert!(title_ink > 20, "no title drawn");
        assert!(short > 10, "no caption drawn");
        assert!(long > short, "a longer caption did not cover more pixels");
        // Nothing is drawn over the (white) tiles themselves.
        assert_eq!(ink_in(&img, GAP, GAP + title_band, GAP + 120, y), 0);
    }

    #[test]
    fn captions_wider_than_small_tiles_widen_the_cells_instead_of_overlapping() {
        let tile = RgbImage::from_pixel(40, 30, Rgb([255, 255, 255]));
        let text = "light sampling · 69 / 411".to_string();
        let tiles = vec![(tile.clone(), text.clone()), (tile, text.clone())];
        let img = sheet("", &tiles, 2).unwrap();
        let cell = (img.width() - 3 * GAP) / 2;
        assert!(
            cell >= text_width(&font(), SMALLEST_PX, &text) as u32,
            "cell {cell}"
        );
        // No ink in the gap between the two cells' caption bands.
        let y = GAP + 30;
        let gap = ink_in(&img, GAP + cell, y, 2 * GAP + cell, img.height());
        assert_eq!(gap, 0, "captions run into the gap between cells");
    }
}

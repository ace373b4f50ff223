//! Labelled contact sheets: a title line over a grid of images, each with
//! a caption under it, for `hybrid series` and the report's gallery (text
//! set by [`crate::text`]).

use std::path::Path;

use image::{Rgb, RgbImage};

use crate::text::{draw_centred, fitting_px, font, line_height, text_width, SMALLEST_PX};

const BACKGROUND: Rgb<u8> = Rgb([255, 255, 255]);
const GAP: u32 = 8;

/// Pixel height of captions and of the title.
const CAPTION_PX: f32 = 15.0;
const TITLE_PX: f32 = 18.0;

/// A contact sheet: `tiles` in rows of `columns`, each with its caption
/// under it, and a title line over them (none when empty). Every tile gets
/// a cell as large as the largest; smaller ones sit at its top left. A
/// caption wider than its cell at the smallest text size is broken into
/// lines at spaces, so captions never run into their neighbours.
pub fn sheet(
    title: &str,
    tiles: &[(RgbImage, String)],
    columns: usize,
) -> Result<RgbImage, String> {
    if tiles.is_empty() {
        return Err("a contact sheet needs at least one image".into());
    }
    let w = tiles.iter().map(|(t, _)| t.width()).max().unwrap_or(1);
    let h = tiles.iter().map(|(t, _)| t.height()).max().unwrap_or(1);
    let font = font();
    let captions: Vec<Vec<String>> = tiles.iter().map(|(_, t)| lines(&font, t, w)).collect();
    let most_lines = captions.iter().map(Vec::len).max().unwrap_or(1).max(1) as u32;
    let cols = columns.max(1).min(tiles.len()) as u32;
    let rows = tiles.len().div_ceil(cols as usize) as u32;
    let line = line_height(&font, CAPTION_PX);
    let caption = line * most_lines;
    let width = cols * w + (cols + 1) * GAP;
    // A title wider than the sheet is broken into lines too.
    let title_lines = if title.is_empty() {
        Vec::new()
    } else {
        lines(&font, title, width - 2 * GAP)
    };
    let title_line = line_height(&font, TITLE_PX);
    let title_band = if title_lines.is_empty() {
        0
    } else {
        title_line * title_lines.len() as u32 + GAP
    };
    let height = GAP + title_band + rows * (h + caption) + rows * GAP;
    let mut out = RgbImage::from_pixel(width, height, BACKGROUND);
    let title_px = title_lines
        .iter()
        .map(|l| fitting_px(&font, TITLE_PX, l, width - 2 * GAP))
        .fold(TITLE_PX, f32::min);
    for (k, l) in title_lines.iter().enumerate() {
        let y = GAP + k as u32 * title_line;
        draw_centred(&mut out, &font, title_px, l, GAP, width - 2 * GAP, y);
    }
    for (i, ((img, _), text)) in tiles.iter().zip(&captions).enumerate() {
        let (c, r) = (i as u32 % cols, i as u32 / cols);
        let x = GAP + c * (w + GAP);
        let y = GAP + title_band + r * (h + caption + GAP);
        image::imageops::replace(&mut out, img, x as i64, y as i64);
        // One size for all the lines of a caption: the largest at which
        // each fits.
        let px = text
            .iter()
            .map(|l| fitting_px(&font, CAPTION_PX, l, w))
            .fold(CAPTION_PX, f32::min);
        for (k, l) in text.iter().enumerate() {
            draw_centred(&mut out, &font, px, l, x, w, y + h + 2 + k as u32 * line);
        }
    }
    Ok(out)
}

/// `text` as lines that each fit in `width` at the smallest text size,
/// broken at spaces (one line when it fits; a word wider than `width`
/// keeps a line of its own).
fn lines(font: &ab_glyph::FontRef, text: &str, width: u32) -> Vec<String> {
    let fits = |t: &str| text_width(font, SMALLEST_PX, t) <= width as f32;
    if fits(text) {
        return vec![text.to_string()];
    }
    let mut out: Vec<String> = Vec::new();
    for word in text.split_whitespace() {
        match out.last_mut() {
            Some(last) if fits(&format!("{last} {word}")) => {
                last.push(' ');
                last.push_str(word);
            }
            _ => out.push(word.to_string()),
        }
    }
    out
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
    fn captions_wider_than_small_tiles_break_into_lines_instead_of_overlapping() {
        let tile = RgbImage::from_pixel(40, 30, Rgb([255, 255, 255]));
        let text = "light sampling · 69 / 411".to_string();
        let tiles = vec![(tile.clone(), text.clone()), (tile, text.clone())];
        let img = sheet("", &tiles, 2).unwrap();
        let cell = 40;
        assert_eq!(
            img.width(),
            2 * cell + 3 * GAP,
            "cells keep the tiles' width"
        );
        assert!(lines(&font(), &text, cell).len() > 1);
        // No ink in the gap between the two cells' caption bands.
        let y = GAP + 30;
        let gap = ink_in(&img, GAP + cell, y, 2 * GAP + cell, img.height());
        assert_eq!(gap, 0, "captions run into the gap between cells");
    }
}

//! Labelled contact sheets: a title line over a grid of equally sized
//! images, each with a caption under it, for `hybrid series` and the
//! report's gallery. Text is rasterised from an outline font with
//! `ab_glyph`; the font is Hack (MIT and Bitstream Vera licences), which
//! the `epaint_default_fonts` crate carries, so no font file lives in this
//! repository and none is looked up on the machine.

use std::path::Path;

use ab_glyph::{point, Font, FontRef, GlyphId, PxScale, ScaleFont};
use image::{Rgb, RgbImage};

const BACKGROUND: Rgb<u8> = Rgb([255, 255, 255]);
const INK: Rgb<u8> = Rgb([25, 25, 25]);
const GAP: u32 = 8;

/// Pixel height of captions and of the title.
const CAPTION_PX: f32 = 15.0;
const TITLE_PX: f32 = 18.0;
/// Smallest size text shrinks to when it is wider than its space.
const SMALLEST_PX: f32 = 8.0;

fn font() -> FontRef<'static> {
    FontRef::try_from_slice(epaint_default_fonts::HACK_REGULAR)
        .expect("the font shipped with epaint_default_fonts parses")
}

/// The glyphs of `text` set at `px` from x = 0 with kerning: each glyph and
/// its pen position, and the pen position after the last.
fn layout(font: &FontRef, px: f32, text: &str) -> (Vec<(GlyphId, f32)>, f32) {
    let scaled = font.as_scaled(PxScale::from(px));
    let mut x = 0.0;
    let mut previous = None;
    let mut glyphs = Vec::with_capacity(text.len());
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(p) = previous {
            x += scaled.kern(p, id);
        }
        glyphs.push((id, x));
        x += scaled.h_advance(id);
        previous = Some(id);
    }
    (glyphs, x)
}

/// Width in pixels of `text` set at `px`.
fn text_width(font: &FontRef, px: f32, text: &str) -> f32 {
    layout(font, px, text).1
}

/// The size at which `text` fits in `width` pixels: `px`, or smaller.
fn fitting_px(font: &FontRef, px: f32, text: &str, width: u32) -> f32 {
    let w = text_width(font, px, text);
    if w <= width as f32 {
        px
    } else {
        (px * width as f32 / w).max(SMALLEST_PX)
    }
}

/// Draws `text` at `px` centred in the band `x0..x0 + width` with its top at
/// `top`, blending ink by each pixel's coverage; what falls outside the
/// image is clipped.
fn draw_centred(
    img: &mut RgbImage,
    font: &FontRef,
    px: f32,
    text: &str,
    x0: u32,
    width: u32,
    top: u32,
) {
    let px = fitting_px(font, px, text, width);
    let (glyphs, text_w) = layout(font, px, text);
    let left = x0 as f32 + ((width as f32 - text_w) / 2.0).max(0.0);
    let baseline = top as f32 + font.as_scaled(PxScale::from(px)).ascent();
    for (id, x) in glyphs {
        let glyph = id.with_scale_and_position(PxScale::from(px), point(left + x, baseline));
        let Some(outline) = font.outline_glyph(glyph) else {
            continue;
        };
        let bounds = outline.px_bounds();
        outline.draw(|gx, gy, coverage| {
            let (px_x, px_y) = (
                bounds.min.x as i64 + gx as i64,
                bounds.min.y as i64 + gy as i64,
            );
            if px_x < 0 || px_y < 0 || px_x >= img.width() as i64 || px_y >= img.height() as i64 {
                return;
            }
            let p = img.get_pixel_mut(px_x as u32, px_y as u32);
            let a = coverage.clamp(0.0, 1.0);
            for ch in 0..3 {
                p.0[ch] = (p.0[ch] as f32 * (1.0 - a) + INK.0[ch] as f32 * a).round() as u8;
            }
        });
    }
}

/// Line height of text set at `px`.
fn line_height(font: &FontRef, px: f32) -> u32 {
    let scaled = font.as_scaled(PxScale::from(px));
    (scaled.ascent() - scaled.descent()).ceil() as u32 + 4
}

/// A contact sheet: `tiles` (equally sized) in rows of `columns`, each with
/// its caption under it, and a title line over them (none when empty).
pub fn sheet(
    title: &str,
    tiles: &[(RgbImage, String)],
    columns: usize,
) -> Result<RgbImage, String> {
    let Some((first, _)) = tiles.first() else {
        return Err("a contact sheet needs at least one image".into());
    };
    let (w, h) = first.dimensions();
    if let Some((odd, _)) = tiles.iter().find(|(t, _)| t.dimensions() != (w, h)) {
        return Err(format!(
            "contact sheet tiles differ in size: {w}x{h} and {}x{}",
            odd.width(),
            odd.height()
        ));
    }
    let font = font();
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
        image::imageops::replace(&mut out, img, x as i64, y as i64);
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
    fn text_wider_than_its_tile_shrinks_to_fit() {
        let font = font();
        let text = "a caption far too long for a tile of forty pixels";
        let px = fitting_px(&font, CAPTION_PX, text, 200);
        assert!(px < CAPTION_PX);
        assert!(text_width(&font, px, text) <= 200.5 || px == SMALLEST_PX);
    }
}

//! Text set into images: captions of contact sheets and the rate image's
//! legend. Glyphs are rasterised from an outline font with `ab_glyph`; the
//! font is Hack (MIT and Bitstream Vera licences), which the
//! `epaint_default_fonts` crate carries, so no font file lives in this
//! repository and none is looked up on the machine.

use ab_glyph::{point, Font, FontRef, GlyphId, PxScale, ScaleFont};
use image::{Rgb, RgbImage};

/// The colour text is set in.
pub const INK: Rgb<u8> = Rgb([25, 25, 25]);
/// Smallest size text shrinks to when it is wider than its space.
pub const SMALLEST_PX: f32 = 8.0;

pub fn font() -> FontRef<'static> {
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
pub fn text_width(font: &FontRef, px: f32, text: &str) -> f32 {
    layout(font, px, text).1
}

/// The size at which `text` fits in `width` pixels: `px`, or smaller.
pub fn fitting_px(font: &FontRef, px: f32, text: &str, width: u32) -> f32 {
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
pub fn draw_centred(
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
pub fn line_height(font: &FontRef, px: f32) -> u32 {
    let scaled = font.as_scaled(PxScale::from(px));
    (scaled.ascent() - scaled.descent()).ceil() as u32 + 4
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_wider_than_its_tile_shrinks_to_fit() {
        let font = font();
        let text = "a caption far too long for a tile of forty pixels";
        let px = fitting_px(&font, 15.0, text, 200);
        assert!(px < 15.0);
        assert!(text_width(&font, px, text) <= 200.5 || px == SMALLEST_PX);
    }
}

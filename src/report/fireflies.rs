//! Fireflies: isolated pixels far brighter than their surroundings, the
//! signature of rare high-weight paths.

/// [`count_fireflies`] on a film's luminance.
pub fn film_fireflies(film: &crate::render::film::Film, factor: f32) -> usize {
    let luminance: Vec<f32> = film
        .pixels
        .iter()
        .map(|&p| crate::geom::sampling::luminance(p))
        .collect();
    count_fireflies(
        &luminance,
        film.width as usize,
        film.height as usize,
        factor,
    )
}

/// Pixels of a `width` x `height` luminance image that exceed `factor`
/// times the median of their 5x5 neighbourhood (clipped at the borders).
/// A neighbourhood whose median is 0 counts any positive pixel.
pub fn count_fireflies(luminance: &[f32], width: usize, height: usize, factor: f32) -> usize {
    firefly_pixels(luminance, width, height, factor).len()
}

/// Where [`count_fireflies`] finds them, as `(x, y)`.
pub fn firefly_pixels(
    luminance: &[f32],
    width: usize,
    height: usize,
    factor: f32,
) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut window = Vec::with_capacity(25);
    for y in 0..height {
        for x in 0..width {
            window.clear();
            for yy in y.saturating_sub(2)..(y + 3).min(height) {
                for xx in x.saturating_sub(2)..(x + 3).min(width) {
                    window.push(luminance[yy * width + xx]);
                }
            }
            window.sort_by(f32::total_cmp);
            let median = window[window.len() / 2];
            let v = luminance[y * width + x];
            if v > factor * median && v > 0.0 {
                out.push((x, y));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_an_isolated_bright_pixel_and_nothing_in_a_gradient() {
        let (w, h) = (9, 7);
        let mut img: Vec<f32> = (0..w * h).map(|i| 1.0 + (i % w) as f32 * 0.1).collect();
        assert_eq!(count_fireflies(&img, w, h, 10.0), 0);
        img[3 * w + 4] = 50.0;
        assert_eq!(count_fireflies(&img, w, h, 10.0), 1);
    }
}

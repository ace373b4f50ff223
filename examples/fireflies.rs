//! Developer tool: counts fireflies in EXR renders, pixels whose luminance
//! exceeds 10x the median of their 5x5 neighbourhood.
//! `cargo run --release --example fireflies -- a.exr b.exr ...`
//! (`FACTOR=2` for another threshold, `SHOW=1` to list the pixels)

use hybrid::geom::sampling::luminance;
use hybrid::report::fireflies::count_fireflies;

fn main() {
    let factor: f32 = std::env::var("FACTOR")
        .ok()
        .and_then(|f| f.parse().ok())
        .unwrap_or(10.0);
    for path in std::env::args().skip(1) {
        let img = match image::open(&path) {
            Ok(img) => img.to_rgb32f(),
            Err(e) => {
                eprintln!("{path}: {e}");
                std::process::exit(2);
            }
        };
        let (w, h) = img.dimensions();
        let luminance: Vec<f32> = img
            .pixels()
            .map(|p| luminance(glam::Vec3::from(p.0)))
            .collect();
        let n = count_fireflies(&luminance, w as usize, h as usize, factor);
        println!(
            "{path}: {n} pixels over {factor}x their 5x5 median, of {}",
            w * h
        );
        if std::env::var_os("SHOW").is_some() {
            let at = hybrid::report::fireflies::firefly_pixels(
                &luminance, w as usize, h as usize, factor,
            );
            println!("  {:?}", &at[..at.len().min(40)]);
        }
    }
}

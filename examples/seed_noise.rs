//! Developer tool: the seed-to-seed noise of two EXR renders of one scene
//! at two seeds (issue 47's measure): the root mean square of their
//! per-channel difference over the image and, given `X0 Y0 X1 Y1`, over
//! that rectangle of pixels (x0..x1, y0..y1), divided by sqrt(2) so that
//! it reads as one render's noise.
//! `cargo run --release --example seed_noise -- a.exr b.exr [X0 Y0 X1 Y1]`

use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() != 2 && args.len() != 6 {
        eprintln!("usage: seed_noise A.exr B.exr [X0 Y0 X1 Y1]");
        return ExitCode::from(2);
    }
    let open = |path: &str| image::open(path).map(|i| i.to_rgb32f());
    let (a, b) = match (open(&args[0]), open(&args[1])) {
        (Ok(a), Ok(b)) => (a, b),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("seed_noise: {e}");
            return ExitCode::from(2);
        }
    };
    if a.dimensions() != b.dimensions() {
        eprintln!("seed_noise: the images differ in size");
        return ExitCode::from(2);
    }
    let (w, h) = a.dimensions();
    let rect: Vec<u32> = args[2..].iter().filter_map(|v| v.parse().ok()).collect();
    if rect.len() != args.len() - 2 {
        eprintln!("seed_noise: X0 Y0 X1 Y1 must be pixel numbers");
        return ExitCode::from(2);
    }
    let noise = |x0: u32, y0: u32, x1: u32, y1: u32| {
        let (mut sum, mut n) = (0.0f64, 0u64);
        for y in y0..y1.min(h) {
            for x in x0..x1.min(w) {
                let (p, q) = (a.get_pixel(x, y).0, b.get_pixel(x, y).0);
                for c in 0..3 {
                    let d = f64::from(p[c] - q[c]);
                    sum += d * d;
                    n += 1;
                }
            }
        }
        (sum / n.max(1) as f64 / 2.0).sqrt()
    };
    print!("image {:.5}", noise(0, 0, w, h));
    if let [x0, y0, x1, y1] = rect[..] {
        print!(" rect {:.5}", noise(x0, y0, x1, y1));
    }
    println!();
    ExitCode::SUCCESS
}

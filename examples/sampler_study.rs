//! Developer tool: the report's sampler study alone.
//! `cargo run --release --example sampler_study -- SCENES_DIR [quick]`.

use hybrid::report::sampler;

fn main() {
    let mut args = std::env::args().skip(1);
    let dir = args.next().unwrap_or_else(|| "../shared/scenes".into());
    let quick = args.next().is_some_and(|a| a == "quick");
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    match sampler::measure(std::path::Path::new(&dir), quick, threads) {
        Ok(study) => print!("{}", sampler::markdown(&study)),
        Err(e) => {
            eprintln!("sampler_study: {e}");
            std::process::exit(1)
        }
    }
}

//! Writes the project's demonstration sky, a small bright sun over a blue
//! sky (`scene::generate::demo_sky`), as an equirectangular EXR for `-e`:
//! `cargo run --release --example sky_map -- sky.exr`
//! then `hybrid render ../shared/scenes/sky/bunny.dae -e sky.exr -s 64 -m 3`.

use std::path::PathBuf;

fn main() {
    let Some(path) = std::env::args().nth(1).map(PathBuf::from) else {
        eprintln!("usage: sky_map OUT.exr");
        std::process::exit(2);
    };
    let sky = hybrid::scene::generate::demo_sky();
    if let Err(e) = sky.save(&path) {
        eprintln!("{e}");
        std::process::exit(2);
    }
    let (w, h) = sky.size();
    println!("wrote {} ({w} x {h})", path.display());
}

//! `hybrid merge`: combine partial renders (cells of `-p`, sample ranges
//! of `--samples`) into the image one process would have rendered.

use std::path::PathBuf;

use clap::Args;

use crate::render::film::{check_writable, rate_path, write_files, Film};
use crate::render::part::{merge, read_part};

#[derive(Args, Debug, Clone)]
pub struct MergeArgs {
    /// Output image: .png (tone-mapped as the parts were) or .exr.
    #[arg(short = 'f', required = true)]
    pub output: PathBuf,
    /// The parts: EXR files written by `hybrid render -p ... / --samples ...`.
    #[arg(required = true, value_name = "PART.exr")]
    pub parts: Vec<PathBuf>,
}

pub fn run(args: &MergeArgs) -> Result<(), String> {
    // The output's name first, then whether it would replace a part: both
    // before any part is read.
    Film::check_image_name(&args.output).map_err(|e| e.to_string())?;
    check_writable(&args.output).map_err(|e| e.to_string())?;
    for part in &args.parts {
        let same_path = std::path::absolute(&args.output).ok() == std::path::absolute(part).ok();
        if same_path || super::render::same_file(&args.output, part) {
            return Err(format!(
                "-f {} is also a part of this merge; it would be overwritten: give the output its own name",
                args.output.display()
            ));
        }
    }
    let parts = args
        .parts
        .iter()
        .map(|p| read_part(p))
        .collect::<Result<Vec<_>, _>>()?;
    let names: Vec<String> = args.parts.iter().map(|p| p.display().to_string()).collect();
    let (film, map) = merge(&parts, &names)?;
    let image = film.file(&args.output, map).map_err(|e| e.to_string())?;
    if film.origin.adaptive.is_some() {
        let rate = rate_path(&args.output);
        check_writable(&rate).map_err(|e| e.to_string())?;
        write_files(&[(&args.output, image), (&rate, film.rate_file())])
            .map_err(|e| e.to_string())?;
    } else {
        write_files(&[(&args.output, image)]).map_err(|e| e.to_string())?;
    }
    say!(
        "merged {} parts into {}x{} at {} spp: wrote {}",
        parts.len(),
        film.width,
        film.height,
        film.origin.total,
        args.output.display()
    );
    Ok(())
}

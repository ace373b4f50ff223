//! `hybrid series`: one scene rendered over a list of values of one option,
//! written as the single images and one labelled contact sheet (the value
//! and render time under each tile, the fixed options in the title), so a
//! write-up's figure is one command.

use std::path::{Path, PathBuf};

use clap::{Args, Parser};

use super::render::{render_with, RenderArgs};
use crate::render::film::{check_writable, write_files, ImageFile};
use crate::report::gallery::image;
use crate::report::sheet::sheet;

/// Render options that take one value but that a series does not vary:
/// where files go (`-f` names the sheet, `--save-camera` writes a camera
/// file), which part of a frame a run renders (`--part`, `--samples`; a
/// series renders whole images), and a safety limit (`--max-scene-mb`).
const NOT_VARIED: [&str; 5] = ["f", "save-camera", "part", "samples", "max-scene-mb"];

/// Options a series can vary, as written after `--vary` (one letter: the
/// short flag; otherwise the long one): `scene`, and every render option
/// that takes one value, read from the render command's own definitions,
/// but [`NOT_VARIED`].
pub fn variable_options() -> Vec<String> {
    let mut command = <RenderArgs as clap::Args>::augment_args(clap::Command::new("render"));
    command.build();
    let mut names = vec!["scene".to_string()];
    for arg in command.get_arguments() {
        let one_value = arg
            .get_num_args()
            .is_some_and(|n| n.min_values() == 1 && n.max_values() == 1);
        if arg.is_positional() || !one_value || !arg.get_action().takes_values() {
            continue;
        }
        let name = match (arg.get_short(), arg.get_long()) {
            (Some(c), _) => c.to_string(),
            (None, Some(long)) => long.to_string(),
            (None, None) => continue,
        };
        if !NOT_VARIED.contains(&name.as_str()) {
            names.push(name);
        }
    }
    names
}

#[derive(Args, Debug, Clone)]
pub struct SeriesArgs {
    /// The option and its values: `l=1,4,16,64`, `m=0..5` (both ends
    /// included), `s=1,2,4,...,1024` (continued by the ratio, or the step,
    /// of the two values before `...`), `estimator=hemisphere,light`,
    /// `accel=native,embree,none`, `scene=a.dae,b.dae`. With `-a`, each
    /// render's sample-rate image follows it on the sheet.
    #[arg(long, value_name = "OPTION=VALUES")]
    pub vary: String,
    /// Tiles per row of the contact sheet (default: up to 4).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=64))]
    pub columns: Option<u16>,
    /// The render options every tile shares; `-f` names the contact sheet
    /// (default: SCENE_OPTION.png), the single images go beside it as
    /// SHEET_VALUE.png.
    #[command(flatten)]
    pub render: RenderArgs,
}

/// One value's command line parsed again, the value's flag last so that it
/// overrides the shared one.
#[derive(Parser, Debug)]
#[command(name = "hybrid series", args_override_self = true)]
struct Variant {
    #[command(flatten)]
    series: SeriesArgs,
}

/// The most values one series renders (ranges and lists alike).
const MAX_VALUES: usize = 64;

/// `NAME=VALUES` as the name and the list of values.
pub fn parse_vary(text: &str) -> Result<(String, Vec<String>), String> {
    let bad = |why: &str| format!("--vary {text}: {why}");
    let (name, values) = text
        .split_once('=')
        .ok_or_else(|| bad("expected OPTION=VALUES, e.g. l=1,4,16,64"))?;
    let name = name.trim().trim_start_matches('-').to_string();
    let variable = variable_options();
    if !variable.contains(&name) {
        return Err(bad(&format!(
            "'{name}' is not an option a series varies (one of {})",
            variable.join(", ")
        )));
    }
    let values = values.trim();
    let list: Vec<String> = if let Some((a, b)) =
        values.split_once("..").filter(|_| !values.contains(','))
    {
        let (a, b): (i64, i64) = match (a.trim().parse(), b.trim().parse()) {
            (Ok(a), Ok(b)) if a <= b && b - a < 64 => (a, b),
            _ => {
                return Err(bad(
                    "expected A..B with whole numbers A <= B, at most 64 values",
                ))
            }
        };
        (a..=b).map(|v| v.to_string()).collect()
    } else {
        let parts: Vec<&str> = values.split(',').map(str::trim).collect();
        match parts.iter().position(|p| *p == "...") {
            None => parts.iter().map(|p| p.to_string()).collect(),
            Some(at) => continued(&parts, at).ok_or_else(|| {
                bad("'...' needs two numbers before it and one after, e.g. 1,2,4,...,1024 (at most 64 values)")
            })?,
        }
    };
    if list.is_empty() || list.iter().any(|v| v.is_empty()) {
        return Err(bad("an empty value"));
    }
    // A sheet of more tiles is unreadable, and each value is a render.
    if list.len() > MAX_VALUES {
        return Err(bad(&format!(
            "{} values; a series takes at most {MAX_VALUES}",
            list.len()
        )));
    }
    Ok((name, list))
}

/// `a, b, ..., z` continued geometrically when b / a is a whole ratio
/// above 1, else arithmetically by b - a, up to z.
fn continued(parts: &[&str], at: usize) -> Option<Vec<String>> {
    if at < 2 || at + 2 != parts.len() {
        return None;
    }
    let number = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite());
    let (a, b, end) = (
        number(parts[at - 2])?,
        number(parts[at - 1])?,
        number(parts[at + 1])?,
    );
    if b <= a {
        return None;
    }
    let mut out: Vec<String> = parts[..at].iter().map(|p| p.to_string()).collect();
    let geometric = a > 0.0 && (b / a).fract() == 0.0;
    let next = |v: f64| if geometric { v * (b / a) } else { v + (b - a) };
    let mut v = next(b);
    while v <= end + 1e-9 && out.len() < 64 {
        out.push(format_number(v));
        v = next(v);
    }
    (out.last().map(String::as_str) == Some(&format_number(end))).then_some(out)
}

/// A render time as a caption shows it: milliseconds under a second.
fn duration(seconds: f64) -> String {
    if seconds < 1.0 {
        format!("{:.0} ms", seconds * 1e3)
    } else {
        format!("{seconds:.2} s")
    }
}

fn format_number(v: f64) -> String {
    if v.fract() == 0.0 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}

/// The flag that sets option `name`.
fn flag(name: &str) -> String {
    if name.len() == 1 {
        format!("-{name}")
    } else {
        format!("--{name}")
    }
}

/// The shared options as typed, without the series' own (`--vary`,
/// `--columns`, `-f`) and the scene: the sheet's title.
fn fixed_options(raw: &[String], scene: Option<&Path>) -> String {
    let mut out = Vec::new();
    let mut i = 0;
    while i < raw.len() {
        let a = raw[i].as_str();
        if matches!(a, "--vary" | "--columns" | "-f") {
            i += 2;
            continue;
        }
        if a.starts_with("--vary=") || a.starts_with("--columns=") || scene == Some(Path::new(a)) {
            i += 1;
            continue;
        }
        out.push(a.to_string());
        i += 1;
    }
    out.join(" ")
}

pub fn run(args: &SeriesArgs, raw: &[String]) -> Result<(), String> {
    let (name, values) = parse_vary(&args.vary)?;
    let scene_name = match name.as_str() {
        "scene" => "scenes".to_string(),
        _ => args
            .render
            .input
            .scene
            .as_ref()
            .and_then(|p| p.file_name())
            .and_then(|s| s.to_str())
            .unwrap_or("cornell.dae")
            .to_string(),
    };
    let sheet_path = args.render.output.clone().unwrap_or_else(|| {
        PathBuf::from(format!(
            "{}_{name}.png",
            scene_name.trim_end_matches(".dae")
        ))
    });
    if sheet_path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
        != Some("png")
    {
        return Err(format!(
            "{}: a contact sheet is a .png",
            sheet_path.display()
        ));
    }
    check_writable(&sheet_path).map_err(|e| e.to_string())?;
    let stem = sheet_path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("series")
        .to_string();
    let single = |value: &str| {
        sheet_path.with_file_name(format!("{stem}_{}.png", value.replace(['/', ' '], "_")))
    };

    // Every value's options are checked before any render.
    let mut variants = Vec::new();
    for value in &values {
        let mut argv = vec!["hybrid series".to_string()];
        argv.extend(raw.iter().cloned());
        if name != "scene" {
            argv.push(flag(&name));
            argv.push(value.clone());
        }
        let mut variant = Variant::try_parse_from(&argv).map_err(|e| {
            format!(
                "--vary {name}={value}: {}",
                super::one_line(&e.render().to_string())
            )
        })?;
        if name == "scene" {
            // Every scene loads before any renders, so a bad one fails
            // first, not after the others' renders.
            let input = &mut variant.series.render.input;
            input.scene = Some(PathBuf::from(value));
            crate::scene::collada::load_limited(
                Path::new(value),
                crate::scene::NormalMode::Smooth,
                input.max_scene_mb.saturating_mul(1 << 20),
            )
            .map_err(|e| format!("--vary scene={value}: {e}"))?;
        }
        let settings = variant
            .series
            .render
            .settings()
            .map_err(|e| format!("--vary {name}={value}: {e}"))?;
        variants.push((value.clone(), variant.series.render, settings));
    }

    // The options every value shares, warned about once.
    if let Some((_, first, _)) = variants.first() {
        for warning in first.warnings() {
            super::report_line("warning", &warning);
        }
    }
    let mut tiles = Vec::new();
    let mut films = Vec::new();
    for (value, render_args, settings) in &variants {
        say!("series: {name} = {value}");
        let out = render_with(render_args, settings)?;
        say!("series: {name} = {value} rendered in {:.2} s", out.seconds);
        let shown = match name.as_str() {
            "scene" => Path::new(value)
                .file_name()
                .and_then(|f| f.to_str())
                .unwrap_or(value),
            _ => value,
        };
        tiles.push((
            image(&out.film, render_args.tone_map()),
            format!("{name} = {shown} · {}", duration(out.seconds)),
        ));
        // Adaptive sampling: the rate image follows its render.
        if settings.adaptive.is_some() {
            let rate = out.film.rate_image();
            tiles.push((rate, format!("rate · {:.0} spp mean", out.mean_samples())));
        }
        films.push((
            single(shown.trim_end_matches(".dae")),
            out.film,
            render_args.tone_map(),
        ));
    }
    let mut fixed = fixed_options(raw, args.render.input.scene.as_deref());
    // Without a scene the default scene's converged settings fill in what
    // was not given (as for `hybrid render`); the title says which.
    let preset = variants
        .first()
        .map(|(_, r, _)| r.preset_options())
        .unwrap_or_default();
    if !preset.is_empty() {
        say!("series: the default scene with converged settings: {preset}");
        if !fixed.is_empty() {
            fixed.push(' ');
        }
        fixed += &preset;
    }
    let title = format!(
        "{scene_name} · {} · varying {}",
        if fixed.is_empty() {
            "defaults".to_string()
        } else {
            fixed
        },
        if name == "scene" {
            name.clone()
        } else {
            flag(&name)
        }
    );
    let columns = args.columns.map_or(
        match tiles.len() {
            n @ 0..=4 => n,
            5 | 6 => 3,
            _ => 4,
        },
        usize::from,
    );
    let contact = sheet(&title, &tiles, columns)?;
    let mut files = Vec::new();
    for (path, film, map) in &films {
        files.push((
            path.as_path(),
            film.file(path, *map).map_err(|e| e.to_string())?,
        ));
    }
    files.push((sheet_path.as_path(), ImageFile::Picture(&contact)));
    write_files(&files).map_err(|e| e.to_string())?;
    say!(
        "wrote the contact sheet {} ({} tiles) and {}",
        sheet_path.display(),
        tiles.len(),
        films
            .iter()
            .map(|(p, _, _)| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_lists_inclusive_ranges_or_continued_sequences() {
        let v = |t: &str| parse_vary(t).map(|(n, v)| (n, v.join(" ")));
        assert_eq!(v("l=1,4,16,64").unwrap(), ("l".into(), "1 4 16 64".into()));
        assert_eq!(v("m=0..5").unwrap().1, "0 1 2 3 4 5");
        assert_eq!(
            v("s=1,2,4,...,1024").unwrap().1,
            "1 2 4 8 16 32 64 128 256 512 1024"
        );
        assert_eq!(v("m=0,2,...,8").unwrap().1, "0 2 4 6 8");
        assert_eq!(
            v("estimator=hemisphere,light").unwrap().1,
            "hemisphere light"
        );
        assert!(v("x=1,2")
            .unwrap_err()
            .contains("not an option a series varies"));
        assert!(
            v("s=1,2,4,...,1000").is_err(),
            "1000 is not in the sequence"
        );
        assert!(v("l").is_err());
        assert!(v("m=5..0").is_err());
    }

    #[test]
    fn the_title_keeps_the_shared_options_only() {
        let raw: Vec<String> = [
            "scene.dae",
            "-s",
            "64",
            "--vary",
            "m=0..5",
            "-f",
            "x.png",
            "--columns",
            "3",
            "-l",
            "4",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        assert_eq!(
            fixed_options(&raw, Some(Path::new("scene.dae"))),
            "-s 64 -l 4"
        );
    }

    #[test]
    fn the_variable_options_are_the_render_options_of_one_value() {
        let names = variable_options();
        for wanted in [
            "scene",
            "s",
            "l",
            "m",
            "rr",
            "estimator",
            "accel",
            "crease",
            "e",
        ] {
            assert!(
                names.iter().any(|n| n == wanted),
                "{wanted} missing from {names:?}"
            );
        }
        // Output names, partial renders, switches and two-value options.
        for refused in [
            "f", "samples", "part", "flat", "normals", "r", "a", "p", "help",
        ] {
            assert!(
                !names.iter().any(|n| n == refused),
                "{refused} in {names:?}"
            );
        }
    }
}

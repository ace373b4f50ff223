//! `hybrid series`: one scene rendered over a list of values of one option,
//! written as the single images and one labelled contact sheet (the value
//! and render time under each tile, the fixed options in the title), so a
//! write-up's figure is one command.

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use clap::{Args, Parser};

use super::render::{render_with, ExposureArg, RenderArgs};
use crate::render::film::{check_writable, rate_path, write_files, ImageFile, ToneMap};
use crate::report::gallery::image;
use crate::report::sheet::sheet;

mod vary;

use self::vary::{axes, fixed_options, flag, shown_values, Axis};

/// Render options that take one value but that a series does not vary:
/// where files go (`-f` names the sheet, `--save-camera` writes a camera
/// file), which part of a frame a run renders (`--part`, `--samples`; a
/// series renders whole images), and a safety limit (`--max-scene-mb`).
/// (`--mitsuba`, one render's scene for another renderer, is refused.)
const NOT_VARIED: [&str; 6] = [
    "f",
    "save-camera",
    "mitsuba",
    "part",
    "samples",
    "max-scene-mb",
];

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
    /// `accel=native,embree,none`, `scene=a.dae,b.dae`. Given twice, every
    /// pair is rendered: the first option down the sheet, the second
    /// across (`--vary scene=a.dae,b.dae --vary accel=native,none`: the
    /// with-and-without-BVH table). With `-a`, each render's sample-rate
    /// image follows it on the sheet.
    #[arg(long, value_name = "OPTION=VALUES", required = true)]
    pub vary: Vec<String>,
    /// Tiles per row of the contact sheet (default: up to 4; with two
    /// options, the second one's values).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=64))]
    pub columns: Option<u16>,
    /// The render options every tile shares; `-f` names the contact sheet
    /// (default: SCENE_OPTION.png), the single images go beside it as
    /// SHEET_VALUE.png (SHEET_VALUE_rate.png with -a), the times as
    /// SHEET.md and SHEET.csv.
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

/// One render of a series: its values (one per axis), options and results.
struct Tile {
    values: Vec<String>,
    render: RenderArgs,
    settings: crate::render::RenderSettings,
}

/// What one render measured, for the sheet's captions and the tables.
struct Timed {
    values: Vec<String>,
    triangles: usize,
    build_seconds: f64,
    render_seconds: f64,
    mean_samples: f64,
}

/// What a series renders and writes, decided and checked before any
/// render: every tile's options parsed, every varied scene loaded, every
/// output name distinct and writable.
struct Plan {
    axes: Vec<Axis>,
    scene_name: String,
    sheet_path: PathBuf,
    stem: String,
    tiles: Vec<Tile>,
}

impl Plan {
    /// The file beside the sheet whose name ends in `suffix`.
    fn beside(&self, suffix: &str) -> PathBuf {
        self.sheet_path
            .with_file_name(format!("{}{suffix}", self.stem))
    }

    /// The image file of the tile showing `shown`.
    fn single(&self, shown: &[&str]) -> PathBuf {
        let key: Vec<String> = shown.iter().map(|v| v.replace(['/', ' '], "_")).collect();
        self.beside(&format!("_{}.png", key.join("_")))
    }
}

/// Checks a series' command line as [`run`] does before its first render
/// (for `cli::check_command_line`, which the fuzz target calls).
pub fn check(args: &SeriesArgs, raw: &[OsString]) -> Result<(), String> {
    plan(args, raw).map(|_| ())
}

fn plan(args: &SeriesArgs, raw: &[OsString]) -> Result<Plan, String> {
    if args.render.mitsuba.is_some() {
        return Err(
            "--mitsuba writes the scene of one render: give it to `hybrid render`, not a series"
                .into(),
        );
    }
    let axes = axes(&args.vary)?;
    let varies_scene = axes.iter().any(|a| a.name == "scene");
    let scene_name = if varies_scene {
        "scenes".to_string()
    } else {
        args.render
            .input
            .scene
            .as_ref()
            .and_then(|p| p.file_name())
            .and_then(|s| s.to_str())
            .unwrap_or("cornell.dae")
            .to_string()
    };
    let names: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
    let sheet_path = args.render.output.clone().unwrap_or_else(|| {
        PathBuf::from(format!(
            "{}_{}.png",
            scene_name.trim_end_matches(".dae"),
            names.join("_")
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

    // Every render's options are checked, and every scene loaded, before
    // any render, so a bad value fails first.
    let combinations: Vec<Vec<String>> = match axes.as_slice() {
        [a] => a.values.iter().map(|v| vec![v.clone()]).collect(),
        [a, b] => a
            .values
            .iter()
            .flat_map(|v| b.values.iter().map(move |w| vec![v.clone(), w.clone()]))
            .collect(),
        _ => return Err("--vary: expected one or two options".into()),
    };
    if varies_scene {
        let axis = axes.iter().find(|a| a.name == "scene").expect("varied");
        for value in &axis.values {
            crate::scene::collada::load_limited(
                Path::new(value),
                crate::scene::NormalMode::Smooth,
                args.render.input.max_scene_mb.saturating_mul(1 << 20),
            )
            .map_err(|e| format!("--vary scene={value}: {e}"))?;
        }
    }
    let mut tiles = Vec::new();
    for values in &combinations {
        // The command line as given (file names need not be UTF-8), then
        // this tile's values.
        let mut argv = vec![OsString::from("hybrid series")];
        argv.extend(raw.iter().cloned());
        for (axis, value) in axes.iter().zip(values) {
            if axis.name != "scene" {
                argv.push(flag(&axis.name).into());
                argv.push(value.into());
            }
        }
        let what = axes
            .iter()
            .zip(values)
            .map(|(a, v)| format!("{}={v}", a.name))
            .collect::<Vec<_>>()
            .join(" ");
        let mut variant = Variant::try_parse_from(&argv).map_err(|e| {
            format!(
                "--vary {what}: {}",
                super::one_line(&e.render().to_string())
            )
        })?;
        for (axis, value) in axes.iter().zip(values) {
            if axis.name == "scene" {
                variant.series.render.input.scene = Some(PathBuf::from(value));
            }
        }
        let settings = variant
            .series
            .render
            .settings()
            .map_err(|e| format!("--vary {what}: {e}"))?;
        tiles.push(Tile {
            values: values.clone(),
            render: variant.series.render,
            settings,
        });
    }

    let plan = Plan {
        axes,
        scene_name,
        sheet_path,
        stem,
        tiles,
    };
    // Every file the series will write, checked before any render: each
    // name distinct (two scenes of one file name, a value given twice) and
    // writable (no directory, link or device in the way).
    let mut outputs: Vec<PathBuf> = Vec::new();
    for tile in &plan.tiles {
        let shown = shown_values(&plan.axes, &tile.values);
        let path = plan.single(&shown);
        if tile.settings.adaptive.is_some() {
            outputs.push(rate_path(&path));
        }
        outputs.push(path);
    }
    outputs.extend([
        plan.sheet_path.clone(),
        plan.beside(".md"),
        plan.beside(".csv"),
    ]);
    for (k, path) in outputs.iter().enumerate() {
        if outputs[..k].contains(path) {
            return Err(format!(
                "{}: two of the series' files would have this name (a value given twice, or two scenes of one file name): give distinct values",
                path.display()
            ));
        }
        check_writable(path).map_err(|e| e.to_string())?;
    }
    Ok(plan)
}

/// Renders a series: every tile, then the sheet, its tables and each
/// tile's image, all written together once every render is done.
pub fn run(args: &SeriesArgs, raw: &[OsString]) -> Result<(), String> {
    let plan = plan(args, raw)?;
    let Plan {
        axes,
        scene_name,
        sheet_path,
        tiles,
        ..
    } = &plan;

    // The options every value shares, warned about once.
    if let Some(first) = tiles.first() {
        for warning in first.render.warnings() {
            super::report_line("warning", &warning);
        }
    }
    let mut pictures = Vec::new();
    let mut films = Vec::new();
    let mut timed = Vec::new();
    for tile in tiles {
        let shown = shown_values(axes, &tile.values);
        let what = axes
            .iter()
            .zip(&shown)
            .map(|(a, v)| format!("{} = {v}", a.name))
            .collect::<Vec<_>>()
            .join(", ");
        say!("series: {what}");
        // With two options the title names them; a caption gives values.
        let caption = if axes.len() == 1 {
            what.clone()
        } else {
            shown.join(" · ")
        };
        let rendered = render_with(&tile.render, &tile.settings)?;
        let out = &rendered.output;
        say!(
            "series: {what}: built in {}, rendered in {} (wall clock)",
            super::duration(rendered.build_seconds),
            super::duration(out.seconds)
        );
        let map = tile.render.tone_map(&out.film);
        let exposure = match (tile.render.exposure, map) {
            (Some(ExposureArg::Auto), ToneMap::Reference(e)) => format!(" · {}", e.label()),
            _ => String::new(),
        };
        pictures.push((
            image(&out.film, map),
            format!(
                "{caption}{exposure} · {} + {}",
                super::duration(rendered.build_seconds),
                super::duration(out.seconds)
            ),
        ));
        let path = plan.single(&shown);
        // Adaptive sampling: the rate image follows its render, on the
        // sheet and as its own file.
        let rate = tile.settings.adaptive.is_some().then(|| {
            pictures.push((
                out.film.rate_image(),
                format!("rate · {:.0} spp mean", out.mean_samples()),
            ));
            rate_path(&path)
        });
        timed.push(Timed {
            values: shown.iter().map(|v| v.to_string()).collect(),
            triangles: rendered.triangles,
            build_seconds: rendered.build_seconds,
            render_seconds: out.seconds,
            mean_samples: out.mean_samples(),
        });
        films.push((path, rate, rendered.output.film, map));
    }
    let lossy: Vec<String> = raw
        .iter()
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    let mut fixed = fixed_options(&lossy, args.render.input.scene.as_deref());
    // Without a scene the default scene's converged settings fill in what
    // was not given (as for `hybrid render`); the title says which.
    let preset = tiles
        .first()
        .map(|t| t.render.preset_options())
        .unwrap_or_default();
    if !preset.is_empty() {
        say!("series: the default scene with converged settings: {preset}");
        if !fixed.is_empty() {
            fixed.push(' ');
        }
        fixed += &preset;
    }
    let title = format!(
        "{scene_name} · {} · varying {} · times: build + render, wall clock",
        if fixed.is_empty() {
            "defaults".to_string()
        } else {
            fixed
        },
        axes.iter().map(Axis::flag).collect::<Vec<_>>().join(" by ")
    );
    let per_tile = if tiles.first().is_some_and(|t| t.settings.adaptive.is_some()) {
        2
    } else {
        1
    };
    let columns = args.columns.map_or(
        match (axes.as_slice(), pictures.len()) {
            ([_, b], _) => b.values.len() * per_tile,
            (_, n @ 0..=4) => n,
            (_, 5 | 6) => 3,
            _ => 4,
        },
        usize::from,
    );
    let contact = sheet(&title, &pictures, columns)?;
    let (markdown, csv) = tables(axes, &timed, &title);
    let (md_path, csv_path) = (plan.beside(".md"), plan.beside(".csv"));
    let mut files = Vec::new();
    for (path, rate, film, map) in &films {
        files.push((
            path.as_path(),
            film.file(path, *map).map_err(|e| e.to_string())?,
        ));
        if let Some(rate) = rate {
            files.push((rate.as_path(), film.rate_file()));
        }
    }
    files.push((sheet_path.as_path(), ImageFile::Picture(&contact)));
    files.push((md_path.as_path(), ImageFile::Text(&markdown)));
    files.push((csv_path.as_path(), ImageFile::Text(&csv)));
    write_files(&files).map_err(|e| e.to_string())?;
    say!(
        "wrote the contact sheet {} ({} tiles), the times {} and {}, and {}",
        sheet_path.display(),
        pictures.len(),
        md_path.display(),
        csv_path.display(),
        films
            .iter()
            .flat_map(|(p, r, _, _)| std::iter::once(p).chain(r))
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}

/// The series' times as Markdown and CSV. Markdown: one row per value of
/// the first option (with its triangles when it is the scene), and with
/// two options one column pair (build, render) per value of the second.
/// CSV: one line per render.
fn tables(axes: &[Axis], timed: &[Timed], title: &str) -> (String, String) {
    let ms = |s: f64| format!("{:.3}", s * 1e3);
    let mut csv = axes
        .iter()
        .map(|a| a.name.clone())
        .chain(["triangles", "build_ms", "render_ms", "total_ms", "mean_spp"].map(String::from))
        .collect::<Vec<_>>()
        .join(",");
    csv.push('\n');
    for t in timed {
        let quoted: Vec<String> = t
            .values
            .iter()
            .map(|v| {
                if v.contains([',', '"']) {
                    format!("\"{}\"", v.replace('"', "\"\""))
                } else {
                    v.clone()
                }
            })
            .collect();
        csv += &format!(
            "{},{},{},{},{},{:.2}\n",
            quoted.join(","),
            t.triangles,
            ms(t.build_seconds),
            ms(t.render_seconds),
            ms(t.build_seconds + t.render_seconds),
            t.mean_samples
        );
    }
    let first = &axes[0];
    let with_triangles = first.name == "scene";
    let mut md = format!("{title}\n\n");
    let mut header = vec![first.name.clone()];
    if with_triangles {
        header.push("triangles".into());
    }
    let columns: Vec<Option<&String>> = match axes.get(1) {
        Some(b) => b.values.iter().map(Some).collect(),
        None => vec![None],
    };
    for c in &columns {
        let prefix = c.map_or(String::new(), |v| {
            format!("{} = {} ", axes[1].name, axes[1].shown(v))
        });
        header.push(format!("{prefix}build"));
        header.push(format!("{prefix}render"));
    }
    md += &format!("| {} |\n", header.join(" | "));
    md += &format!("|{}\n", " --- |".repeat(header.len()));
    let time = |s: f64| super::duration(s);
    for value in &first.values {
        let shown = first.shown(value);
        let row: Vec<&Timed> = timed.iter().filter(|t| t.values[0] == shown).collect();
        let mut cells = vec![shown.to_string()];
        if with_triangles {
            cells.push(
                row.first()
                    .map_or(String::new(), |t| t.triangles.to_string()),
            );
        }
        for t in &row {
            cells.push(time(t.build_seconds));
            cells.push(time(t.render_seconds));
        }
        md += &format!("| {} |\n", cells.join(" | "));
    }
    (md, csv)
}

#[cfg(test)]
mod tests;

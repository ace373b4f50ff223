//! The gallery: the course write-up's series rendered on the native
//! backend (normal shading, light samples, bounces, Russian roulette,
//! samples per pixel, adaptive sampling with its rate image), and the
//! direct-lighting estimators side by side on the project's own scenes.

use std::path::Path;

use image::RgbImage;

use super::budget::{Budget, NORMALS_SCENES, SAMPLES_SCENE, SERIES_SCENE};
use super::error::ESTIMATORS;
use super::fireflies::film_fireflies;
use super::sheet::write_sheet;
use super::{load, load_builtin};
use crate::accel::BackendConfig;
use crate::render::film::{Film, ToneMap};
use crate::render::integrator::{PathSettings, Shading};
use crate::render::{render, Adaptive, RenderSettings, Silent};
use crate::scene::builtin::{CORNELL, GLOSSY};
use crate::scene::Scene;

struct Shooter {
    width: u32,
    height: u32,
    threads: usize,
}

impl Shooter {
    fn film(
        &self,
        scene: &Scene,
        samples: u32,
        shading: Shading,
        adaptive: Option<Adaptive>,
    ) -> Result<Film, String> {
        let settings = RenderSettings {
            width: self.width,
            height: self.height,
            samples,
            threads: self.threads,
            seed: 1,
            shading,
            adaptive,
            ..RenderSettings::default()
        };
        let accel = BackendConfig::NATIVE
            .build(scene)
            .map_err(|e| e.to_string())?;
        Ok(render(scene, &accel, &settings, &Silent).film)
    }
}

/// A shared scene's file name without the folder and `.dae`.
fn scene_name(rel: &str) -> String {
    rel.rsplit('/')
        .next()
        .unwrap_or(rel)
        .trim_end_matches(".dae")
        .to_string()
}

pub(crate) fn image(film: &Film, map: ToneMap) -> RgbImage {
    RgbImage::from_raw(film.width, film.height, film.to_rgb8(map)).expect("film size")
}

fn path(max_bounces: u32, light_samples: u32) -> PathSettings {
    PathSettings {
        max_bounces,
        light_samples,
        ..PathSettings::default()
    }
}

/// Renders the gallery into `out` and returns its Markdown.
pub fn section(dir: &Path, out: &Path, budget: &Budget, threads: usize) -> Result<String, String> {
    let (width, height) = budget.gallery;
    let shooter = Shooter {
        width,
        height,
        threads,
    };
    let shoot = |scene: &Scene, samples: u32, settings: PathSettings| {
        shooter
            .film(scene, samples, Shading::Path(settings), None)
            .map(|f| image(&f, ToneMap::REFERENCE))
    };
    let series = load(dir, SERIES_SCENE)?;
    let samples_scene = load(dir, SAMPLES_SCENE)?;
    let mut md = format!("## Gallery\n\nThe course write-up's series, rendered on the native backend at {width}x{height} (the Embree images are identical, see `docs/parity.md`).\n\n");

    let normals = NORMALS_SCENES
        .iter()
        .map(|rel| {
            let s = load(dir, rel)?;
            let img = image(
                &shooter.film(&s, 4, Shading::Normals, None)?,
                ToneMap::Identity,
            );
            Ok((img, scene_name(rel)))
        })
        .collect::<Result<Vec<_>, String>>()?;
    write_sheet(&out.join("gallery_normals.png"), "--normals", &normals, 4)?;
    md += "Normal shading: CBspheres_lambertian, CBbunny, maxplanck, banana.\n\n![normals](gallery_normals.png)\n\n";

    let lights = [1, 4, 16, 64]
        .iter()
        .map(|&l| Ok((shoot(&series, 1, path(1, l))?, format!("-l {l}"))))
        .collect::<Result<Vec<_>, String>>()?;
    write_sheet(
        &out.join("gallery_light_samples.png"),
        "CBbunny · -s 1 -m 1",
        &lights,
        4,
    )?;
    md += "CBbunny, direct lighting at `-s 1` with `-l 1, 4, 16, 64`: the soft shadows' noise falls.\n\n![light samples](gallery_light_samples.png)\n\n";

    let spp = budget.gallery_spp;
    let mut bounces = Vec::new();
    for accumulate in [false, true] {
        for m in 0..=5 {
            let img = shoot(
                &series,
                spp,
                PathSettings {
                    accumulate,
                    ..path(m, 1)
                },
            )?;
            bounces.push((img, format!("-m {m} -o {}", u8::from(accumulate))));
        }
    }
    write_sheet(
        &out.join("gallery_bounces.png"),
        &format!("CBbunny · -s {spp}"),
        &bounces,
        6,
    )?;
    md += &format!("CBbunny at {spp} spp, `-m 0..5`: top row only the m-th bounce (`-o 0`), bottom row accumulated (`-o 1`).\n\n![bounces](gallery_bounces.png)\n\n");

    let rr = [0, 1, 2, 3, 4, 100]
        .iter()
        .map(|&m| {
            let img = shoot(
                &series,
                spp,
                PathSettings {
                    russian_roulette: Some(0.7),
                    ..path(m, 1)
                },
            )?;
            Ok((img, format!("-m {m}")))
        })
        .collect::<Result<Vec<_>, String>>()?;
    write_sheet(
        &out.join("gallery_russian_roulette.png"),
        &format!("CBbunny · -s {spp} --rr 0.7"),
        &rr,
        6,
    )?;
    md += "CBbunny with Russian roulette (continuation 0.7), `-m 0, 1, 2, 3, 4, 100`.\n\n![russian roulette](gallery_russian_roulette.png)\n\n";

    let by_spp = budget
        .spp_series
        .iter()
        .map(|&s| Ok((shoot(&samples_scene, s, path(3, 1))?, format!("-s {s}"))))
        .collect::<Result<Vec<_>, String>>()?;
    write_sheet(
        &out.join("gallery_samples.png"),
        "CBspheres_lambertian · -m 3",
        &by_spp,
        4,
    )?;
    md += &format!(
        "CBspheres_lambertian, 3 bounces, `-s {}`.\n\n![samples per pixel](gallery_samples.png)\n\n",
        budget
            .spp_series
            .iter()
            .map(|s| s.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );

    md += &estimators(&shooter, out, budget)?;

    let (batch, tolerance, cap) = budget.adaptive_gallery;
    let mut adaptive = Vec::new();
    let mut mean_spp = Vec::new();
    for (scene, name) in [(&series, SERIES_SCENE), (&samples_scene, SAMPLES_SCENE)] {
        let film = shooter.film(
            scene,
            cap,
            Shading::Path(path(5, 1)),
            Some(Adaptive { batch, tolerance }),
        )?;
        let mean = film.mean_samples();
        mean_spp.push(mean);
        adaptive.push((image(&film, ToneMap::REFERENCE), scene_name(name)));
        adaptive.push((film.rate_image(), format!("rate · {mean:.0} spp mean")));
    }
    write_sheet(
        &out.join("gallery_adaptive.png"),
        &format!("-a {batch} {tolerance} -s {cap} -m 5"),
        &adaptive,
        4,
    )?;
    md += &format!(
        "Adaptive sampling `-a {batch} {tolerance} -s {cap}`, 5 bounces: CBbunny and its sample rate (mean {:.0} spp), CBspheres_lambertian and its rate (mean {:.0} spp); the rate image's scale is absolute and logarithmic, blue = one batch, red = 4096 samples (its legend gives the counts).\n\n![adaptive](gallery_adaptive.png)\n",
        mean_spp[0], mean_spp[1]
    );
    Ok(md)
}

/// Light sampling against MIS (and hemisphere sampling on the glossy
/// scene) at equal samples per pixel, with each image's firefly count.
fn estimators(shooter: &Shooter, out: &Path, budget: &Budget) -> Result<String, String> {
    let (glossy_spp, cornell_spp) = budget.estimator_gallery;
    let mut md = String::new();
    // What each scene's fireflies are: the text speaks of its own scene.
    let glossy_note = "the fireflies left under MIS are edges of the light and of the box against the black outside, and the mirror sphere's small reflections of them; the speckles light sampling adds are walls lit through glossy surfaces, paths MIS finds by BSDF sampling";
    let cornell_note = "the Cornell box is diffuse with a small ceiling light, so both estimators take the same light samples and differ only where a diffuse bounce finds the light itself, which MIS weighs against the light sample; the counts say how many pixels that changes at this sample count";
    for (builtin, spp, bounces, shown, note) in [
        (GLOSSY, glossy_spp, 3, &ESTIMATORS[..], glossy_note),
        // Hemisphere sampling of the default scene's small light is noise.
        (CORNELL, cornell_spp, 5, &ESTIMATORS[1..], cornell_note),
    ] {
        let scene = load_builtin(builtin)?;
        let mut captions = Vec::new();
        let mut tiles = Vec::new();
        for (label, estimator) in shown {
            let film = shooter.film(
                &scene,
                spp,
                Shading::Path(PathSettings {
                    estimator: *estimator,
                    ..path(bounces, 1)
                }),
                None,
            )?;
            let (fireflies, speckles) = (film_fireflies(&film, 10.0), film_fireflies(&film, 2.0));
            captions.push(format!(
                "{label} ({fireflies} fireflies, {speckles} speckles)"
            ));
            tiles.push((
                image(&film, ToneMap::REFERENCE),
                format!("{label} · {fireflies} / {speckles}"),
            ));
        }
        let file = format!(
            "gallery_estimators_{}.png",
            builtin
                .name
                .trim_start_matches("dae/")
                .trim_end_matches(".dae")
        );
        write_sheet(
            &out.join(&file),
            &format!(
                "{} · -s {spp} -m {bounces} · fireflies / speckles",
                builtin.name
            ),
            &tiles,
            tiles.len(),
        )?;
        md += &format!(
            "`{}` at {spp} spp, {bounces} bounces, one light sample, left to right: {}. A firefly is a pixel brighter than 10x the median of its 5x5 neighbourhood, a speckle one brighter than 2x; {note}.\n\n![estimators]({file})\n\n",
            builtin.name,
            captions.join(", ")
        );
    }
    Ok(md)
}

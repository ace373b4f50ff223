//! The environment light: error of sampling the map by luminance against
//! sampling it uniformly, at equal samples, on a small bright sun
//! ([`demo_sky`] over [`spheres_on_a_plate`]). Direct light only: beyond
//! it, the sun's caustics off the polished sphere are found by BSDF
//! sampling alone and add the same error to both strategies.

use std::path::Path;
use std::sync::Arc;

use super::budget::Budget;
use super::error::rmse;
use super::gallery::image;
use super::sheet::write_sheet;
use super::table::{Cell, Table};
use crate::accel::BackendConfig;
use crate::render::film::{Film, ToneMap};
use crate::render::integrator::{PathSettings, Shading};
use crate::render::{render, RenderSettings, Silent};
use crate::scene::environment::EnvSampling;
use crate::scene::generate::{demo_sky, spheres_on_a_plate};
use crate::scene::Scene;

/// RMSE of both strategies at one sample count.
pub struct EnvironmentRow {
    pub spp: u32,
    pub uniform: f64,
    pub importance: f64,
}

pub struct EnvironmentStudy {
    pub resolution: (u32, u32),
    pub reference_spp: u32,
    pub rows: Vec<EnvironmentRow>,
}

fn scene_with(sampling: EnvSampling) -> Scene {
    let mut sky = demo_sky();
    sky.sampling = sampling;
    let mut scene = spheres_on_a_plate();
    scene.environment = Some(Arc::new(sky));
    scene
}

/// Measures the study and writes the two strategies' images at the
/// middle sample count side by side into `out`.
pub fn measure(budget: &Budget, threads: usize, out: &Path) -> Result<EnvironmentStudy, String> {
    let (w, h) = budget.environment_resolution;
    let importance = scene_with(EnvSampling::Importance);
    let uniform = scene_with(EnvSampling::Uniform);
    // The two scenes differ only in how the map is sampled: one BVH.
    let accel = BackendConfig::NATIVE
        .with_threads(threads)
        .build(&importance)
        .map_err(|e| e.to_string())?;
    let frame = |scene: &Scene, spp: u32, seed: u64| -> Film {
        let settings = RenderSettings {
            width: w,
            height: h,
            samples: spp,
            threads,
            seed,
            shading: Shading::Path(PathSettings {
                max_bounces: 1,
                ..PathSettings::default()
            }),
            camera: crate::render::camera::CameraMode::Node,
            ..RenderSettings::default()
        };
        render(scene, &accel, &settings, &Silent).film
    };
    let reference = frame(&importance, budget.environment_reference_spp, 424_242);
    let shown = budget.environment_spp[budget.environment_spp.len() / 2];
    let mut rows = Vec::new();
    for &spp in &budget.environment_spp {
        let u = frame(&uniform, spp, 1);
        let i = frame(&importance, spp, 1);
        if spp == shown {
            let tiles = [
                (image(&u, ToneMap::REFERENCE), "uniform".to_string()),
                (image(&i, ToneMap::REFERENCE), "by luminance".to_string()),
            ];
            write_sheet(
                &out.join("environment.png"),
                &format!("-s {spp} -m 1 · environment map sampled"),
                &tiles,
                2,
            )?;
        }
        rows.push(EnvironmentRow {
            spp,
            uniform: rmse(&u, &reference),
            importance: rmse(&i, &reference),
        });
    }
    Ok(EnvironmentStudy {
        resolution: (w, h),
        reference_spp: budget.environment_reference_spp,
        rows,
    })
}

pub fn table(study: &EnvironmentStudy) -> Table {
    let mut table = Table::new([
        ("spp", "spp"),
        ("rmse_uniform", "RMSE, uniform"),
        ("rmse_importance", "RMSE, by luminance"),
        ("ratio", "uniform / by luminance (> 1: luminance better)"),
    ]);
    for r in &study.rows {
        table.row(vec![
            Cell::Count(r.spp as u64),
            Cell::Number(r.uniform, 4),
            Cell::Number(r.importance, 4),
            Cell::Ratio(r.uniform / r.importance),
        ]);
    }
    table
}

pub fn markdown(study: &EnvironmentStudy, budget: &Budget) -> String {
    let (w, h) = study.resolution;
    let shown = budget.environment_spp[budget.environment_spp.len() / 2];
    let ratios: Vec<f64> = study
        .rows
        .iter()
        .map(|r| r.uniform / r.importance)
        .collect();
    let (lo, hi) = ratios.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &r| {
        (lo.min(r), hi.max(r))
    });
    format!(
        "## Environment light: sampling the map by luminance or uniformly\n\n\
         Three spheres (diffuse, rough gold, polished silver) on a plate under the project's demonstration sky (`cargo run --release --example sky_map -- sky.exr`: a sun of 2 degrees radius, radiance 1000, over a sky of about 0.5), {w}x{h}, direct light (`-m 1`), MIS, native backend, against a {}-spp render sampled by luminance with another seed. At equal samples, uniform sampling's RMSE is {lo:.1}-{hi:.1}x that of sampling by luminance: uniform directions find the sun (0.03% of the sphere) on one sample in about three thousand, and the surfaces it lights stay speckled until they do.\n\n{}\n\
         Left: uniform, right: by luminance, both at {shown} spp.\n\n![environment](environment.png)\n\n",
        study.reference_spp,
        table(study).markdown()
    )
}

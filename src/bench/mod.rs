//! Ray sets anyone can replay: `hybrid rays export DIR SCENE` writes the
//! scene's triangles (transforms applied, as hybrid loads them) and every
//! ray kind of the report in the files of [`file`]; `hybrid bench DIR`
//! replays them on every backend, on one thread, against Embree called as
//! a plain C program calls it. Another program reading the same files
//! (`docs/rays.md` has a C reader) measures the same rays.

pub mod corpus;
pub mod file;
pub mod waves;

use std::path::{Path, PathBuf};

use crate::accel::config::compared;
use crate::accel::{Backend, BackendConfig};
use crate::geom::ray::FlatRay;
use crate::geom::Ray;
use crate::measure::paired::{compare, compare_batched, compare_plain, PairedRow};
pub use crate::measure::Settle;
use crate::measure::{ray_sets, time_repeats, Measured, Query, RAY_KINDS};
pub use crate::report::paired::{batched_table, table};
use crate::scene::builder::SceneBuilder;
use crate::scene::{Material, NormalMode, Scene};
use glam::Vec3;

/// The file of a ray kind: `camera rows` -> `camera_rows.rays`.
pub fn file_name(kind: &str) -> String {
    format!("{}.rays", kind.replace(' ', "_"))
}

/// The triangles file's name.
pub const TRIANGLES: &str = "triangles.bin";

/// What an export wrote.
pub struct Exported {
    pub triangles: usize,
    /// Spheres of the scene that were left out (the files hold triangles).
    pub spheres_dropped: usize,
    pub sets: Vec<(String, usize)>,
}

/// Writes `scene`'s triangles and about `n` rays of each kind into `dir`.
/// The rays are made on the triangles alone, so that a replay on the
/// exported triangles sees the same hits.
pub fn export(scene: &Scene, dir: &Path, n: usize) -> Result<Exported, String> {
    let mut triangles_only = scene.clone();
    let spheres_dropped = std::mem::take(&mut triangles_only.spheres).len();
    if triangles_only.mesh.is_empty() {
        return Err(format!(
            "{}: the scene has no triangles; the files hold triangles only ({spheres_dropped} spheres would be left out), so there is nothing to export",
            scene.name
        ));
    }
    let finder = BackendConfig::NATIVE
        .build(&triangles_only)
        .map_err(|e| e.to_string())?;
    let staging = Staging::new(dir)?;
    let (triangles, sets) = write_export(&triangles_only, &finder, staging.path(), n)?;
    staging.publish()?;
    Ok(Exported {
        triangles,
        spheres_dropped,
        sets,
    })
}

/// Writes the triangles and every non-empty ray set of `scene` into `dir`.
fn write_export(
    triangles_only: &Scene,
    finder: &Backend,
    dir: &Path,
    n: usize,
) -> Result<(usize, Vec<(String, usize)>), String> {
    let corners: Vec<[f32; 9]> = (0..triangles_only.mesh.len())
        .map(|i| {
            let [a, b, c] = triangles_only.mesh.corners(i);
            [a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z]
        })
        .collect();
    file::write_triangles(&dir.join(TRIANGLES), &corners).map_err(|e| e.to_string())?;
    let mut sets = Vec::new();
    for set in ray_sets(triangles_only, finder, n) {
        let flat: Vec<FlatRay> = set.rays.iter().map(Ray::flat).collect();
        if flat.is_empty() {
            // A set of nothing (light rays where nothing is lit) would be
            // refused by `bench`: it is left out.
            continue;
        }
        let name = file_name(set.kind);
        file::write_rays(&dir.join(&name), set.query, &flat).map_err(|e| e.to_string())?;
        sets.push((name, flat.len()));
    }
    for (kind, query, rays) in waves::wave_sets(triangles_only, finder, n) {
        let flat: Vec<FlatRay> = rays.iter().map(Ray::flat).collect();
        if flat.is_empty() {
            continue;
        }
        let name = file_name(kind);
        file::write_rays(&dir.join(&name), query, &flat).map_err(|e| e.to_string())?;
        sets.push((name, flat.len()));
    }
    Ok((corners.len(), sets))
}

/// Whether an export may write `dir`: a new folder, or one that holds
/// nothing but an export's files (which it replaces whole). Reads only.
pub fn check_export_dir(dir: &Path) -> Result<(), String> {
    if dir.as_os_str().is_empty() {
        return Err("rays export: DIR is empty: name the folder to write".into());
    }
    if !dir.exists() {
        return Ok(());
    }
    if !dir.is_dir() {
        return Err(format!(
            "{}: is not a folder: export into a new folder or an export's own",
            dir.display()
        ));
    }
    let entries = std::fs::read_dir(dir)
        .map_err(|e| format!("{}: cannot read the folder: {e}", dir.display()))?;
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let ours = name == TRIANGLES || name.ends_with(".rays");
        if !ours || !entry.file_type().is_ok_and(|t| t.is_file()) {
            return Err(format!(
                "{}: holds {name}, which no export writes: export into a new folder or an export's own",
                dir.display()
            ));
        }
    }
    Ok(())
}

/// An export is written whole into a hidden folder beside `DIR` and only
/// then takes `DIR`'s place, so a failed or interrupted export never
/// leaves new triangles beside old rays (issue 46, class 3). An existing
/// `DIR` is replaced only when it holds nothing but an export's files.
struct Staging {
    dir: PathBuf,
    tmp: PathBuf,
    published: bool,
}

impl Staging {
    fn new(dir: &Path) -> Result<Staging, String> {
        check_export_dir(dir)?;
        let name = dir
            .file_name()
            .map_or("export".into(), |n| n.to_string_lossy().into_owned());
        let tmp = dir.with_file_name(format!(".{name}.partial-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&tmp);
        std::fs::create_dir_all(&tmp)
            .map_err(|e| format!("{}: cannot create the folder: {e}", dir.display()))?;
        Ok(Staging {
            dir: dir.to_path_buf(),
            tmp,
            published: false,
        })
    }

    fn path(&self) -> &Path {
        &self.tmp
    }

    /// Puts the finished export in `DIR`'s place; an old export is moved
    /// aside first and removed after.
    fn publish(mut self) -> Result<(), String> {
        let dir = self.dir.clone();
        let fail = |e: std::io::Error| format!("{}: cannot replace the folder: {e}", dir.display());
        let old = self.tmp.with_extension("old");
        let had_old = self.dir.exists();
        if had_old {
            std::fs::rename(&self.dir, &old).map_err(fail)?;
        }
        if let Err(e) = std::fs::rename(&self.tmp, &self.dir) {
            if had_old {
                let _ = std::fs::rename(&old, &self.dir);
            }
            return Err(fail(e));
        }
        self.published = true;
        if had_old {
            let _ = std::fs::remove_dir_all(&old);
        }
        Ok(())
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        if !self.published {
            let _ = std::fs::remove_dir_all(&self.tmp);
        }
    }
}

/// The scene of a triangles file: one mesh of the default material, built
/// as every scene is (its coordinates are already in range, so nothing is
/// rescaled).
pub fn scene_of(triangles: &[[f32; 9]], name: &str) -> Scene {
    let positions: Vec<Vec3> = triangles
        .iter()
        .flat_map(|t| (0..3).map(move |c| Vec3::new(t[3 * c], t[3 * c + 1], t[3 * c + 2])))
        .collect();
    let faces: Vec<[u32; 3]> = (0..triangles.len() as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    let mut builder = SceneBuilder::new(name);
    let material = builder.material(Material::DEFAULT);
    builder.mesh(&positions, &faces, material);
    builder.finish(NormalMode::Flat)
}

/// Replays every ray set in `dir` on every compared backend, one thread,
/// each Embree through its wrapper and as a plain C caller; or, `batched`,
/// in every batched mode ([`compare_batched`]).
pub fn replay(dir: &Path, settle: Settle, batched: bool) -> Result<Vec<PairedRow>, String> {
    let triangles = file::read_triangles(&dir.join(TRIANGLES)).map_err(|e| e.to_string())?;
    let scene = scene_of(&triangles, &dir.display().to_string());
    let backends = compared()
        .iter()
        .map(|c| Ok((c.label(), c.with_threads(1).build(&scene)?)))
        .collect::<Result<Vec<_>, crate::accel::AccelError>>()
        .map_err(|e| e.to_string())?;
    let mut rows = Vec::new();
    for kind in RAY_KINDS.into_iter().chain(waves::WAVE_KINDS) {
        let path = dir.join(file_name(kind));
        if !path.exists() {
            continue;
        }
        let (query, flat) = file::read_rays(&path).map_err(|e| e.to_string())?;
        let refs: Vec<(String, &Backend)> = backends.iter().map(|(l, b)| (l.clone(), b)).collect();
        // On a one-thread pool, as the report runs it: where the traversal
        // runs moves native's speed (docs/design.md, Measuring), so the
        // two must run alike to agree.
        rows.push(crate::measure::on_threads(1, || {
            if batched {
                compare_batched(kind, query, &flat, &refs, settle)
            } else {
                compare(kind, query, &flat, &refs, settle)
            }
        }));
    }
    if rows.is_empty() {
        return Err(format!(
            "{}: no ray files (hybrid rays export {} SCENE writes them)",
            dir.display(),
            dir.display()
        ));
    }
    Ok(rows)
}

/// The kinds a corpus replay times: the report's camera, incoherent and
/// shadow rays, and the renderer's own bounce rays, as rays and as waves.
pub const CORPUS_KINDS: [&str; 5] = ["camera", "incoherent", "shadow", "bounce", "wave bounce"];

/// Whether `dir` holds a corpus (`hybrid rays corpus`): no triangles of
/// its own, and a folder with triangles.
pub fn is_corpus(dir: &Path) -> bool {
    !dir.join(TRIANGLES).exists()
        && corpus::names()
            .iter()
            .any(|n| dir.join(n).join(TRIANGLES).is_file())
}

/// Whether a corpus export may write `dir`: a new folder, or one that
/// holds nothing but corpus folders, each an export's own. Reads only.
pub fn check_corpus_dir(dir: &Path) -> Result<(), String> {
    if dir.as_os_str().is_empty() {
        return Err("rays corpus: DIR is empty: name the folder to write".into());
    }
    if !dir.exists() {
        return Ok(());
    }
    if !dir.is_dir() {
        return Err(format!(
            "{}: is not a folder: write the corpus into a new folder or a corpus's own",
            dir.display()
        ));
    }
    let names = corpus::names();
    let entries = std::fs::read_dir(dir)
        .map_err(|e| format!("{}: cannot read the folder: {e}", dir.display()))?;
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let folder = entry.file_type().is_ok_and(|t| t.is_dir());
        if !folder || !names.contains(&name) {
            return Err(format!(
                "{}: holds {name}, which no corpus export writes: write the corpus into a new folder or a corpus's own",
                dir.display()
            ));
        }
        check_export_dir(&entry.path())?;
    }
    Ok(())
}

/// Writes every corpus mesh's export into `dir/<mesh>/`, one mesh at a
/// time (each loaded or generated, exported and dropped), about `n` rays
/// of each kind; `progress` hears each mesh as it is done.
pub fn export_corpus(
    scenes: &Path,
    dir: &Path,
    n: usize,
    mut progress: impl FnMut(&str, &Exported),
) -> Result<(), String> {
    check_corpus_dir(dir)?;
    // Every shared scene is read before anything is written, so a missing
    // one is found before minutes of work.
    for rel in corpus::SHARED {
        let path = scenes.join(rel);
        if !path.is_file() {
            return Err(format!(
                "{}: not found: the corpus needs every shared mesh ({})",
                path.display(),
                corpus::SHARED.join(", ")
            ));
        }
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| format!("{}: cannot create the folder: {e}", dir.display()))?;
    for name in corpus::names() {
        let scene = corpus::load(scenes, &name)?;
        let out = export(&scene, &dir.join(&name), n)?;
        progress(&name, &out);
    }
    Ok(())
}

/// One corpus mesh's replay: one-thread build times and every kind of
/// [`CORPUS_KINDS`] it has, native against each Embree as a plain C
/// caller at medium and high build quality.
pub struct CorpusMesh {
    pub name: String,
    pub triangles: usize,
    /// Median wall time of one-thread builds, seconds, per backend (the
    /// order of [`corpus_backends`]).
    pub builds: Vec<(String, Measured)>,
    pub rows: Vec<PairedRow>,
}

/// The corpus replay's backends: native, then each Embree present at
/// medium (its default) and high build quality, on one thread.
pub fn corpus_backends() -> Vec<BackendConfig> {
    let all = [
        BackendConfig::NATIVE,
        BackendConfig::EMBREE,
        BackendConfig::EMBREE_HIGH,
        BackendConfig::EMBREE4,
        BackendConfig::EMBREE4_HIGH,
    ];
    all.into_iter()
        .filter(|c| c.available().is_ok())
        .map(|c| c.with_threads(1))
        .collect()
}

/// Replays every mesh of the corpus in `dir` ([`is_corpus`]), in the
/// corpus's order, on one thread; `progress` hears each mesh as it is done.
pub fn replay_corpus(
    dir: &Path,
    settle: Settle,
    mut progress: impl FnMut(&CorpusMesh),
) -> Result<Vec<CorpusMesh>, String> {
    let mut out = Vec::new();
    for name in corpus::names() {
        let mesh_dir = dir.join(&name);
        if !mesh_dir.join(TRIANGLES).is_file() {
            continue;
        }
        let triangles =
            file::read_triangles(&mesh_dir.join(TRIANGLES)).map_err(|e| e.to_string())?;
        let mut sets = Vec::new();
        for kind in CORPUS_KINDS {
            let path = mesh_dir.join(file_name(kind));
            if path.exists() {
                let (query, flat) = file::read_rays(&path).map_err(|e| e.to_string())?;
                sets.push((kind, query, flat));
            }
        }
        let mesh = replay_mesh(&name, &scene_of(&triangles, &name), &sets, settle)?;
        progress(&mesh);
        out.push(mesh);
    }
    if out.is_empty() {
        return Err(format!(
            "{}: no corpus meshes (hybrid rays corpus {} writes them)",
            dir.display(),
            dir.display()
        ));
    }
    Ok(out)
}

/// One corpus ray set: its kind, query and rays.
pub type CorpusSet = (&'static str, Query, Vec<FlatRay>);

/// The corpus's ray sets of `scene` made in memory, as `rays corpus`
/// writes them: about `n` rays of each kind of [`CORPUS_KINDS`].
pub fn corpus_sets(scene: &Scene, n: usize) -> Result<Vec<CorpusSet>, String> {
    let finder = BackendConfig::NATIVE
        .build(scene)
        .map_err(|e| e.to_string())?;
    let mut sets = Vec::new();
    let made = ray_sets(scene, &finder, n)
        .into_iter()
        .map(|s| (s.kind, s.query, s.rays))
        .chain(waves::wave_sets(scene, &finder, n));
    for (kind, query, rays) in made {
        if CORPUS_KINDS.contains(&kind) && !rays.is_empty() {
            sets.push((kind, query, rays.iter().map(Ray::flat).collect()));
        }
    }
    Ok(sets)
}

/// One mesh's replay: its one-thread builds, then each set on one thread,
/// native against each Embree as a plain C caller.
pub fn replay_mesh(
    name: &str,
    scene: &Scene,
    sets: &[(&str, Query, Vec<FlatRay>)],
    settle: Settle,
) -> Result<CorpusMesh, String> {
    let configs = corpus_backends();
    let builds = configs
        .iter()
        .map(|c| {
            let took =
                crate::measure::on_threads(1, || time_repeats(3, || c.build(scene).map(|_| ())));
            (c.label(), took)
        })
        .collect();
    let backends = configs
        .iter()
        .map(|c| Ok((c.label(), c.build(scene)?)))
        .collect::<Result<Vec<_>, crate::accel::AccelError>>()
        .map_err(|e| e.to_string())?;
    let refs: Vec<(String, &Backend)> = backends.iter().map(|(l, b)| (l.clone(), b)).collect();
    let rows = sets
        .iter()
        .map(|(kind, query, flat)| {
            crate::measure::on_threads(1, || compare_plain(kind, *query, flat, &refs, settle))
        })
        .collect();
    Ok(CorpusMesh {
        name: name.to_string(),
        triangles: scene.triangle_count(),
        builds,
        rows,
    })
}

/// The fastest plain-C Embree run of a row, if any.
pub fn best_embree(row: &PairedRow) -> Option<&crate::measure::paired::Run> {
    row.runs
        .iter()
        .filter(|r| r.plain_c)
        .max_by(|a, b| a.cpu.median.total_cmp(&b.cpu.median))
}

/// Native over the best Embree of a row.
pub fn over_best(row: &PairedRow) -> Option<f64> {
    best_embree(row).map(|b| row.runs[0].cpu.median / b.cpu.median)
}

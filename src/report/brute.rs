//! "With and without acceleration": camera-ray throughput of brute force
//! against both BVHs on small scenes.

use std::path::Path;

use super::budget::{Budget, BRUTE_FORCE_SCENES};
use super::load;
use super::table::{Cell, Table};
use crate::accel::config::with_and_without;
use crate::accel::BackendConfig;
use crate::measure::Measured;
use crate::measure::{mrays, Query};
use crate::parity::rays;

/// One scene: camera-ray Mrays/s per configuration of [`with_and_without`].
pub struct BruteRow {
    pub scene: String,
    pub primitives: usize,
    pub mrays: Vec<Measured>,
}

pub fn measure(dir: &Path, budget: &Budget) -> Result<Vec<BruteRow>, String> {
    BRUTE_FORCE_SCENES
        .iter()
        .map(|rel| {
            let scene = load(dir, rel)?;
            let set = rays::camera_rays(&scene, (budget.rays / 4).max(2_000), 4);
            let mrays = with_and_without()
                .iter()
                .map(|config| {
                    let accel = config.build(&scene).map_err(|e| e.to_string())?;
                    // Brute force is slow: fewer repeats.
                    let repeats = match config {
                        BackendConfig::Brute => budget.repeats.min(3),
                        _ => budget.repeats,
                    };
                    Ok(mrays(&accel, &set, Query::Closest, 1, repeats))
                })
                .collect::<Result<_, String>>()?;
            Ok(BruteRow {
                scene: rel.to_string(),
                primitives: scene.primitive_count(),
                mrays,
            })
        })
        .collect()
}

pub fn table(rows: &[BruteRow]) -> Table {
    let mut columns = vec![
        ("scene".to_string(), "scene".to_string()),
        ("primitives".into(), "primitives".into()),
    ];
    let configs = with_and_without();
    for c in &configs {
        columns.push((
            format!("{}_mrays", c.kind()),
            format!("{} Mrays/s", c.kind()),
        ));
    }
    for c in &configs[1..] {
        columns.push((
            format!("{}_speedup", c.kind()),
            format!("{} speed-up over none", c.kind()),
        ));
    }
    let mut table = Table::new(columns);
    for r in rows {
        let mut row = vec![
            Cell::Text(r.scene.clone()),
            Cell::Count(r.primitives as u64),
        ];
        row.extend(r.mrays.iter().map(|m| Cell::Measured(*m, 2)));
        row.extend(
            r.mrays[1..]
                .iter()
                .map(|m| Cell::ratio_of(m.median / r.mrays[0].median, &[*m, r.mrays[0]])),
        );
        table.row(row);
    }
    table
}

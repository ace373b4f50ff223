//! The per-scene results as the report writes them: Markdown tables and
//! their JSON, from the rows [`super::scenes::measure`] filled (measuring
//! there, writing here).

use serde_json::{json, Value};

use super::paired::batched_table;
use super::scenes::SceneResult;
use super::table::{Cell, Flag, Table};
use crate::accel::{BackendConfig, TreeFacts};
use crate::measure::Measured;

fn builds_table(r: &SceneResult) -> Table {
    let t = r.threads;
    let mut table = Table::new([
        ("build", "build".to_string()),
        ("ms_1_thread", "ms, 1 thread (CPU time)".to_string()),
        (
            "ms_all_threads",
            format!("ms, {}", super::counted(t, "thread")),
        ),
        ("memory_mib", "memory MiB".to_string()),
        ("nodes", "nodes".to_string()),
        ("depth", "depth".to_string()),
        ("sah_cost", "SAH cost (binary)".to_string()),
        ("wide_sah_cost", "SAH cost (wide)".to_string()),
    ]);
    for b in &r.builds {
        let tree = |f: fn(&TreeFacts) -> Cell| b.stats.tree.as_ref().map_or(Cell::Empty, f);
        table.row(vec![
            Cell::Text(b.config.label()),
            Cell::Measured(Measured::millis(&b.one_thread), 2),
            Cell::Measured(Measured::millis(&b.all_threads), 2).flagged(
                (b.all_threads.median > b.one_thread.median).then_some(Flag::BelowOneThread),
            ),
            Cell::Number(b.stats.memory_bytes as f64 / (1 << 20) as f64, 2),
            tree(|t| Cell::Count(t.nodes as u64)),
            tree(|t| Cell::Count(t.depth as u64)),
            tree(|t| Cell::Number(t.sah_cost, 2)),
            tree(|t| Cell::Number(t.wide_sah_cost, 2)),
        ]);
    }
    table
}

fn traces_table(r: &SceneResult) -> Table {
    let t = r.threads;
    let labels: Vec<String> = r.compared.iter().map(BackendConfig::label).collect();
    // Backends with a plain-C baseline (Embree), by index.
    let with_c: Vec<usize> = r
        .traces
        .first()
        .map(|row| {
            (1..labels.len())
                .filter(|&j| row.plain_c[j].is_some())
                .collect()
        })
        .unwrap_or_default();
    let mut columns = vec![
        ("kind".to_string(), "rays".to_string()),
        ("rays".to_string(), "count".to_string()),
    ];
    for l in &labels {
        columns.push((format!("{l}_mrays"), format!("{l} Mrays/s, 1 thread")));
    }
    for &j in &with_c {
        let l = &labels[j];
        columns.push((format!("{l}_plain_c_mrays"), format!("{l} plain C")));
    }
    for l in &labels[1..] {
        columns.push((format!("native_over_{l}"), format!("{}/{l}", labels[0])));
    }
    for &j in &with_c {
        let l = &labels[j];
        columns.push((
            format!("{l}_wrapper_over_plain_c"),
            format!("{l} wrapper/plain C"),
        ));
    }
    columns.push(("rounds".to_string(), "rounds".to_string()));
    // On one thread the all-threads columns would repeat the figures.
    let all_threads = t > 1;
    if all_threads {
        for l in &labels {
            columns.push((format!("{l}_mrays_all_threads"), format!("{l} {t} threads")));
        }
        for l in &labels[1..] {
            columns.push((
                format!("native_over_{l}_all_threads"),
                format!("{}/{l}, {t} threads", labels[0]),
            ));
        }
    }
    let mut table = Table::new(columns);
    for row in &r.traces {
        let mut cells = vec![Cell::Text(row.kind.into()), Cell::Count(row.rays as u64)];
        cells.extend(row.one_thread.iter().map(|m| Cell::Measured(*m, 2)));
        cells.extend(with_c.iter().map(|&j| match row.plain_c[j] {
            Some(m) => Cell::Measured(m, 2),
            None => Cell::Empty,
        }));
        cells.extend((1..labels.len()).map(|j| {
            Cell::Ratio(row.ratio(j)).flagged(row.verdict_unsure(j).then_some(Flag::Noisy))
        }));
        cells.extend(with_c.iter().map(|&j| match row.wrapper_speed(j) {
            Some(s) => Cell::Ratio(s),
            None => Cell::Empty,
        }));
        cells.push(Cell::Count(row.rounds as u64));
        if all_threads {
            // A figure on all threads below its one-thread figure is flagged.
            cells.extend(row.all_threads.iter().enumerate().map(|(i, m)| {
                Cell::Measured(*m, 2)
                    .flagged((m.median < row.one_thread[i].median).then_some(Flag::BelowOneThread))
            }));
            cells.extend(
                (1..labels.len())
                    .map(|j| Cell::ratio_of(row.ratio_all_threads(j), &row.pair(j, true))),
            );
        }
        table.row(cells);
    }
    table
}

/// Each backend's batch query against its own single rays, all threads.
fn batched_all_table(r: &SceneResult) -> Table {
    let t = r.threads;
    let mut columns = vec![("kind", "rays".to_string())];
    let labels: Vec<String> = r.compared.iter().map(|c| c.label()).collect();
    let mut keys = Vec::new();
    for l in &labels {
        keys.push((format!("{l}_single"), format!("{l} single, {t} threads")));
        keys.push((format!("{l}_batch"), format!("{l} batch, {t} threads")));
    }
    keys.push((
        "native_batch_over_best".into(),
        "native batch / best Embree".into(),
    ));
    let mut table = Table::new(
        columns
            .drain(..)
            .map(|(k, v)| (k.to_string(), v))
            .chain(keys),
    );
    for (kind, pairs) in &r.batched_all {
        let mut cells = vec![Cell::Text(kind.to_string())];
        for pair in pairs {
            cells.push(Cell::Measured(pair[0], 2));
            cells.push(Cell::Measured(pair[1], 2));
        }
        let native = pairs[0][1];
        let best = pairs[1..]
            .iter()
            .flatten()
            .max_by(|a, b| a.median.total_cmp(&b.median));
        cells.push(match best {
            Some(b) => Cell::ratio_of(native.median / b.median, &[native, *b]),
            None => Cell::Empty,
        });
        table.row(cells);
    }
    table
}

/// The packets' figures against issue 28's targets, one line per scene
/// and ray kind: native packets over Embree's best mode on one thread
/// (plain C) and on all threads, and each backend's frame time with
/// packets over without.
pub fn packets_section(results: &[SceneResult]) -> (String, Value) {
    let mut table = Table::new([
        ("scene", "scene".to_string()),
        ("kind", "rays".to_string()),
        (
            "packets_over_single",
            "native packets / single, 1 thread".to_string(),
        ),
        (
            "packets_over_best_1",
            "native packets / best Embree, 1 thread".to_string(),
        ),
        ("best_embree_1", "best Embree, 1 thread".to_string()),
        (
            "packets_over_best_all",
            "native packets / best Embree, all threads".to_string(),
        ),
        ("target", "target".to_string()),
    ]);
    let mut frames = Vec::new();
    for r in results {
        for (row, (_, pairs)) in r.batched.iter().zip(&r.batched_all) {
            let (single, packets) = (row.runs[0].cpu.median, row.runs[1].cpu.median);
            let best = row
                .runs
                .iter()
                .filter(|run| run.plain_c)
                .max_by(|a, b| a.cpu.median.total_cmp(&b.cpu.median));
            let best_all = pairs[1..]
                .iter()
                .flatten()
                .map(|m| m.median)
                .fold(f64::NAN, f64::max);
            let target = if row.kind == "camera" { 1.2 } else { 1.0 };
            table.row(vec![
                Cell::Text(r.scene.clone()),
                Cell::Text(row.kind.clone()),
                Cell::Ratio(packets / single),
                best.map_or(Cell::Empty, |b| Cell::Ratio(packets / b.cpu.median)),
                best.map_or(Cell::Empty, |b| Cell::Text(b.describe())),
                Cell::Ratio(pairs[0][1].median / best_all),
                Cell::Text(format!("≥ {target:.1}x")),
            ]);
        }
        frames.push(format!(
            "{}: {}",
            r.scene,
            r.compared
                .iter()
                .enumerate()
                .map(|(i, c)| {
                    let (lo, median, hi) = r.packet_frame[i];
                    format!("{} {median:.3}x ({lo:.3}–{hi:.3})", c.label())
                })
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let md = format!(
        "## Packets\n\nCamera rays and the light rays of the camera's first hits, traced in batches: native in packets of sixteen rays of one octant with AVX-512, else eight (an interval test of each node's children against the packet, then the single-ray slab test lane by lane, leaves tested all the packet's rays per triangle, a child entered by one ray handed to the single-ray kernel); Embree in each batched mode its version has, called from C (`rtcIntersect8`/`rtcIntersect16`, `rtcOccluded8`/`rtcOccluded16`, Embree 3's `rtcIntersect1M`/`rtcOccluded1M` stream), each mode with the coherent hint or without, whichever traced the rays faster in a trial (the best mode names it). One thread: Mrays/s by CPU time, interleaved rounds as the headline's; all threads: wall clock, each backend's batch query and single rays. Targets (issue 28): native packets at least 1.2x Embree's best mode on camera rays and 1.0x on light rays.\n\n{}\nFrame time in the reference mode with each wave's camera rays in packets over every ray alone (`--no-packets`) (below 1: packets are faster; the per-scene sections' frame, same image either way), the median of the ratios of frames rendered one after the other in each of the interleaved rounds, with its 95% interval in parentheses: {}.\n\n",
        table.markdown(),
        frames.join("; ")
    );
    (md, json!({ "targets": table.json() }))
}

/// Each backend's frame in the renderer's three ways, and where the
/// waves' time went.
fn frames_table(r: &SceneResult) -> Table {
    let mut table = Table::new([
        ("backend", "backend"),
        ("default_seconds", "camera rays batched, s"),
        ("embree_over_native", "its time / native's"),
        ("alone_seconds", "every ray alone, s"),
        ("waves_seconds", "waves, s"),
        ("waves_over_default", "waves / default"),
        ("waves_over_default_interval", "its interval"),
        (
            "one_thread_default_seconds",
            "1 thread: camera rays batched, s",
        ),
        ("one_thread_waves_seconds", "1 thread: waves, s"),
        (
            "one_thread_waves_ksamples_per_second",
            "1 thread: waves, 10^3 samples/s",
        ),
        ("waves_extension_percent", "waves: extension-ray batches, %"),
        ("waves_shadow_percent", "waves: shadow-ray batches, %"),
        ("waves_paths_percent", "waves: stepping paths, %"),
        ("waves_arrive_percent", "of which taking the hits, %"),
        ("waves_light_percent", "sampling the lights, %"),
        ("waves_leave_percent", "summing light and leaving, %"),
        ("waves_kib_per_thread", "waves: KiB a thread at most"),
    ]);
    // Every mode gives the same image (the same error), so samples per
    // second compare the modes at equal error.
    let (w, h, spp) = r.frame;
    let samples = f64::from(w) * f64::from(h) * f64::from(spp);
    for (i, c) in r.compared.iter().enumerate() {
        let (lo, median, hi) = r.wave_frame[i];
        let shares = r.wave_times[i].shares();
        let percent = |x: f64| Cell::Number(100.0 * x, 0);
        let mut cells = vec![
            Cell::Text(c.label()),
            Cell::Measured(r.frame_seconds[i], 3),
            if i == 0 {
                Cell::Empty
            } else {
                Cell::ratio_of(r.frame_ratio(i), &r.frame_pair(i))
            },
            Cell::Measured(r.frame_seconds_alone[i], 3),
            Cell::Measured(r.frame_seconds_waves[i], 3),
            Cell::Ratio(median),
            Cell::Text(format!("{lo:.3}–{hi:.3}")),
            Cell::Measured(r.frame_seconds_one[i], 3),
            Cell::Measured(r.frame_seconds_waves_one[i], 3),
            Cell::Number(
                samples / r.frame_seconds_waves_one[i].median.max(1e-9) / 1e3,
                0,
            ),
            percent(shares[0]),
            percent(shares[1]),
            percent(shares[2]),
        ];
        // The stepping's steps, as shares of the whole wave (empty where
        // nothing was timed).
        let steps = r.wave_times[i].steps.shares();
        cells.extend((0..3).map(|k| match steps {
            Some(s) => percent(shares[2] * s[k]),
            None => Cell::Empty,
        }));
        cells.push(Cell::Number(r.wave_times[i].peak_bytes as f64 / 1024.0, 0));
        table.row(cells);
    }
    table
}

/// The per-scene section: Markdown and the JSON of every scene.
pub fn section(results: &[SceneResult]) -> (String, Value) {
    let mut md = String::from("## Build and trace, per scene\n\nMedians of warmed-up repeats with their range (min–max); ⚠ marks figures whose repeats spread by more than 10% (and ratios of such figures), ↓ a figure on all threads worse than the same on one thread. Ratios are native / each Embree's throughput: greater than 1 means native is faster.\n\n");
    let mut scenes = Vec::new();
    for r in results {
        let builds = builds_table(r);
        let traces = traces_table(r);
        let batched = batched_table(&r.batched);
        let batched_all = batched_all_table(r);
        let calls: Vec<String> = r
            .compared
            .iter()
            .zip(&r.batch_calls)
            .map(|(c, call)| format!("{}: {call}", c.label()))
            .collect();
        let (w, h, spp) = r.frame;
        let frames = frames_table(r);
        md += &format!(
            "### {} ({}: {} primitives)\n\n{}\n{}\nCamera and light rays in every batched mode, 1 thread (Mrays/s by CPU time; each Embree called from C):\n\n{}\nThe same on {} threads, through each backend's batch query ({}):\n\n{}\nTime per frame ({w}x{h}, {spp} spp, 3 bounces, light sampling, {} threads) in the renderer's three ways, the same image in each: the reference mode, camera rays in batches and each path alone (`--mode reference`), the same with every ray alone (`--no-packets`), and the wavefront, every bounce's rays of a wave of paths in batches (`--mode wavefront`, the default where its lanes take the scene, its paths' state in lists stepped sixteen at a time); \"default\" below is the reference frame, and waves / default is the median of the per-round ratios with its 95% interval; the default and the waves again on one thread, the waves also as samples per second (every mode makes the same image, so this compares them at equal error); and the last columns say where the waves' thread time went (both thread counts) and the most memory one thread's wave held (its paths, rays, hits and shadow tape):\n\n{}\n",
            r.scene,
            r.size,
            r.primitives,
            builds.markdown(),
            traces.markdown(),
            batched.markdown(),
            r.threads,
            calls.join("; "),
            batched_all.markdown(),
            r.threads,
            frames.markdown(),
        );
        let frame_json: serde_json::Map<String, Value> = r
            .compared
            .iter()
            .zip(&r.frame_seconds)
            .map(|(c, t)| (c.label(), json!(t.median)))
            .collect();
        scenes.push(json!({
            "scene": r.scene,
            "size": r.size,
            "primitives": r.primitives,
            "builds": builds.json(),
            "traces": traces.json(),
            "batched": batched.json(),
            "batched_all_threads": batched_all.json(),
            "frames": frames.json(),
            "frame_seconds": frame_json,
            "frame_seconds_without_packets": r
                .compared
                .iter()
                .zip(&r.frame_seconds_alone)
                .map(|(c, t)| (c.label(), json!(t.median)))
                .collect::<serde_json::Map<String, Value>>(),
            "frame_with_packets_over_without": r
                .compared
                .iter()
                .zip(&r.packet_frame)
                .map(|(c, (lo, median, hi))| {
                    (c.label(), json!({ "median": median, "lo": lo, "hi": hi }))
                })
                .collect::<serde_json::Map<String, Value>>(),
        }));
    }
    (md, Value::Array(scenes))
}

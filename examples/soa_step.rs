//! Developer tool: the bet of a wave whose path state lives in arrays,
//! measured on one bounce's step before any integrator is rewritten
//! (issue 45; docs/experiments.md, stop 51). The step is what a wave does
//! for each path between its two batch queries: arrive at the hit (its
//! surface point, facing, shading frame and the point lifted onto the
//! smooth surface), take one sample of an area light with its shadow ray
//! and MIS weight, and draw the next direction from the BSDF with its ray.
//!
//! Two forms of the same step on the same hits:
//! - **renderer**: the wave renderer's own code, a path at a time through
//!   `PathState` (`surface_points` in lanes, then `begin`, `light_at`,
//!   `go_on`), every shadow ray answered unblocked;
//! - **arrays**: the same operations in the same order, written as passes
//!   over structure-of-arrays lists of the whole wave, sixteen paths at a
//!   time on sixteen-float values ([`F16`]) in passes compiled for AVX2, the
//!   generators in lists too; sine and cosine lane by lane from libm (the
//!   renderer's bits) or as polynomials (not its bits).
//!
//! It handles Lambertian surfaces lit by one rectangular area light (the
//! Cornell boxes of `../shared/scenes/sky`); the rays are a real render's
//! bounce rays (`hybrid rays export DIR SCENE`, `wave_bounce.rays`),
//! traced once for their hits. It first compares every shadow and next
//! ray the forms make, bit for bit, then prints ns per path for each
//! form, best of `PASSES`, with what their outputs add to, on the calling
//! thread:
//!
//! ```text
//! hybrid rays export /tmp/rays-bunny ../shared/scenes/sky/CBbunny.dae
//! taskset -c 1 cargo run --release --example soa_step -- ../shared/scenes/sky/CBbunny.dae /tmp/rays-bunny [PASSES]
//! ```

use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use glam::Vec3;
use hybrid::accel::native::cpu::Avx2;
use hybrid::accel::{Accel, BackendConfig, Coherence, TraceCounters};
use hybrid::bench::file;
use hybrid::geom::ray::SHADOW_END;
use hybrid::geom::sampling::Rng;
use hybrid::geom::{gamma, Hit, Ray};
use hybrid::render::integrator::{
    DirectEstimator, Integrator, PathSettings, PathState, Shading, ShadowTape,
};
use hybrid::render::lanes::surface_points;
use hybrid::render::wide::{F16, LANES};
use hybrid::scene::{collada, Light, Material, NormalMode, Scene, SurfacePoint, TEST_ULPS};
use hybrid::{each3, map3};

/// Paths a wave holds (the renderer's `WAVE_PATHS`).
const WAVE: usize = 1024;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(scene_path), Some(dir)) = (args.first(), args.get(1)) else {
        eprintln!("usage: soa_step SCENE.dae RAYS_DIR [PASSES]");
        return ExitCode::from(2);
    };
    let passes: usize = args.get(2).and_then(|p| p.parse().ok()).unwrap_or(7);
    let scene = match collada::load(Path::new(scene_path), NormalMode::Smooth) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("soa_step: {e}");
            return ExitCode::from(2);
        }
    };
    let Some(avx2) = Avx2::detect() else {
        eprintln!("soa_step: needs AVX2");
        return ExitCode::from(2);
    };
    let light = match scene.lights.as_slice() {
        [Light::Area(a)] if !a.triangle => *a,
        _ => {
            eprintln!("soa_step: the scene must have one rectangular area light");
            return ExitCode::from(2);
        }
    };
    let flat = match file::read_rays(&Path::new(dir).join("wave_bounce.rays")) {
        Ok((_, flat)) => flat,
        Err(e) => {
            eprintln!("soa_step: {e}");
            return ExitCode::from(2);
        }
    };
    let lambertian =
        |m: &Material| matches!(m, Material::Lambertian { .. } | Material::Emission { .. });
    if !scene.materials.iter().all(lambertian) {
        eprintln!("soa_step: every material must be Lambertian or an emitter");
        return ExitCode::from(2);
    }
    let accel = match BackendConfig::NATIVE.with_threads(1).build(&scene) {
        Ok(accel) => accel,
        Err(e) => {
            eprintln!("soa_step: {e}");
            return ExitCode::from(2);
        }
    };
    let rays: Vec<Ray> = flat.iter().map(Ray::from_flat).collect();
    let mut hits = vec![None; rays.len()];
    let mut counters = TraceCounters::default();
    accel.closest_hits(&rays, Coherence::Incoherent, &mut hits, &mut counters);
    // Triangle hits only (a sphere's surface point is another function).
    let (rays, hits): (Vec<Ray>, Vec<Hit>) = rays
        .iter()
        .zip(&hits)
        .filter_map(|(r, h)| h.map(|h| (*r, h)))
        .filter(|(_, h)| (h.prim as usize) < scene.mesh.len())
        .collect();
    let n = rays.len() / WAVE * WAVE;
    let settings = PathSettings {
        estimator: DirectEstimator::Mis,
        light_samples: 1,
        max_bounces: 5,
        ..PathSettings::default()
    };
    let integrator = Integrator::new(&scene, &accel, Shading::Path(settings));
    let some_hits: Vec<Option<Hit>> = hits.iter().map(|h| Some(*h)).collect();
    if let Err(e) = away_is_next_up() {
        eprintln!("soa_step: {e}");
        return ExitCode::FAILURE;
    }
    // The rays of every form, compared bit for bit with the renderer's.
    let mut expected = Emitted::default();
    renderer(
        &integrator,
        &scene,
        avx2,
        &rays[..n],
        &some_hits[..n],
        Some(&mut expected),
    );
    let mut arrays = Arrays::default();
    for polynomials in [false, true] {
        arrays.polynomials = polynomials;
        let mut got = Emitted::default();
        for (k, (rays, hits)) in rays[..n]
            .chunks(WAVE)
            .zip(hits[..n].chunks(WAVE))
            .enumerate()
        {
            arrays.step(&scene, &light, avx2, rays, hits, (k * WAVE) as u64);
            arrays.emitted(&mut got);
        }
        println!(
            "arrays ({}): {} of {} rays differ from the renderer's in some bit",
            if polynomials { "polynomials" } else { "libm" },
            got.differences(&expected),
            expected.shadows.len() + expected.next.iter().flatten().count()
        );
    }
    let mut best = [f64::MAX; 3];
    let mut sums: [Sums; 3] = Default::default();
    for _ in 0..passes {
        let start = Instant::now();
        sums[0] = renderer(&integrator, &scene, avx2, &rays[..n], &some_hits[..n], None);
        best[0] = best[0].min(start.elapsed().as_secs_f64());
        for (form, polynomials) in [(1, false), (2, true)] {
            arrays.polynomials = polynomials;
            let start = Instant::now();
            sums[form] = Sums::default();
            for (k, (rays, hits)) in rays[..n]
                .chunks(WAVE)
                .zip(hits[..n].chunks(WAVE))
                .enumerate()
            {
                arrays.step(&scene, &light, avx2, rays, hits, (k * WAVE) as u64);
                sums[form].add(&arrays.sums());
            }
            best[form] = best[form].min(start.elapsed().as_secs_f64());
        }
    }
    let ns = |t: f64| t / n as f64 * 1e9;
    println!(
        "{n} paths ({} waves of {WAVE}), ns a path, best of {passes}:",
        n / WAVE
    );
    for (form, name) in ["renderer", "arrays, libm", "arrays, polynomials"]
        .iter()
        .enumerate()
    {
        println!(
            "{name:20} {:6.1} ({:.2}x the renderer's speed); {}",
            ns(best[form]),
            best[0] / best[form],
            sums[form]
        );
    }
    ExitCode::SUCCESS
}

/// `F16::away` against the standard library's `next_up` and `next_down`
/// on the edge cases the rays may not reach (zeros, subnormals,
/// infinities, NaN).
fn away_is_next_up() -> Result<(), String> {
    let edges = [
        0.0,
        -0.0,
        f32::MIN_POSITIVE,
        -f32::from_bits(1),
        1e-40,
        f32::MAX,
        f32::INFINITY,
        f32::NAN,
    ];
    let ordinary = [
        1.0,
        -1.0,
        3.5,
        -2.5,
        7.0,
        -7.0,
        f32::NEG_INFINITY,
        -f32::MAX,
    ];
    let lanes = |a: [f32; 8]| F16(std::array::from_fn(|l| a[l % 8]));
    for x in [lanes(edges), lanes(edges.map(|x| -x)), lanes(ordinary)] {
        for o in [1.0, -1.0, 0.0] {
            let got = x.away(F16::splat(o));
            for (g, x) in got.0.into_iter().zip(x.0) {
                let want = match o {
                    o if o > 0.0 => x.next_up(),
                    o if o < 0.0 => x.next_down(),
                    _ => x,
                };
                if g.to_bits() != want.to_bits() {
                    return Err(format!("one ulp from {x} towards {o} gave {g}, not {want}"));
                }
            }
        }
    }
    Ok(())
}

/// What a step's outputs add to: paths going on, shadow rays, the next
/// rays' directions, and the direct terms (all unblocked).
#[derive(Default)]
struct Sums {
    moving: usize,
    shadows: usize,
    /// The arrays form's only: the renderer's paths keep theirs inside.
    direct: Option<f64>,
    directions: [f64; 3],
}

impl Sums {
    fn add(&mut self, o: &Sums) {
        self.moving += o.moving;
        self.shadows += o.shadows;
        if let Some(d) = o.direct {
            *self.direct.get_or_insert(0.0) += d;
        }
        for a in 0..3 {
            self.directions[a] += o.directions[a];
        }
    }
}

impl std::fmt::Display for Sums {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        let d = self.directions;
        write!(
            f,
            "{} go on, {} shadow rays, next directions ({:.0}, {:.0}, {:.0})",
            self.moving, self.shadows, d[0], d[1], d[2]
        )?;
        match self.direct {
            Some(direct) => write!(f, ", direct light {direct:.1}"),
            None => Ok(()),
        }
    }
}

/// The renderer's step, wave by wave, as `Wave::radiance` takes it.
fn renderer<A: Accel>(
    integrator: &Integrator<A>,
    scene: &Scene,
    avx2: Avx2,
    rays: &[Ray],
    hits: &[Option<Hit>],
    mut out: Option<&mut Emitted>,
) -> Sums {
    let mut sums = Sums::default();
    let mut states: Vec<PathState> = Vec::with_capacity(WAVE);
    let mut streams: Vec<Rng> = Vec::with_capacity(WAVE);
    let mut tape = ShadowTape::default();
    let mut points: Vec<SurfacePoint> = Vec::new();
    let mut counters = TraceCounters::default();
    let mut blocked = Vec::new();
    for (k, (rays, hits)) in rays.chunks(WAVE).zip(hits.chunks(WAVE)).enumerate() {
        surface_points(scene, Some(avx2), rays, hits, &mut points);
        states.clear();
        streams.clear();
        tape.clear();
        for (i, (ray, hit)) in rays.iter().zip(hits).enumerate() {
            let mut stream = Rng::new(7, (k * WAVE + i) as u64);
            let mut state = PathState::Done(Vec3::ZERO);
            integrator.begin(
                ray,
                *hit,
                Some(&points[i]),
                &mut stream,
                &mut counters,
                &mut state,
            );
            states.push(state);
            streams.push(stream);
        }
        for (state, stream) in states.iter_mut().zip(&mut streams) {
            integrator.light_at(state, stream, &mut tape, &mut counters);
        }
        if let Some(out) = out.as_deref_mut() {
            out.shadows.extend_from_slice(tape.rays());
        }
        blocked.clear();
        blocked.resize(tape.rays().len(), false);
        sums.shadows += tape.rays().len();
        for (state, stream) in states.iter_mut().zip(&mut streams) {
            integrator.go_on(state, &tape, &blocked, stream);
            if let Some(out) = out.as_deref_mut() {
                out.next.push(state.ray().copied());
            }
            if let Some(ray) = state.ray() {
                sums.moving += 1;
                for a in 0..3 {
                    sums.directions[a] += ray.dir[a] as f64;
                }
            }
        }
    }
    sums
}

/// The rays a form's step made: the shadow rays in path order, and each
/// path's next ray.
#[derive(Default, PartialEq)]
struct Emitted {
    shadows: Vec<Ray>,
    next: Vec<Option<Ray>>,
}

impl Emitted {
    /// How many of the rays differ from `o`'s in any bit.
    fn differences(&self, o: &Emitted) -> usize {
        let bits = |r: &Ray| r.flat().map(f32::to_bits);
        let shadows = self
            .shadows
            .iter()
            .zip(&o.shadows)
            .filter(|(a, b)| bits(a) != bits(b));
        let next = self
            .next
            .iter()
            .zip(&o.next)
            .filter(|(a, b)| a.map(|r| bits(&r)) != b.map(|r| bits(&r)));
        shadows.count()
            + next.count()
            + self.shadows.len().abs_diff(o.shadows.len())
            + self.next.len().abs_diff(o.next.len())
    }
}

/// One wave's step in structure-of-arrays form: every list holds one
/// value per path.
#[derive(Default)]
struct Arrays {
    // Inputs gathered per path.
    dir: [Vec<f32>; 3],
    w: [Vec<f32>; 3],
    corner: [[Vec<f32>; 3]; 3],
    normal: [[Vec<f32>; 3]; 3],
    albedo: [Vec<f32>; 3],
    emits: Vec<f32>,
    // The surface point.
    p: [Vec<f32>; 3],
    error: [Vec<f32>; 3],
    ng: [Vec<f32>; 3],
    ns: [Vec<f32>; 3],
    // The vertex.
    s: [Vec<f32>; 3],
    t: [Vec<f32>; 3],
    wo: [Vec<f32>; 3],
    lift: [Vec<f32>; 3],
    lifted: Vec<f32>,
    // Generators: the path's, and its vertex's light stream.
    state: Vec<u64>,
    inc: Vec<u64>,
    light_state: Vec<u64>,
    light_inc: Vec<u64>,
    // Outputs.
    shadow: [Vec<f32>; 8],
    shadow_ok: Vec<f32>,
    term: [Vec<f32>; 3],
    next: [Vec<f32>; 8],
    next_ok: Vec<f32>,
    /// Sine and cosine as polynomials, else libm's (the renderer's).
    polynomials: bool,
}

fn resize<const N: usize>(lists: &mut [Vec<f32>; N], n: usize) {
    for l in lists {
        l.clear();
        l.resize(n, 0.0);
    }
}

fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

const PCG_MULTIPLIER: u64 = 6_364_136_223_846_793_005;

/// PCG32's step over a list of generators: each one's next number.
#[inline(always)]
fn next_u32(state: &mut [u64], inc: &[u64], out: &mut [u32]) {
    for ((s, &i), o) in state.iter_mut().zip(inc).zip(out.iter_mut()) {
        let old = *s;
        *s = old.wrapping_mul(PCG_MULTIPLIER).wrapping_add(i);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        *o = xorshifted.rotate_right((old >> 59) as u32);
    }
}

/// Three coordinates of sixteen paths from `lists` at path `i`.
#[inline(always)]
fn v3(lists: &[Vec<f32>; 3], i: usize) -> [F16; 3] {
    each3!(|a| F16::load(&lists[a][i..]))
}

#[inline(always)]
fn dot(a: [F16; 3], b: [F16; 3]) -> F16 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
fn cross(a: [F16; 3], b: [F16; 3]) -> [F16; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `Ray::spawn`'s origin: the point moved past its error bound along the
/// normal, to the side `dir` leaves on, then one ulp further away.
#[inline(always)]
fn spawn(p: [F16; 3], error: [F16; 3], ng: [F16; 3], dir: [F16; 3]) -> [F16; 3] {
    let zero = F16::splat(0.0);
    let d = ng[0].abs() * error[0] + ng[1].abs() * error[1] + ng[2].abs() * error[2];
    let d = F16::select(dot(dir, ng).lt(zero), -d, d);
    let mut origin = [zero; 3];
    for k in 0..3 {
        let offset = ng[k] * d;
        origin[k] = (p[k] + offset).away(offset);
    }
    origin
}

/// Sine and cosine of `2 pi v` for v in [0, 1): the quarter turn taken
/// exactly, then polynomials on [-pi/4, pi/4].
#[inline(always)]
fn sin_cos_turn(v: F16) -> (F16, F16) {
    let c = F16::splat;
    let q = (v * c(4.0) + c(0.5)).floor();
    let x = (v * c(4.0) - q) * c(std::f32::consts::FRAC_PI_2);
    let x2 = x * x;
    let s = x * (c(1.0) + x2 * (c(-1.0 / 6.0) + x2 * (c(1.0 / 120.0) + x2 * c(-1.0 / 5040.0))));
    let co = c(1.0)
        + x2 * (c(-0.5) + x2 * (c(1.0 / 24.0) + x2 * (c(-1.0 / 720.0) + x2 * c(1.0 / 40320.0))));
    let (odd, high) = q.quadrant();
    let (s, co) = (F16::select(odd, co, s), F16::select(odd, -s, co));
    (F16::select(high, -s, s), F16::select(high, -co, co))
}

impl Arrays {
    /// The rays of the last wave, as `Emitted`.
    fn emitted(&self, out: &mut Emitted) {
        let ray = |r: &[Vec<f32>; 8], i: usize| Ray::from_flat(&r.each_ref().map(|c| c[i]));
        for i in 0..self.next_ok.len() {
            if self.shadow_ok[i] > 0.0 {
                out.shadows.push(ray(&self.shadow, i));
            }
            out.next
                .push((self.next_ok[i] > 0.0).then(|| ray(&self.next, i)));
        }
    }

    fn sums(&self) -> Sums {
        let mut sums = Sums::default();
        for i in 0..self.next_ok.len() {
            if self.shadow_ok[i] > 0.0 {
                sums.shadows += 1;
                *sums.direct.get_or_insert(0.0) +=
                    (self.term[0][i] + self.term[1][i] + self.term[2][i]) as f64;
            }
            if self.next_ok[i] > 0.0 {
                sums.moving += 1;
                for a in 0..3 {
                    sums.directions[a] += self.next[3 + a][i] as f64;
                }
            }
        }
        sums
    }

    fn step(
        &mut self,
        scene: &Scene,
        light: &hybrid::scene::AreaLight,
        _avx2: Avx2,
        rays: &[Ray],
        hits: &[Hit],
        first: u64,
    ) {
        self.gather(scene, rays, hits, first);
        // SAFETY: `Avx2` proves the CPU runs AVX2, the passes' one
        // requirement.
        unsafe {
            self.surface();
            self.vertex();
            self.split();
            self.light(light);
            if self.polynomials {
                self.bsdf::<true>();
            } else {
                self.bsdf::<false>();
            }
        }
    }

    /// Each path's ray, triangle, corners' normals and material.
    fn gather(&mut self, scene: &Scene, rays: &[Ray], hits: &[Hit], first: u64) {
        let n = rays.len();
        resize(&mut self.dir, n);
        resize(&mut self.w, n);
        resize(&mut self.albedo, n);
        for k in 0..3 {
            resize(&mut self.corner[k], n);
            resize(&mut self.normal[k], n);
        }
        self.emits.clear();
        self.state.clear();
        self.inc.clear();
        for (i, (ray, hit)) in rays.iter().zip(hits).enumerate() {
            let p = hit.prim as usize;
            let corners = scene.mesh.corners(p);
            let normals = scene.corner_normals(p);
            let [wa, wb, wc] = hybrid::scene::barycentric_weights(hit);
            for a in 0..3 {
                self.dir[a][i] = ray.dir[a];
                for k in 0..3 {
                    self.corner[k][a][i] = corners[k][a];
                    self.normal[k][a][i] = normals[k][a];
                }
            }
            self.w[0][i] = wa;
            self.w[1][i] = wb;
            self.w[2][i] = wc;
            let m = &scene.materials[scene.mesh.materials[p] as usize];
            let (albedo, emits) = match *m {
                Material::Lambertian { albedo, .. } => (albedo, false),
                _ => (Vec3::ZERO, true),
            };
            for a in 0..3 {
                self.albedo[a][i] = albedo[a];
            }
            self.emits.push(if emits { 1.0 } else { 0.0 });
            // A generator per path, as `Rng::new(7, path)` seeds one
            // (the renderer form's): the same numbers in both forms.
            let inc = (mix(first + i as u64) << 1) | 1;
            let state = inc.wrapping_add(mix(7));
            self.state
                .push(state.wrapping_mul(PCG_MULTIPLIER).wrapping_add(inc));
            self.inc.push(inc);
        }
    }

    /// The surface points (`Scene::surface_point`'s operations).
    #[target_feature(enable = "avx2")]
    unsafe fn surface(&mut self) {
        let n = self.dir[0].len();
        for l in [&mut self.p, &mut self.error, &mut self.ng, &mut self.ns] {
            resize(l, n);
        }
        let margin_ulps = F16::splat(gamma(TEST_ULPS));
        let g9 = F16::splat(gamma(9));
        let (two, third, zero) = (F16::splat(2.0), F16::splat(3.0), F16::splat(0.0));
        for i in (0..n).step_by(LANES) {
            let w = each3!(|k| F16::load(&self.w[k][i..]));
            let c = each3!(|k| v3(&self.corner[k], i));
            let nm = each3!(|k| v3(&self.normal[k], i));
            let d = |x: usize, y: usize, a: usize| (c[x][a] - c[y][a]).abs();
            let s = each3!(|a| d(1, 0, a).max(d(2, 0, a)).max(d(2, 1, a)));
            let margin = margin_ulps * s[0].max(s[1]).max(s[2]);
            let on = each3!(|a| c[0][a] * w[0] + c[1][a] * w[1] + c[2][a] * w[2]);
            let inward = each3!(|a| (c[0][a] + c[1][a] + c[2][a]) / third - on[a]);
            let reach = dot(inward, inward).sqrt();
            let steps = reach.gt(two * margin);
            let step = two * margin / reach;
            let e1 = each3!(|a| c[1][a] - c[0][a]);
            let e2 = each3!(|a| c[2][a] - c[0][a]);
            let x = cross(e1, e2);
            let len = dot(x, x).sqrt();
            let ng = map3!(x, |v| v / len);
            let sm = each3!(|a| nm[0][a] * w[0] + nm[1][a] * w[1] + nm[2][a] * w[2]);
            let recip = F16::splat(1.0) / dot(sm, sm).sqrt();
            let unit = map3!(sm, |x| x * recip);
            let outward = dot(unit, ng).lt(zero);
            for a in 0..3 {
                F16::select(steps, on[a] + inward[a] * step, on[a]).store(&mut self.p[a][i..]);
                let e = (c[0][a] * w[0]).abs() + (c[1][a] * w[1]).abs() + (c[2][a] * w[2]).abs();
                (g9 * e + margin).store(&mut self.error[a][i..]);
                ng[a].store(&mut self.ng[a][i..]);
                F16::select(outward, -unit[a], unit[a]).store(&mut self.ns[a][i..]);
            }
        }
    }

    /// Facing, the shading frame, wo in it, and the terminator lift.
    #[target_feature(enable = "avx2")]
    unsafe fn vertex(&mut self) {
        let n = self.dir[0].len();
        for l in [&mut self.s, &mut self.t, &mut self.wo, &mut self.lift] {
            resize(l, n);
        }
        self.lifted.clear();
        self.lifted.resize(n, 0.0);
        let (zero, one) = (F16::splat(0.0), F16::splat(1.0));
        for i in (0..n).step_by(LANES) {
            let wo = map3!(v3(&self.dir, i), |x| -x);
            let (ng0, ns0) = (v3(&self.ng, i), v3(&self.ns, i));
            let back = F16::select(dot(wo, ng0).lt(zero), -one, one);
            let ng = map3!(ng0, |x| x * back);
            let ns = map3!(ns0, |x| x * back);
            // (A diffuse surface keeps the smooth normal's side: no turn to
            // the view, `Lobe::turns_to_view`.)
            let sign = one.copysign(ns[2]);
            let fa = -one / (sign + ns[2]);
            let fb = ns[0] * ns[1] * fa;
            let s = [one + sign * ns[0] * ns[0] * fa, sign * fb, -(sign * ns[0])];
            let t = [fb, sign + ns[1] * ns[1] * fa, -ns[1]];
            let w = each3!(|k| F16::load(&self.w[k][i..]));
            let nk = each3!(|k| v3(&self.normal[k], i));
            let interp = each3!(|a| nk[0][a] * w[0] + nk[1][a] * w[1] + nk[2][a] * w[2]);
            let flip = F16::select(dot(interp, ng).lt(zero), -one, one);
            let p = v3(&self.p, i);
            let mut lift = [zero; 3];
            for k in 0..3 {
                let nn = map3!(nk[k], |x| x * flip);
                let c = v3(&self.corner[k], i);
                let below = dot(each3!(|a| p[a] - c[a]), nn).min(zero);
                for a in 0..3 {
                    lift[a] = lift[a] - nn[a] * (below * w[k]);
                }
            }
            F16::select(dot(lift, ng).gt(zero), one, zero).store(&mut self.lifted[i..]);
            for a in 0..3 {
                ng[a].store(&mut self.ng[a][i..]);
                ns[a].store(&mut self.ns[a][i..]);
                s[a].store(&mut self.s[a][i..]);
                t[a].store(&mut self.t[a][i..]);
                lift[a].store(&mut self.lift[a][i..]);
            }
            dot(wo, s).store(&mut self.wo[0][i..]);
            dot(wo, t).store(&mut self.wo[1][i..]);
            dot(wo, ns).store(&mut self.wo[2][i..]);
        }
    }

    /// Each vertex's light stream, split off its path's (`Rng::split`).
    #[target_feature(enable = "avx2")]
    unsafe fn split(&mut self) {
        let n = self.state.len();
        let (mut hi, mut lo) = (vec![0u32; n], vec![0u32; n]);
        next_u32(&mut self.state, &self.inc, &mut hi);
        next_u32(&mut self.state, &self.inc, &mut lo);
        self.light_state.clear();
        self.light_inc.clear();
        for i in 0..n {
            self.light_state
                .push(mix((u64::from(hi[i]) << 32) | u64::from(lo[i])));
            self.light_inc
                .push((self.inc[i] ^ 0x5851_F42D_4C95_7F2D) | 1);
        }
    }

    /// One light sample each: its term (MIS-weighted, unblocked) and
    /// shadow ray.
    #[target_feature(enable = "avx2")]
    unsafe fn light(&mut self, light: &hybrid::scene::AreaLight) {
        let n = self.state.len();
        let (mut a, mut b) = (vec![0u32; n], vec![0u32; n]);
        next_u32(&mut self.light_state, &self.light_inc, &mut a);
        next_u32(&mut self.light_state, &self.light_inc, &mut b);
        resize(&mut self.shadow, n);
        resize(&mut self.term, n);
        self.shadow_ok.clear();
        self.shadow_ok.resize(n, 0.0);
        let splat3 = |v: Vec3| [F16::splat(v.x), F16::splat(v.y), F16::splat(v.z)];
        let (o, eu, ev) = (
            splat3(light.origin),
            splat3(light.edge_u),
            splat3(light.edge_v),
        );
        let (ln, radiance) = (splat3(light.normal), splat3(light.radiance));
        let area = F16::splat(light.area);
        let g1 = F16::splat(gamma(1));
        let (zero, one, inf) = (F16::splat(0.0), F16::splat(1.0), F16::splat(f32::INFINITY));
        let pi = F16::splat(std::f32::consts::FRAC_1_PI);
        for i in (0..n).step_by(LANES) {
            let (u, v) = (F16::unit(&a[i..]), F16::unit(&b[i..]));
            let p = v3(&self.p, i);
            let to = each3!(|k| o[k] + eu[k] * u + ev[k] * v - p[k]);
            let d2 = dot(to, to);
            let distance = d2.sqrt();
            let cos_light = -dot(to, ln) / distance;
            let pdf = d2 / (cos_light * area);
            let wi = map3!(to, |x| x / distance);
            let ng = v3(&self.ng, i);
            let local_z = dot(wi, v3(&self.ns, i));
            let in_front = dot(wi, ng).gt(zero);
            let lifted = F16::load(&self.lifted[i..]).gt(zero);
            let emits = F16::load(&self.emits[i..]).gt(zero);
            let ok = d2
                .ne(zero)
                .and(cos_light.gt(zero))
                .and(pdf.gt(zero))
                .and(pdf.lt(inf))
                .and(local_z.gt(zero))
                .and(in_front.or(lifted))
                .and_not(emits);
            let albedo = v3(&self.albedo, i);
            let f = map3!(albedo, |x| x * pi);
            let black = f[0].ne(zero).or(f[1].ne(zero)).or(f[2].ne(zero));
            let ok = ok.and(black);
            let contribution = map3!(radiance, |x| x / pdf);
            // The MIS weight against the BSDF's density, then the term.
            let (a2, b2) = (pdf * pdf, (local_z * pi) * (local_z * pi));
            let weight = F16::select(in_front, a2 / (a2 + b2), one);
            let scale = local_z.abs() * weight / one;
            // From the lifted point where there is one.
            let error = v3(&self.error, i);
            let lift = v3(&self.lift, i);
            let from = each3!(|k| F16::select(lifted, p[k] + lift[k], p[k]));
            let from_error = each3!(|k| {
                F16::select(
                    lifted,
                    error[k] + (p[k].abs() + lift[k].abs()) * g1,
                    error[k],
                )
            });
            let reach = each3!(|k| p[k] + wi[k] * distance - from[k]);
            let length = dot(reach, reach).sqrt();
            let dir = each3!(|k| F16::select(lifted, reach[k] / length, wi[k]));
            let far = F16::select(lifted, length, distance);
            let origin = spawn(from, from_error, ng, dir);
            for k in 0..3 {
                origin[k].store(&mut self.shadow[k][i..]);
                dir[k].store(&mut self.shadow[3 + k][i..]);
                (f[k] * contribution[k] * scale).store(&mut self.term[k][i..]);
            }
            zero.store(&mut self.shadow[6][i..]);
            (far * F16::splat(SHADOW_END)).store(&mut self.shadow[7][i..]);
            F16::select(ok, one, zero).store(&mut self.shadow_ok[i..]);
        }
    }

    /// The next direction, cosine-weighted, and its ray.
    #[target_feature(enable = "avx2")]
    unsafe fn bsdf<const POLYNOMIALS: bool>(&mut self) {
        let n = self.state.len();
        let (mut a, mut b) = (vec![0u32; n], vec![0u32; n]);
        next_u32(&mut self.state, &self.inc, &mut a);
        next_u32(&mut self.state, &self.inc, &mut b);
        resize(&mut self.next, n);
        self.next_ok.clear();
        self.next_ok.resize(n, 0.0);
        let (zero, one) = (F16::splat(0.0), F16::splat(1.0));
        for i in (0..n).step_by(LANES) {
            let (u, v) = (F16::unit(&a[i..]), F16::unit(&b[i..]));
            let r = u.sqrt();
            let (sin, cos) = if POLYNOMIALS {
                sin_cos_turn(v)
            } else {
                let phi = F16::splat(2.0 * std::f32::consts::PI) * v;
                (phi.each(f32::sin), phi.each(f32::cos))
            };
            let local = [r * cos, r * sin, (one - u).max(zero).sqrt()];
            let (s, t, ns) = (v3(&self.s, i), v3(&self.t, i), v3(&self.ns, i));
            let wi = each3!(|k| s[k] * local[0] + t[k] * local[1] + ns[k] * local[2]);
            let ng = v3(&self.ng, i);
            let emits = F16::load(&self.emits[i..]).gt(zero);
            let ok = local[2].gt(zero).and(dot(wi, ng).gt(zero)).and_not(emits);
            F16::select(ok, one, zero).store(&mut self.next_ok[i..]);
            let origin = spawn(v3(&self.p, i), v3(&self.error, i), ng, wi);
            for k in 0..3 {
                origin[k].store(&mut self.next[k][i..]);
                wi[k].store(&mut self.next[3 + k][i..]);
            }
            zero.store(&mut self.next[6][i..]);
            F16::splat(f32::INFINITY).store(&mut self.next[7][i..]);
        }
    }
}

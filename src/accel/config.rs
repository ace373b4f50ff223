//! Every backend, named once: what a configuration is ([`BackendConfig`]),
//! its label, how it is built into the run-time union ([`Backend`]), and the
//! named sets that the parity suite, the hard cases, the report, the
//! benches and the CLI iterate. Adding a backend means its folder (declared
//! in `accel/mod.rs`), this file and its CLI flags.

use super::embree::{
    BuildQuality, Embree3, Embree4, EmbreeAccel, EmbreeOptions, EmbreeVersion, PlainC,
};
use super::native::build::BuildMethod;
use super::native::triangle::TriangleMode;
use super::native::{NativeBvh, NativeOptions};
use super::{brute, Accel, AccelError, AccelStats, Coherence, TraceCounters};
use crate::choice::Choice;
use crate::geom::{Hit, Ray};
use crate::scene::Scene;

/// The backend chosen at run time, as a tagged union: static dispatch on
/// the per-ray path, one match per query.
pub enum Backend<'s> {
    Native(NativeBvh),
    Embree3(EmbreeAccel<'s, Embree3>),
    Embree4(EmbreeAccel<'s, Embree4>),
    Brute(brute::BruteForce),
}

/// `$call` on whichever backend `$backend` holds, bound to `$a`: the
/// dispatch written once for every query.
macro_rules! on_backend {
    ($backend:expr, $a:ident => $call:expr) => {
        match $backend {
            Backend::Native($a) => $call,
            Backend::Embree3($a) => $call,
            Backend::Embree4($a) => $call,
            Backend::Brute($a) => $call,
        }
    };
}

impl Accel for Backend<'_> {
    #[inline]
    fn closest_hit(&self, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit> {
        on_backend!(self, a => a.closest_hit(ray, counters))
    }

    #[inline]
    fn occluded(&self, ray: &Ray, counters: &mut TraceCounters) -> bool {
        on_backend!(self, a => a.occluded(ray, counters))
    }

    fn closest_hits(
        &self,
        rays: &[Ray],
        coherence: Coherence,
        out: &mut [Option<Hit>],
        counters: &mut TraceCounters,
    ) {
        on_backend!(self, a => a.closest_hits(rays, coherence, out, counters))
    }

    fn occluded_all(&self, rays: &[Ray], out: &mut [bool], counters: &mut TraceCounters) {
        on_backend!(self, a => a.occluded_all(rays, out, counters))
    }

    fn stats(&self) -> AccelStats {
        on_backend!(self, a => a.stats())
    }
}

impl Backend<'_> {
    /// The backend's library as a plain C program calls it (the report's
    /// baseline), for the backends that are a C library: measurement, not
    /// a query, so it is not part of [`Accel`].
    pub fn plain_c(&self) -> Option<&dyn PlainC> {
        match self {
            Backend::Embree3(a) => Some(a),
            Backend::Embree4(a) => Some(a),
            Backend::Native(_) | Backend::Brute(_) => None,
        }
    }
}

/// The backends as `--accel` spells them, each name written once (Embree's
/// versions by [`EmbreeVersion`]'s names): the CLI parses these, and every
/// label begins with one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackendKind {
    Native,
    /// The newest Embree present: 4 when it loads, else 3.
    Embree,
    Embree3,
    Embree4,
    /// Brute force: every primitive for every ray.
    None,
}

impl Choice for BackendKind {
    const ALL: &'static [Self] = &[
        BackendKind::Native,
        BackendKind::Embree,
        BackendKind::Embree3,
        BackendKind::Embree4,
        BackendKind::None,
    ];
    fn name(self) -> &'static str {
        match self {
            BackendKind::Native => "native",
            BackendKind::Embree => "embree",
            BackendKind::Embree3 => EmbreeVersion::V3.name(),
            BackendKind::Embree4 => EmbreeVersion::V4.name(),
            BackendKind::None => "none",
        }
    }
}

impl BackendKind {
    /// The kind of `config` (an Embree by its version).
    pub fn of(config: &BackendConfig) -> BackendKind {
        match config {
            BackendConfig::Native(_) => BackendKind::Native,
            BackendConfig::Embree(o) => match o.version {
                EmbreeVersion::V3 => BackendKind::Embree3,
                EmbreeVersion::V4 => BackendKind::Embree4,
            },
            BackendConfig::Brute => BackendKind::None,
        }
    }

    /// This backend with `native`'s or `embree`'s options (whose version
    /// this kind decides).
    pub fn configure(self, native: NativeOptions, embree: EmbreeOptions) -> BackendConfig {
        let embree_of = |version| BackendConfig::Embree(EmbreeOptions { version, ..embree });
        match self {
            BackendKind::Native => BackendConfig::Native(native),
            BackendKind::Embree => embree_of(EmbreeVersion::newest()),
            BackendKind::Embree3 => embree_of(EmbreeVersion::V3),
            BackendKind::Embree4 => embree_of(EmbreeVersion::V4),
            BackendKind::None => BackendConfig::Brute,
        }
    }
}

/// One backend with its options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BackendConfig {
    Native(NativeOptions),
    Embree(EmbreeOptions),
    /// Every primitive for every ray (`--accel none`).
    Brute,
}

/// Brute force joins comparisons (parity, the report) up to this many
/// primitives; beyond it a run would take minutes.
pub const BRUTE_FORCE_LIMIT: usize = 5_000;

impl BackendConfig {
    /// The native BVH as the renderer uses it by default (Möller–Trumbore).
    pub const NATIVE: BackendConfig = BackendConfig::Native(NativeOptions::DEFAULT);
    /// The native BVH with the watertight triangle test: the accuracy
    /// reference of the parity suite.
    pub const NATIVE_WATERTIGHT: BackendConfig = BackendConfig::Native(NativeOptions {
        triangle: TriangleMode::Watertight,
        ..NativeOptions::DEFAULT
    });
    /// The native BVH with packets of eight rays (AVX2 lanes) even where
    /// the CPU runs sixteen: the batch queries' narrower kernels.
    pub const NATIVE_PACKETS8: BackendConfig = BackendConfig::Native(NativeOptions {
        packet_lanes: 8,
        ..NativeOptions::DEFAULT
    });
    /// The native BVH with packets of sixteen rays: AVX-512 lanes, or two
    /// AVX2 registers per value where the CPU has no AVX-512.
    pub const NATIVE_PACKETS16: BackendConfig = BackendConfig::Native(NativeOptions {
        packet_lanes: 16,
        ..NativeOptions::DEFAULT
    });
    /// The native BVH as the top-down SAH splits leave it, grouped
    /// largest child first: what the moves and the planned grouping buy.
    pub const NATIVE_TOP_DOWN: BackendConfig = BackendConfig::Native(NativeOptions {
        method: BuildMethod::SahTopDown,
        ..NativeOptions::DEFAULT
    });
    /// The native BVH built by median splits: the baseline the SAH is
    /// measured against.
    pub const NATIVE_MEDIAN: BackendConfig = BackendConfig::Native(NativeOptions {
        method: BuildMethod::Median,
        ..NativeOptions::DEFAULT
    });
    /// Embree 3 at its default (medium) build quality.
    pub const EMBREE: BackendConfig =
        BackendConfig::embree(EmbreeVersion::V3, BuildQuality::Medium, false);
    pub const EMBREE_ROBUST: BackendConfig =
        BackendConfig::embree(EmbreeVersion::V3, BuildQuality::Medium, true);
    pub const EMBREE_LOW: BackendConfig =
        BackendConfig::embree(EmbreeVersion::V3, BuildQuality::Low, false);
    pub const EMBREE_HIGH: BackendConfig =
        BackendConfig::embree(EmbreeVersion::V3, BuildQuality::High, false);
    /// Embree 4, the same four.
    pub const EMBREE4: BackendConfig =
        BackendConfig::embree(EmbreeVersion::V4, BuildQuality::Medium, false);
    pub const EMBREE4_ROBUST: BackendConfig =
        BackendConfig::embree(EmbreeVersion::V4, BuildQuality::Medium, true);
    pub const EMBREE4_LOW: BackendConfig =
        BackendConfig::embree(EmbreeVersion::V4, BuildQuality::Low, false);
    pub const EMBREE4_HIGH: BackendConfig =
        BackendConfig::embree(EmbreeVersion::V4, BuildQuality::High, false);

    const fn embree(version: EmbreeVersion, quality: BuildQuality, robust: bool) -> BackendConfig {
        BackendConfig::Embree(EmbreeOptions {
            version,
            quality,
            robust,
            threads: 0,
        })
    }
    pub const BRUTE: BackendConfig = BackendConfig::Brute;

    /// The backend's name as `--accel` spells it ([`BackendKind`]).
    pub fn kind(&self) -> &'static str {
        BackendKind::of(self).name()
    }

    /// `Ok` when the backend can be built on this machine (its library
    /// loads), else what to install.
    pub fn available(&self) -> Result<(), String> {
        match self {
            BackendConfig::Embree(o) => o.version.available(),
            _ => Ok(()),
        }
    }

    /// A short label naming the backend and every option that differs from
    /// its default, e.g. `native`, `native watertight`, `embree robust`.
    pub fn label(&self) -> String {
        let mut label = self.kind().to_string();
        match *self {
            BackendConfig::Native(o) => {
                let d = NativeOptions::DEFAULT;
                if o.triangle != d.triangle {
                    label += &format!(" {}", o.triangle.name());
                }
                if o.method != d.method {
                    label += &format!(" {}", o.method.name());
                }
                if o.max_leaf != d.max_leaf {
                    label += &format!(" leaf {}", o.max_leaf);
                }
                if o.simd != d.simd {
                    label += " scalar";
                }
                if o.packet_lanes != d.packet_lanes {
                    label += &format!(" packets of {}", o.packet_lanes);
                }
            }
            BackendConfig::Embree(o) => {
                if o.quality != EmbreeOptions::DEFAULT.quality {
                    label += &format!(" {}", o.quality.name());
                }
                if o.robust {
                    label += " robust";
                }
            }
            BackendConfig::Brute => label += " (brute force)",
        }
        label
    }

    /// The same configuration with `threads` build threads (Embree's pool;
    /// 0 means all cores). The native build uses the caller's rayon pool.
    pub fn with_threads(self, threads: usize) -> BackendConfig {
        match self {
            BackendConfig::Embree(o) => BackendConfig::Embree(EmbreeOptions { threads, ..o }),
            other => other,
        }
    }

    /// Whether the configuration is sensible for `scene` (brute force only
    /// on small scenes).
    pub fn suits(&self, scene: &Scene) -> bool {
        !matches!(self, BackendConfig::Brute) || scene.primitive_count() <= BRUTE_FORCE_LIMIT
    }

    /// Builds the backend over `scene`.
    pub fn build<'s>(&self, scene: &'s Scene) -> Result<Backend<'s>, AccelError> {
        Ok(match self {
            BackendConfig::Native(o) => Backend::Native(NativeBvh::build(scene, o)?),
            BackendConfig::Embree(o) => match o.version {
                EmbreeVersion::V3 => Backend::Embree3(EmbreeAccel::build(scene, o)?),
                EmbreeVersion::V4 => Backend::Embree4(EmbreeAccel::build(scene, o)?),
            },
            BackendConfig::Brute => Backend::Brute(brute::BruteForce::build(scene)),
        })
    }
}

/// The parity suite's reference: every other configuration is compared
/// with it, hit by hit.
pub const PARITY_REFERENCE: BackendConfig = BackendConfig::NATIVE_WATERTIGHT;

/// Keeps the configurations whose library loads here (the test suite
/// requires both Embree versions under CI, so a missing one fails there
/// rather than shortening a table).
fn present(list: &[BackendConfig]) -> Vec<BackendConfig> {
    list.iter()
        .copied()
        .filter(|c| c.available().is_ok())
        .collect()
}

/// What the parity suite compares with the reference (brute force only
/// where it [suits](BackendConfig::suits) the scene).
pub fn parity_candidates() -> Vec<BackendConfig> {
    present(&[
        BackendConfig::NATIVE,
        BackendConfig::EMBREE,
        BackendConfig::EMBREE_ROBUST,
        BackendConfig::EMBREE4,
        BackendConfig::EMBREE4_ROBUST,
        BackendConfig::BRUTE,
    ])
}

/// The columns of the hard-case table.
pub fn hard_case_modes() -> Vec<BackendConfig> {
    present(&[
        BackendConfig::NATIVE,
        BackendConfig::NATIVE_WATERTIGHT,
        BackendConfig::EMBREE,
        BackendConfig::EMBREE_ROBUST,
        BackendConfig::EMBREE4,
        BackendConfig::EMBREE4_ROBUST,
    ])
}

/// The builds the report and the benches time.
pub fn build_variants() -> Vec<BackendConfig> {
    present(&[
        BackendConfig::NATIVE,
        BackendConfig::NATIVE_WATERTIGHT,
        BackendConfig::NATIVE_TOP_DOWN,
        BackendConfig::NATIVE_MEDIAN,
        BackendConfig::EMBREE_LOW,
        BackendConfig::EMBREE,
        BackendConfig::EMBREE_HIGH,
        BackendConfig::EMBREE4_LOW,
        BackendConfig::EMBREE4,
        BackendConfig::EMBREE4_HIGH,
    ])
}

/// The backends whose speed the report and the benches compare: native
/// first, then each Embree present. Every ratio is native over one of
/// the others, found by its label.
pub fn compared() -> Vec<BackendConfig> {
    present(&[
        BackendConfig::NATIVE,
        BackendConfig::EMBREE,
        BackendConfig::EMBREE4,
    ])
}

/// The "with and without acceleration" table.
pub fn with_and_without() -> Vec<BackendConfig> {
    present(&[
        BackendConfig::BRUTE,
        BackendConfig::NATIVE,
        BackendConfig::EMBREE,
        BackendConfig::EMBREE4,
    ])
}

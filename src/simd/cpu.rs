//! Which SIMD code the CPU may run, as a value that proves it.
//!
//! [`Avx2`] can only be made by [`Avx2::detect`], which asks the CPU at run
//! time (`is_x86_feature_detected!`). Every function compiled with
//! `#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]` takes
//! one, so safe code cannot reach those instructions on a CPU without
//! them: the token is the proof each `unsafe` call site relies on. Every
//! CPU with AVX2 has the bit-counting ones; the kernels use them for the
//! hit masks (`count_ones`, `leading_zeros`), which otherwise compile to
//! multiply and shift sequences. Without it the portable scalar code
//! runs; nothing is compiled for the build machine only.
//!
//! [`Isa::ceiling`] lowers what detection finds, for the whole process
//! (`HYBRID_ISA=avx2`, `sse4.2` or `sse2`): an AVX-512 machine then runs
//! the kernels an AVX2-only or an older CPU runs, native and Embree alike,
//! so one machine can prove every path (CI does).

use std::sync::OnceLock;

/// An instruction set level, in the order CPUs gained them. Native has
/// kernels for [`Isa::Avx512`] (16-ray packets), [`Isa::Avx2`] (the 8-wide
/// traversal and 8-ray packets) and below that its scalar twins; Embree
/// has its own kernels for each.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Isa {
    Sse2,
    Sse42,
    Avx2,
    Avx512,
}

/// The environment variable that caps the instruction set.
pub const ISA_VARIABLE: &str = "HYBRID_ISA";

impl Isa {
    /// Every level, lowest first.
    pub const ALL: [Isa; 4] = [Isa::Sse2, Isa::Sse42, Isa::Avx2, Isa::Avx512];

    /// The spelling of `HYBRID_ISA` and of Embree's `max_isa`.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Sse2 => "sse2",
            Isa::Sse42 => "sse4.2",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }

    /// The level a name spells, if any.
    pub fn parse(name: &str) -> Option<Isa> {
        Isa::ALL.into_iter().find(|isa| isa.name() == name)
    }

    /// The widest level this CPU runs, by runtime detection.
    pub fn detected() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            let avx2 = is_x86_feature_detected!("avx2")
                && is_x86_feature_detected!("fma")
                && is_x86_feature_detected!("popcnt")
                && is_x86_feature_detected!("lzcnt")
                && is_x86_feature_detected!("bmi1")
                && is_x86_feature_detected!("bmi2");
            if avx2 && is_x86_feature_detected!("avx512f") {
                return Isa::Avx512;
            }
            if avx2 {
                return Isa::Avx2;
            }
            if is_x86_feature_detected!("sse4.2") {
                return Isa::Sse42;
            }
        }
        Isa::Sse2
    }

    /// What the process may use: the detected level, or the lower one
    /// `HYBRID_ISA` names (a higher one than the CPU has is ignored: a cap
    /// never enables anything). Read once; an unknown name is reported by
    /// [`Isa::check_variable`] before any work.
    pub fn ceiling() -> Isa {
        static CEILING: OnceLock<Isa> = OnceLock::new();
        *CEILING.get_or_init(|| {
            let detected = Isa::detected();
            match Isa::requested() {
                Ok(Some(cap)) => cap.min(detected),
                _ => detected,
            }
        })
    }

    /// The level `HYBRID_ISA` asks for, if set; `Err` names a value that
    /// is not one.
    pub fn requested() -> Result<Option<Isa>, String> {
        let Some(value) = std::env::var_os(ISA_VARIABLE) else {
            return Ok(None);
        };
        let text = value.to_string_lossy();
        if text.is_empty() {
            return Ok(None);
        }
        Isa::parse(&text).map(Some).ok_or_else(|| {
            let names: Vec<_> = Isa::ALL.iter().map(|i| i.name()).collect();
            format!(
                "{ISA_VARIABLE}={text}: not an instruction set (one of {})",
                names.join(", ")
            )
        })
    }

    /// `Err` with one line when `HYBRID_ISA` holds an unknown value.
    pub fn check_variable() -> Result<(), String> {
        Isa::requested().map(|_| ())
    }

    /// A line saying the instruction set is capped below the CPU's, when
    /// it is.
    pub fn cap_note() -> Option<String> {
        let (ceiling, detected) = (Isa::ceiling(), Isa::detected());
        (ceiling < detected).then(|| {
            format!(
                "instruction set capped at {} by {ISA_VARIABLE} (this CPU runs {}): native and Embree run the kernels of such a CPU",
                ceiling.name(),
                detected.name()
            )
        })
    }

    /// Embree's device configuration for this ceiling: `max_isa=...` when
    /// it lies below what the CPU runs, else nothing (Embree picks the
    /// best it has).
    pub fn embree_config() -> Option<String> {
        let ceiling = Isa::ceiling();
        (ceiling < Isa::detected()).then(|| format!("max_isa={}", ceiling.name()))
    }
}

/// Proof that this CPU runs AVX2, FMA, POPCNT, LZCNT and BMI1/2
/// instructions (and that the process may use them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Avx2 {
    _detected: (),
}

impl Avx2 {
    /// `Some` when the CPU has all of them and [`Isa::ceiling`] allows them.
    pub fn detect() -> Option<Avx2> {
        (Isa::ceiling() >= Isa::Avx2).then_some(Avx2 { _detected: () })
    }
}

/// Proof that this CPU runs AVX-512 (foundation) besides everything
/// [`Avx2`] proves: the sixteen-ray packet kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Avx512 {
    _detected: (),
}

impl Avx512 {
    /// `Some` when the CPU has AVX-512F and the [`Avx2`] set, and
    /// [`Isa::ceiling`] allows them.
    pub fn detect() -> Option<Avx512> {
        (Isa::ceiling() >= Isa::Avx512).then_some(Avx512 { _detected: () })
    }
}

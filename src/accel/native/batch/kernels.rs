//! Which packet kernels a tree's batch queries run, chosen once per tree
//! from the CPU and the options.

use super::super::NativeOptions;
#[cfg(target_arch = "x86_64")]
use crate::simd::cpu::{Avx2, Avx512};

/// Which packet kernels a tree's batch queries run.
#[derive(Clone, Copy, Debug)]
pub(in crate::accel::native) enum PacketKernels {
    /// Sixteen rays in AVX-512 lanes.
    #[cfg(target_arch = "x86_64")]
    Avx512(Avx512),
    /// Eight rays in AVX2 lanes.
    #[cfg(target_arch = "x86_64")]
    Avx2(Avx2),
    /// Sixteen rays in two AVX2 registers per value.
    #[cfg(target_arch = "x86_64")]
    Avx2Wide(Avx2),
    /// None: every ray alone.
    None,
}

impl PacketKernels {
    /// What a batch query runs, as the backend's stats name it.
    pub(in crate::accel::native) fn describe(self) -> &'static str {
        match self {
            #[cfg(target_arch = "x86_64")]
            PacketKernels::Avx512(_) => {
                "packets of 16 rays (AVX-512) where 12 share an octant; the other rays in streams of 64 (closest hits of coherent batches alone)"
            }
            #[cfg(target_arch = "x86_64")]
            PacketKernels::Avx2(_) => {
                "packets of 8 rays (AVX2) where 6 share an octant; the other rays in streams of 64 (closest hits of coherent batches alone)"
            }
            #[cfg(target_arch = "x86_64")]
            PacketKernels::Avx2Wide(_) => {
                "packets of 16 rays (AVX2, two registers each) where 12 share an octant; the other rays in streams of 64 (closest hits of coherent batches alone)"
            }
            PacketKernels::None => "single-ray loop (no AVX2)",
        }
    }

    /// The kernels for `options`: none without SIMD; sixteen rays in
    /// AVX-512 lanes where the CPU has AVX-512, unless `packet_lanes` asks
    /// for eight; else, with AVX2, eight rays where eight are asked for
    /// and otherwise sixteen in two registers per value, faster than eight
    /// on every ray set measured since packets set up only the lanes that
    /// enter the root (docs/experiments.md).
    pub(in crate::accel::native) fn detect(options: &NativeOptions) -> PacketKernels {
        if !options.simd {
            return PacketKernels::None;
        }
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(wide) = Avx512::detect().filter(|_| options.packet_lanes != 8) {
                return PacketKernels::Avx512(wide);
            }
            if let Some(cpu) = Avx2::detect() {
                return match options.packet_lanes {
                    8 => PacketKernels::Avx2(cpu),
                    _ => PacketKernels::Avx2Wide(cpu),
                };
            }
        }
        PacketKernels::None
    }
}

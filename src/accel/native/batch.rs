//! Batch queries: a batch's rays in groups of the packet width, each
//! group traced as a packet where enough of its rays share an octant
//! ([`min_packet`]), or in a small tree as a packet of mixed octants
//! ([`super::MIXED_PACKET_NODES`]), the others in streams (or one at a
//! time, the closest hits of a coherent batch); the packet kernels chosen
//! once per tree.

use glam::Vec3A;

pub(super) use self::kernels::PacketKernels;
use super::leaves::BlockLeaves;
#[cfg(target_arch = "x86_64")]
use super::leaves::BlockPacket;
#[cfg(target_arch = "x86_64")]
use super::traverse::packet::{self, Packet, PacketRays, Width, X8x2, MAX_LANES, X16, X8};
#[cfg(target_arch = "x86_64")]
use super::traverse::PacketLeaves;
use super::traverse::{self, BoxRay, BoxTest, Work};
use super::triangle::TriangleBlock4;
use super::{min_packet, node, NativeBvh, TriangleStore, PREFETCH_GROUPS, SINGLE_BELOW};
use super::{node::ChildRef, tree::Tree};
use crate::accel::TraceCounters;
use crate::geom::{Hit, Ray};

/// A traceable ray prepared for the box tests, as [`NativeBvh::closest`]
/// prepares it.
fn box_ray_of(ray: &Ray) -> BoxRay {
    BoxRay::new(Vec3A::from(ray.origin), Vec3A::from(ray.dir), ray.t_min)
}

/// The lanes set in `mask`, lowest first.
fn lanes_of(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            i
        })
    })
}

/// One batch query's per-ray work, for the generic group code: the
/// closest hit or occlusion.
#[cfg(target_arch = "x86_64")]
pub(super) trait Query {
    type Answer: Copy;
    const MISS: Self::Answer;
    fn alone(bvh: &NativeBvh, ray: &Ray, counters: &mut TraceCounters) -> Self::Answer;
    /// The rays `which` of `rays` one at a time: [`Query::rest`] where the
    /// CPU runs no stream kernel.
    fn each_alone(
        bvh: &NativeBvh,
        rays: &[Ray],
        which: &[u32],
        out: &mut [Self::Answer],
        counters: &mut TraceCounters,
    ) {
        for &i in which {
            out[i as usize] = Self::alone(bvh, &rays[i as usize], counters);
        }
    }
    /// The rays of a batch that no packet takes (`which`: indices into
    /// `rays`, at most [`traverse::STREAM`]), walked together as one
    /// stream.
    fn rest(
        bvh: &NativeBvh,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        which: &[u32],
        out: &mut [Self::Answer],
        counters: &mut TraceCounters,
    );
    /// The packet `p`, its lanes of one octant or (`MIXED`) of any
    /// ([`packet::walk`]).
    ///
    /// # Safety
    /// From `W`'s `#[target_feature]` code, with a non-empty tree.
    unsafe fn packet<W: Width, const MIXED: bool>(
        bvh: &NativeBvh,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        p: &Packet<W>,
        out: &mut [Self::Answer],
        work: &mut Work,
    );
}

/// What a batch query does with a group of rays besides a packet.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub(super) struct Plan {
    /// Groups that form no packet wait for a stream's worth
    /// ([`Query::rest`]); else their rays go alone.
    pub streams: bool,
    /// A group whose every ray runs to infinity and whose origins spread
    /// wider than this across the first ray's direction forms no packet:
    /// parallel rays from scattered points (a directional light's shadow
    /// rays from a low-resolution frame's hits) share few nodes, and a
    /// packet walks the union of its rays' nodes
    /// ([`super::SCATTERED_FRACTION`]). Infinite: no group is refused.
    pub scattered: f32,
}

#[cfg(target_arch = "x86_64")]
impl Plan {
    /// Whether `rays` (one group) are parallel rays too scattered for a
    /// packet: looked at in scalar code before any lanes are filled.
    #[inline]
    fn refuses(self, rays: &[Ray]) -> bool {
        if self.scattered == f32::INFINITY || rays.iter().any(|r| r.t_max != f32::INFINITY) {
            return false;
        }
        // The origins' spread across the first ray's direction: points
        // along one line walk the same nodes.
        let d = rays[0].dir / rays[0].dir.length_squared();
        let (lo, hi) = rays.iter().fold(
            (glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY),
            |(lo, hi), r| {
                let across = r.origin - rays[0].dir * r.origin.dot(d);
                (lo.min(across), hi.max(across))
            },
        );
        (hi - lo).max_element() > self.scattered
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) struct Closest;

#[cfg(target_arch = "x86_64")]
pub(super) struct Occluded;

/// The packet's walk ([`packet::walk`], closest hits or, with `ANY`, any
/// hits) from the root for its lanes that enter the root box (the others
/// meet no triangle, as alone), with the fast box test where `test` asks
/// for it and every lane's constants fit, else the robust one.
///
/// # Safety
/// As [`packet::walk`].
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn walk_rooted<W: Width, const ANY: bool, const MIXED: bool, P: PacketLeaves<W>>(
    tree: &Tree,
    p: &Packet<W>,
    test: BoxTest,
    t_max: &mut [f32; MAX_LANES],
    leaves: &mut P,
    single: &mut impl FnMut(&mut P, usize, ChildRef, &mut f32, &mut Work) -> bool,
    work: &mut Work,
) -> u32 {
    let rooted = Packet {
        rays: p.rays,
        mask: p.mask & p.rays.rooted,
    };
    if rooted.mask == 0 {
        return 0;
    }
    // SAFETY: the caller keeps `packet::walk`'s contract.
    unsafe {
        if test == BoxTest::Fast && rooted.fast_test_fits() {
            packet::walk::<W, false, ANY, MIXED, P>(
                tree,
                &rooted,
                t_max,
                leaves,
                single,
                work,
                SINGLE_BELOW,
            )
        } else {
            packet::walk::<W, true, ANY, MIXED, P>(
                tree,
                &rooted,
                t_max,
                leaves,
                single,
                work,
                SINGLE_BELOW,
            )
        }
    }
}

/// Prepares a stream's rays (`which`, indices into `rays`): each one's
/// `t_max`, and the traceable ones as [`NativeBvh::closest`] prepares
/// them; returns those as a mask over `which`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn prepare_stream(
    rays: &[Ray],
    which: &[u32],
    box_rays: &mut [BoxRay; traverse::STREAM],
    t_max: &mut [f32; traverse::STREAM],
) -> u64 {
    let mut active = 0u64;
    for (k, &i) in which.iter().enumerate() {
        let ray = &rays[i as usize];
        if let Some((o, d)) = ray.traceable_vectors() {
            active |= 1 << k;
            box_rays[k] = BoxRay::new(o, d, ray.t_min);
        }
        t_max[k] = ray.t_max;
    }
    active
}

#[cfg(target_arch = "x86_64")]
impl Query for Closest {
    type Answer = Option<Hit>;
    const MISS: Option<Hit> = None;
    fn alone(bvh: &NativeBvh, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit> {
        let vectors = ray.traceable_vectors()?;
        bvh.closest(ray, vectors, counters)
    }

    /// As one stream ([`traverse::closest_stream`]), then spheres (if
    /// any) ray by ray within each ray's triangle hit.
    fn rest(
        bvh: &NativeBvh,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        which: &[u32],
        out: &mut [Option<Hit>],
        counters: &mut TraceCounters,
    ) {
        let Some(cpu) = bvh.cpu else {
            return Self::each_alone(bvh, rays, which, out, counters);
        };
        let mut work = Work::default();
        let unused = BoxRay::new(Vec3A::ZERO, Vec3A::X, 0.0);
        let mut box_rays = [unused; traverse::STREAM];
        let mut t_max = [0.0f32; traverse::STREAM];
        let mut leaves: [BlockLeaves; traverse::STREAM] = std::array::from_fn(|k| BlockLeaves {
            blocks,
            ray: &rays[which.get(k).copied().unwrap_or(0) as usize],
            best: None,
        });
        let active = prepare_stream(rays, which, &mut box_rays, &mut t_max);
        let n = which.len();
        let (tree, test) = (&bvh.triangles, bvh.box_test);
        traverse::closest_stream(
            tree,
            &box_rays[..n],
            &mut t_max[..n],
            active,
            &mut leaves[..n],
            cpu,
            test,
            &mut work,
        );
        for (k, &i) in which.iter().enumerate() {
            let mut hit = leaves[k].best.map(|(b, lane, u, v)| Hit {
                t: t_max[k],
                prim: blocks[b as usize].prim(lane),
                u,
                v,
            });
            if active >> k & 1 != 0 && !bvh.sphere_items.is_empty() {
                hit = bvh
                    .closest_sphere(&rays[i as usize], &box_rays[k], &mut t_max[k], &mut work)
                    .or(hit);
            }
            out[i as usize] = hit;
        }
        counters.box_tests += work.nodes * node::WIDTH as u64;
        counters.prim_tests += work.items;
    }

    /// Triangles together, then spheres (if any) ray by ray within each
    /// ray's triangle hit, as [`NativeBvh::closest`] does.
    #[inline(always)]
    unsafe fn packet<W: Width, const MIXED: bool>(
        bvh: &NativeBvh,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        p: &Packet<W>,
        out: &mut [Option<Hit>],
        work: &mut Work,
    ) {
        // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
        // enabled (a detected token chose this code) and the tree was checked by
        // `Tree::new`, so every node reference read from it is in range.
        unsafe {
            let mut t_max = p.rays.t_max();
            let (tree, test, cpu) = (&bvh.triangles, bvh.box_test, bvh.cpu);
            // Ray `i` alone from `start`, its hit kept in the packet's leaves.
            let mut alone =
                |leaves: &mut BlockPacket<W>, i: usize, start, t: &mut f32, work: &mut Work| {
                    // The lane's hit so far goes along: a tie at `t` is
                    // decided by its slot.
                    let mut one = BlockLeaves {
                        blocks,
                        ray: &rays[i],
                        best: leaves.get(i),
                    };
                    let box_ray = box_ray_of(&rays[i]);
                    let hit =
                        traverse::closest(tree, &box_ray, t, &mut one, cpu, test, work, start);
                    leaves.set(i, one.best);
                    hit
                };
            let mut leaves = BlockPacket::new(blocks, p.rays);
            let found = walk_rooted::<W, false, MIXED, _>(
                tree,
                p,
                test,
                &mut t_max,
                &mut leaves,
                &mut alone,
                work,
            );
            // Without spheres a miss is one store, and no lane's branch depends
            // on whether it hit.
            let all = if bvh.sphere_items.is_empty() {
                for i in lanes_of(p.mask & !found) {
                    out[i] = None;
                }
                found
            } else {
                p.mask
            };
            for i in lanes_of(all) {
                let mut hit = leaves.hit(i).map(|(prim, u, v)| Hit {
                    t: t_max[i],
                    prim,
                    u,
                    v,
                });
                if !bvh.sphere_items.is_empty() {
                    let box_ray = box_ray_of(&rays[i]);
                    hit = bvh
                        .closest_sphere(&rays[i], &box_ray, &mut t_max[i], work)
                        .or(hit);
                }
                out[i] = hit;
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl Query for Occluded {
    type Answer = bool;
    const MISS: bool = false;
    fn alone(bvh: &NativeBvh, ray: &Ray, counters: &mut TraceCounters) -> bool {
        ray.traceable_vectors()
            .is_some_and(|v| bvh.any(ray, v, counters))
    }

    /// As one stream ([`traverse::any_stream`]): incoherent occlusion rays
    /// share the nodes they enter (CBbunny's random shadow rays 1.3-1.4x
    /// single rays, AVX2; docs/experiments.md).
    fn rest(
        bvh: &NativeBvh,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        which: &[u32],
        out: &mut [bool],
        counters: &mut TraceCounters,
    ) {
        let Some(cpu) = bvh.cpu else {
            return Self::each_alone(bvh, rays, which, out, counters);
        };
        let mut work = Work::default();
        let unused = BoxRay::new(Vec3A::ZERO, Vec3A::X, 0.0);
        let mut box_rays = [unused; traverse::STREAM];
        let mut t_max = [0.0f32; traverse::STREAM];
        let active = prepare_stream(rays, which, &mut box_rays, &mut t_max);
        let n = which.len();
        let mut leaves = |k: usize| BlockLeaves {
            blocks,
            ray: &rays[which[k] as usize],
            best: None,
        };
        let (tree, test) = (&bvh.triangles, bvh.box_test);
        let blocked = traverse::any_stream(
            tree,
            &box_rays[..n],
            &t_max[..n],
            active,
            &mut leaves,
            cpu,
            test,
            &mut work,
        );
        for (k, &i) in which.iter().enumerate() {
            let ray = &rays[i as usize];
            out[i as usize] = blocked >> k & 1 != 0
                || (active >> k & 1 != 0
                    && !bvh.sphere_items.is_empty()
                    && bvh.any_sphere(ray, &box_rays[k], &mut work));
        }
        counters.box_tests += work.nodes * node::WIDTH as u64;
        counters.prim_tests += work.items;
    }

    /// Triangles together, then spheres ray by ray for those not blocked,
    /// as [`NativeBvh::any`] does.
    #[inline(always)]
    unsafe fn packet<W: Width, const MIXED: bool>(
        bvh: &NativeBvh,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        p: &Packet<W>,
        out: &mut [bool],
        work: &mut Work,
    ) {
        // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
        // enabled (a detected token chose this code) and the tree was checked by
        // `Tree::new`, so every node reference read from it is in range.
        unsafe {
            let mut t_max = p.rays.t_max();
            let (tree, test, cpu) = (&bvh.triangles, bvh.box_test, bvh.cpu);
            let mut alone =
                |_: &mut BlockPacket<W>, i: usize, start, t: &mut f32, work: &mut Work| {
                    let mut one = BlockLeaves {
                        blocks,
                        ray: &rays[i],
                        best: None,
                    };
                    let box_ray = box_ray_of(&rays[i]);
                    traverse::any(tree, &box_ray, *t, &mut one, cpu, test, work, start)
                };
            let mut leaves = BlockPacket::new(blocks, p.rays);
            let blocked = walk_rooted::<W, true, MIXED, _>(
                tree,
                p,
                test,
                &mut t_max,
                &mut leaves,
                &mut alone,
                work,
            );
            for i in lanes_of(p.mask) {
                out[i] = blocked & (1 << i) != 0
                    || (!bvh.sphere_items.is_empty()
                        && bvh.any_sphere(&rays[i], &box_ray_of(&rays[i]), work));
            }
        }
    }
}

impl NativeBvh {
    /// Whether a group of up to `W::N` rays of a batch query forms a
    /// packet: its rays in lanes when an octant holds [`min_packet`] of
    /// them (traceable or not), or the tree takes packets of mixed octants
    /// and the group has that many rays; `None` otherwise, having cost the
    /// transposition and no more.
    ///
    /// # Safety
    /// From `W`'s `#[target_feature]` code.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn forms<W: Width>(&self, rays: &[Ray]) -> Option<[W::V; 8]> {
        // SAFETY: the caller runs with the width's CPU features enabled.
        unsafe {
            let fields = W::fields(rays);
            (self.mixed_packets && rays.len() >= min_packet(W::N) as usize
                || packet::octant_holds::<W>(&fields, rays.len(), min_packet(W::N)))
            .then_some(fields)
        }
    }

    /// The packets of a group of up to `W::N` rays whose fields are
    /// `fields` ([`Self::forms`]): the traceable ones of each octant as a
    /// packet when there are [`min_packet`] of them; the others as one
    /// packet of mixed octants where the tree takes them and they are as
    /// many, else one at a time.
    ///
    /// # Safety
    /// From `W`'s `#[target_feature]` code; the triangle tree is not
    /// empty.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn packets<W: Width, Q: Query>(
        &self,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        fields: &[W::V; 8],
        out: &mut [Q::Answer],
        counters: &mut TraceCounters,
    ) {
        // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
        // enabled (a detected token chose this code) and the tree was checked by
        // `Tree::new`, so every node reference read from it is in range.
        unsafe {
            let prepared =
                PacketRays::<W>::from_fields(*fields, rays.len(), self.triangles.bounds());
            let mut rest = prepared.traceable;
            let lanes = (1u32 << out.len()) - 1;
            for i in lanes_of(lanes & !rest) {
                out[i] = Q::MISS;
            }
            let mut work = Work::default();
            // Lanes of octants too small for a packet of their own.
            let mut few = 0;
            while rest != 0 {
                let group = prepared.same_octant(rest);
                rest &= !group;
                if group.count_ones() >= min_packet(W::N) {
                    let p = Packet {
                        rays: &prepared,
                        mask: group,
                    };
                    Q::packet::<W, false>(self, blocks, rays, &p, out, &mut work);
                } else {
                    few |= group;
                }
            }
            if self.mixed_packets && few.count_ones() >= min_packet(W::N) {
                let p = Packet {
                    rays: &prepared,
                    mask: few,
                };
                Q::packet::<W, true>(self, blocks, rays, &p, out, &mut work);
            } else {
                for i in lanes_of(few) {
                    out[i] = Q::alone(self, &rays[i], counters);
                }
            }
            counters.box_tests += work.nodes * node::WIDTH as u64;
            counters.prim_tests += work.items;
        }
    }

    /// A group of a batch query in AVX2 registers, eight rays ([`X8`]) or
    /// sixteen in two registers per value ([`X8x2`]): traced as packets
    /// when it forms one ([`Self::forms`]), else false with nothing traced.
    ///
    /// # Safety
    /// The CPU has AVX2 (the caller holds the token); the triangle tree is
    /// not empty.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    unsafe fn group_avx2<W: Width, Q: Query>(
        &self,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        out: &mut [Q::Answer],
        counters: &mut TraceCounters,
    ) -> bool {
        // SAFETY: AVX2 and FMA are enabled here, which is all either AVX2
        // width needs, and the caller keeps the tree's contract.
        unsafe {
            let Some(fields) = self.forms::<W>(rays) else {
                return false;
            };
            self.packets::<W, Q>(blocks, rays, &fields, out, counters);
            true
        }
    }

    /// [`Self::group_avx2`] with sixteen rays in AVX-512 lanes.
    ///
    /// # Safety
    /// The CPU has AVX-512F and AVX2 (the caller holds the token); the
    /// triangle tree is not empty.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    unsafe fn group16<Q: Query>(
        &self,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        out: &mut [Q::Answer],
        counters: &mut TraceCounters,
    ) -> bool {
        // SAFETY: AVX-512F is enabled here, which X16 needs, and the
        // caller keeps the tree's contract.
        unsafe {
            let Some(fields) = self.forms::<X16>(rays) else {
                return false;
            };
            self.packets::<X16, Q>(blocks, rays, &fields, out, counters);
            true
        }
    }

    /// A batch query through the packet kernels this tree may run; `None`
    /// when it may not (no AVX2, watertight triangles, no triangles). The
    /// rays that form no packet, or whose group `plan` refuses one, go as
    /// streams ([`Query::rest`]) where it says, else alone.
    #[cfg(target_arch = "x86_64")]
    pub(super) fn batch<Q: Query>(
        &self,
        rays: &[Ray],
        out: &mut [Q::Answer],
        counters: &mut TraceCounters,
        plan: Plan,
    ) -> Option<()> {
        let TriangleStore::Blocks(blocks) = &self.triangle_store else {
            return None;
        };
        if self.triangles.is_empty() {
            return None;
        }
        type Group<Q> = unsafe fn(
            &NativeBvh,
            &[TriangleBlock4],
            &[Ray],
            &mut [<Q as Query>::Answer],
            &mut TraceCounters,
        ) -> bool;
        let (group, lanes): (Group<Q>, usize) = match self.packets {
            PacketKernels::Avx512(_) => (Self::group16::<Q>, 16),
            PacketKernels::Avx2(_) => (Self::group_avx2::<X8, Q>, 8),
            PacketKernels::Avx2Wide(_) => (Self::group_avx2::<X8x2, Q>, 16),
            PacketKernels::None => return None,
        };
        // Rays of groups that form no packet, traced together once there
        // are a stream's worth.
        let mut pending = [0u32; traverse::STREAM];
        let mut waiting = 0;
        // Whether the last group formed a packet. After one that did not,
        // the next is asked in scalar code first ([`packet_can_form`]), so
        // that an incoherent batch does not transpose every group only to
        // send its rays alone; a coherent one goes straight to the lanes.
        let mut formed = true;
        for start in (0..rays.len()).step_by(lanes) {
            let end = rays.len().min(start + lanes);
            let group_rays = &rays[start..end];
            counters.rays += group_rays.len() as u64;
            // The rays of the group after next, half a cache line each:
            // their first loads otherwise wait for memory.
            let ahead = rays.as_ptr().wrapping_add(start + PREFETCH_GROUPS * lanes);
            for line in 0..lanes / 2 {
                let line = ahead.cast::<i8>().wrapping_add(64 * line);
                // SAFETY: SSE is in every x86_64 CPU, and a prefetch never
                // faults, whatever the address.
                unsafe {
                    std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(line)
                };
            }
            // SAFETY: the kernels were chosen by the token that proves
            // their CPU features; the triangle tree is not empty (checked
            // above).
            formed = (formed
                || self.mixed_packets
                || packet::packet_can_form(group_rays, min_packet(lanes)))
                && !plan.refuses(group_rays)
                && unsafe { group(self, blocks, group_rays, &mut out[start..end], counters) };
            if formed {
                continue;
            }
            if !plan.streams {
                // No packet can form: the rays go alone, as single-ray
                // queries do, outside the lanes' code (traced from inside
                // it, incoherent batches ran at 0.93x single rays).
                for (ray, answer) in group_rays.iter().zip(&mut out[start..end]) {
                    *answer = Q::alone(self, ray, counters);
                }
                continue;
            }
            // Or they wait for a stream's worth, traced together.
            for i in start..end {
                pending[waiting] = i as u32;
                waiting += 1;
                if waiting == traverse::STREAM {
                    Q::rest(self, blocks, rays, &pending, out, counters);
                    waiting = 0;
                }
            }
        }
        if waiting > 0 {
            Q::rest(self, blocks, rays, &pending[..waiting], out, counters);
        }
        Some(())
    }
}

mod kernels;
#[cfg(all(test, target_arch = "x86_64"))]
mod tests;

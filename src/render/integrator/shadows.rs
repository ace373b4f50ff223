//! Where direct lighting's terms and shadow rays go: traced at once, one
//! shadow ray at a time, or recorded on a tape with many paths' others and
//! answered by one batch query. Both sum the same terms in the same order.

use glam::Vec3;

use crate::accel::{Accel, TraceCounters};
use crate::geom::Ray;

/// Direct lighting's running sum at one vertex: each group's terms (the
/// samples of one light, or one light group) in order, then the group's
/// mean added to the sum.
#[derive(Clone, Copy, Default)]
pub(in crate::render) struct DirectSum {
    pub(in crate::render) sum: Vec3,
    group: Vec3,
}

impl DirectSum {
    pub(in crate::render) fn add(&mut self, term: Vec3) {
        self.group += term;
    }

    /// Closes a group of `n` terms.
    pub(in crate::render) fn mean(&mut self, n: u32) {
        self.sum += self.group / n as f32;
        self.group = Vec3::ZERO;
    }
}

/// Where direct lighting's terms go: answered at once, one shadow ray at
/// a time ([`Now`]), or recorded with their shadow rays for one batch
/// query over many paths ([`Deferred`], [`ShadowTape`]). Both sum the same
/// terms in the same order, so the two give the same bits.
pub(in crate::render) trait Shadows {
    /// A term without a shadow ray.
    fn term(&mut self, term: Vec3);
    /// A term that counts unless `shadow` is blocked (zero then).
    fn unless_blocked(&mut self, shadow: &Ray, term: impl FnOnce() -> Vec3);
    /// Closes a group of `n` terms: its mean joins the sum.
    fn mean(&mut self, n: u32);
    /// The counters the vertex's other rays (hemisphere sampling's) count
    /// in.
    fn counters(&mut self) -> &mut TraceCounters;
}

/// Shadow rays traced one at a time as direct lighting asks.
pub(in crate::render) struct Now<'c, A> {
    pub(in crate::render) accel: &'c A,
    pub(in crate::render) counters: &'c mut TraceCounters,
    pub(in crate::render) sum: DirectSum,
}

impl<A: Accel> Shadows for Now<'_, A> {
    fn term(&mut self, term: Vec3) {
        self.sum.add(term);
    }

    fn unless_blocked(&mut self, shadow: &Ray, term: impl FnOnce() -> Vec3) {
        let blocked = self.accel.occluded(shadow, self.counters);
        self.sum.add(if blocked { Vec3::ZERO } else { term() });
    }

    fn mean(&mut self, n: u32) {
        self.sum.mean(n);
    }

    fn counters(&mut self) -> &mut TraceCounters {
        self.counters
    }
}

/// The direct lighting of many paths' vertices (the wavefront's paths
/// that the lanes do not step): each one's terms, and the shadow rays they
/// wait on, which the caller answers with one batch query
/// ([`Accel::occluded_all`]) before the paths go on.
#[derive(Default)]
pub struct ShadowTape {
    terms: Vec<Term>,
    rays: Vec<Ray>,
}

#[derive(Clone, Copy)]
enum Term {
    Value(Vec3),
    /// Counts unless the tape's next shadow ray is blocked.
    UnlessBlocked(Vec3),
    Mean(u32),
}

/// One vertex's part of a tape: its terms, and where its shadow rays
/// start.
#[derive(Clone, Copy, Debug)]
pub(in crate::render) struct Span {
    first_term: u32,
    end_term: u32,
    first_ray: u32,
}

impl Span {
    /// The part of `tape` written since it held `first_term` terms and
    /// `first_ray` rays ([`ShadowTape::ends`]).
    pub(in crate::render) fn since(first_term: u32, first_ray: u32, tape: &ShadowTape) -> Span {
        Span {
            first_term,
            end_term: tape.ends().0,
            first_ray,
        }
    }
}

impl ShadowTape {
    /// The bytes the tape's lists hold.
    pub fn held_bytes(&self) -> usize {
        crate::render::times::held(&self.terms) + crate::render::times::held(&self.rays)
    }

    /// How many terms and rays the tape holds: where the next vertex's
    /// part starts. A tape holds one wave's paths, far fewer than 2^32
    /// terms.
    pub(in crate::render) fn ends(&self) -> (u32, u32) {
        (self.terms.len() as u32, self.rays.len() as u32)
    }

    /// Empties the tape for the next batch of paths.
    pub fn clear(&mut self) {
        self.terms.clear();
        self.rays.clear();
    }

    /// The shadow rays the paused paths wait on, in order.
    pub fn rays(&self) -> &[Ray] {
        &self.rays
    }

    /// The direct lighting of `span`, given which of the tape's rays are
    /// blocked: the sum [`Now`] gives.
    pub(in crate::render) fn sum(&self, span: &Span, blocked: &[bool]) -> Vec3 {
        let mut sum = DirectSum::default();
        let mut ray = span.first_ray as usize;
        for term in &self.terms[span.first_term as usize..span.end_term as usize] {
            match *term {
                Term::Value(v) => sum.add(v),
                Term::UnlessBlocked(v) => {
                    sum.add(if blocked[ray] { Vec3::ZERO } else { v });
                    ray += 1;
                }
                Term::Mean(n) => sum.mean(n),
            }
        }
        sum.sum
    }
}

/// Records direct lighting's terms and shadow rays on a tape.
pub(in crate::render) struct Deferred<'t> {
    pub(in crate::render) tape: &'t mut ShadowTape,
    pub(in crate::render) counters: &'t mut TraceCounters,
}

impl Shadows for Deferred<'_> {
    fn term(&mut self, term: Vec3) {
        self.tape.terms.push(Term::Value(term));
    }

    fn unless_blocked(&mut self, shadow: &Ray, term: impl FnOnce() -> Vec3) {
        self.tape.rays.push(*shadow);
        self.tape.terms.push(Term::UnlessBlocked(term()));
    }

    fn mean(&mut self, n: u32) {
        self.tape.terms.push(Term::Mean(n));
    }

    fn counters(&mut self) -> &mut TraceCounters {
        self.counters
    }
}

//! What the path tracer is asked to compute: the direct-lighting
//! estimator, the bounces shown, Russian roulette and the background.

/// How direct lighting is estimated at a diffuse or glossy vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum DirectEstimator {
    /// Uniform directions over the hemisphere, traced to whatever emits.
    Hemisphere,
    /// Points sampled on the lights, tested with shadow rays.
    LightSampling,
    /// Light sampling and BSDF sampling combined by the power heuristic.
    #[default]
    Mis,
}

crate::choice!(DirectEstimator { Mis => "mis", LightSampling => "light", Hemisphere => "hemisphere" });

/// Which bounces an image shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BounceView {
    #[default]
    All,
    /// Emitted light seen directly and direct lighting (bounces 0 and 1).
    Direct,
    /// Light that scattered at least twice.
    Indirect,
}

crate::choice!(BounceView { All => "all", Direct => "direct", Indirect => "indirect" });

/// What camera rays that miss the scene see.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Background {
    /// The sky: the ambient light above the horizon and the environment
    /// map (physical).
    #[default]
    Sky,
    /// Black, as in the course's gallery; the sky still lights the scene.
    Black,
}

crate::choice!(Background { Sky => "sky", Black => "black" });

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSettings {
    pub estimator: DirectEstimator,
    /// Samples per area (and ambient) light, or hemisphere samples.
    pub light_samples: u32,
    pub max_bounces: u32,
    /// False: only bounce `max_bounces` is shown (`-o 0`).
    pub accumulate: bool,
    pub view: BounceView,
    /// Russian roulette continuation probability, from the second vertex on.
    pub russian_roulette: Option<f32>,
    pub background: Background,
}

impl Default for PathSettings {
    fn default() -> Self {
        PathSettings {
            estimator: DirectEstimator::Mis,
            light_samples: 1,
            max_bounces: 1,
            accumulate: true,
            view: BounceView::All,
            russian_roulette: None,
            background: Background::Sky,
        }
    }
}

impl PathSettings {
    /// The last bounce the image shows: paths stop there (0 when it shows
    /// none, say `--only direct -o 0 -m 5`).
    pub fn last_bounce(&self) -> u32 {
        let top = match self.view {
            BounceView::Direct => self.max_bounces.min(1),
            _ => self.max_bounces,
        };
        if self.accumulate || self.counts(top) {
            top
        } else {
            0
        }
    }

    /// Whether the image shows bounce `bounce`.
    #[inline]
    pub(crate) fn counts(&self, bounce: u32) -> bool {
        let in_range = if self.accumulate {
            bounce <= self.max_bounces
        } else {
            bounce == self.max_bounces
        };
        in_range
            && match self.view {
                BounceView::All => true,
                BounceView::Direct => bounce <= 1,
                BounceView::Indirect => bounce >= 2,
            }
    }
}

/// What the renderer computes per camera ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shading {
    /// Colour = shading normal * 0.5 + 0.5 at the first hit.
    Normals,
    Path(PathSettings),
}

//! What a render's time and memory went to, by phase: the one leaf every
//! scheduler and the report share.

/// Where the wavefront's time went, in seconds of the threads that
/// rendered (summed over them): its batch queries of extension rays and of
/// shadow rays, and the rest, which steps the paths (shading each hit,
/// choosing its light samples and next direction) and gathers the moving
/// paths' rays. Each phase is timed once per bounce of a wave, a few clock
/// reads per thousand paths. Zero in the reference mode. With them, the
/// memory a wave held: the most bytes any one row's lists reached (a
/// thread renders one row at a time), the most over the rows.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WaveTimes {
    pub closest: f64,
    pub occluded: f64,
    pub paths: f64,
    /// Where the stepping (`paths`) went, step by step.
    pub steps: Steps,
    pub peak_bytes: usize,
}

/// The stepping of a wavefront's wave, in seconds, by what it does: taking
/// each path's hit (the sky or emission it sees, its vertex gathered, its
/// surface point and shading frame), sampling the lights (each vertex's
/// light samples and the gathering of their shadow rays), and leaving
/// (the direct light summed once the shadow rays are answered, Russian
/// roulette, the BSDF's sample and the next rays gathered).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Steps {
    pub arrive: f64,
    pub light: f64,
    pub leave: f64,
}

impl Steps {
    /// Each step's share of the stepping it breaks down, in the fields'
    /// order; `None` when nothing was timed.
    pub fn shares(&self) -> Option<[f64; 3]> {
        let total = self.arrive + self.light + self.leave;
        (total > 0.0).then(|| [self.arrive, self.light, self.leave].map(|t| t / total))
    }
}

impl std::ops::AddAssign for Steps {
    fn add_assign(&mut self, o: Steps) {
        self.arrive += o.arrive;
        self.light += o.light;
        self.leave += o.leave;
    }
}

impl WaveTimes {
    pub fn total(&self) -> f64 {
        self.closest + self.occluded + self.paths
    }

    /// Each phase's share of the total, in the fields' order (zeros when
    /// nothing was timed).
    pub fn shares(&self) -> [f64; 3] {
        let total = self.total();
        if total <= 0.0 {
            return [0.0; 3];
        }
        [self.closest, self.occluded, self.paths].map(|t| t / total)
    }
}

impl std::ops::AddAssign for WaveTimes {
    fn add_assign(&mut self, o: WaveTimes) {
        self.closest += o.closest;
        self.occluded += o.occluded;
        self.paths += o.paths;
        self.steps += o.steps;
        self.peak_bytes = self.peak_bytes.max(o.peak_bytes);
    }
}

/// The bytes `list`'s allocation holds.
pub fn held<T>(list: &Vec<T>) -> usize {
    list.capacity() * std::mem::size_of::<T>()
}

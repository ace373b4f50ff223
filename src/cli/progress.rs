//! `hybrid render`'s progress bar.

use std::io::IsTerminal;

use crate::render::{Progress, RenderSettings};

/// A progress bar on stderr counting camera samples (hidden when stderr
/// is not a terminal). With adaptive sampling the total is not known in
/// advance: it is re-estimated from the rows done, which the renderer
/// takes in a scattered order.
pub(super) struct Bar {
    bar: indicatif::ProgressBar,
    rows: u64,
    adaptive: bool,
    done: std::sync::Mutex<(u64, u64)>,
}

impl Bar {
    /// Clears the bar from the terminal.
    pub(super) fn finish(&self) {
        self.bar.finish_and_clear();
    }

    pub(super) fn new(settings: &RenderSettings) -> Bar {
        let (width, rows) = settings
            .cell
            .map_or((settings.width, settings.height), |c| (c.width, c.height));
        let per_pixel = match settings.sample_range {
            Some((a, b)) => b - a,
            None => settings.samples,
        };
        let total = u64::from(width) * u64::from(rows) * u64::from(per_pixel);
        let bar = indicatif::ProgressBar::with_draw_target(
            Some(total),
            indicatif::ProgressDrawTarget::stderr(),
        );
        if !std::io::stderr().is_terminal() {
            bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
        }
        let adaptive = settings.adaptive.is_some();
        let template = if adaptive {
            "rendering [{bar:40}] {human_pos} of ~{human_len} samples (adaptive), {elapsed} elapsed, ~{eta} left"
        } else {
            "rendering [{bar:40}] {human_pos}/{human_len} samples, {elapsed} elapsed, ~{eta} left"
        };
        if let Ok(style) = indicatif::ProgressStyle::with_template(template) {
            bar.set_style(style.progress_chars("=> "));
        }
        Bar {
            bar,
            rows: u64::from(rows),
            adaptive,
            done: std::sync::Mutex::new((0, 0)),
        }
    }
}

impl Progress for Bar {
    fn row_done(&self, samples: u64) {
        self.bar.inc(samples);
        if self.adaptive {
            let Ok(mut done) = self.done.lock() else {
                return;
            };
            done.0 += 1;
            done.1 += samples;
            let (rows, taken) = *done;
            self.bar.set_length(taken * self.rows / rows);
        }
    }
}

//! The one frame-timing loop: warm-up frames, then measured repeats; the median of every stage,
//! the fastest total and the median wall-clock time of a frame. `tetbench bench`, `render`,
//! `jbu` and the BCC tables all time frames through [`measure`] (or, for A B A B comparisons
//! inside one run, [`measure_interleaved`], the same loop over several cases in turn).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use algorithms::camera::Camera;
use algorithms::image::Image;
use algorithms::render::{Frame, FrameTimes, Renderer};
use algorithms::{Mesh, Result};

use crate::stats;

/// Set by the Ctrl-C handler; measuring stops at the next frame boundary.
pub static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Whether the user asked to stop.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::Relaxed)
}

/// How many frames: thrown-away warm-up frames, then measured ones (at least one).
#[derive(Clone, Copy, Debug)]
pub struct Frames {
    pub warmup: usize,
    pub repeats: usize,
}

/// One renderer, prepared for `mesh`, to be timed with `camera`.
pub struct Case<'a> {
    pub renderer: &'a mut dyn Renderer,
    pub mesh: &'a Mesh,
    pub camera: Camera,
}

/// What the measured frames of one case gave.
#[derive(Clone, Debug)]
pub struct Measured {
    /// The last measured frame's image and counters.
    pub image: Image,
    pub counters: Vec<(&'static str, f64)>,
    /// Median of each stage over the measured frames (the renderer's own stage times).
    pub times: FrameTimes,
    /// The fastest measured `total_ms`.
    pub total_min_ms: f64,
    /// Median wall-clock time of one `render` call, in ms.
    pub wall_ms: f64,
    /// Frames measured (fewer than asked when interrupted).
    pub frames: usize,
}

/// Times one case: `frames.warmup` frames thrown away, then `frames.repeats` measured.
pub fn measure(
    renderer: &mut dyn Renderer,
    mesh: &Mesh,
    camera: &Camera,
    frames: Frames,
) -> Result<Measured> {
    let mut cases = [Case {
        renderer,
        mesh,
        camera: *camera,
    }];
    Ok(measure_interleaved(&mut cases, frames)?.remove(0))
}

/// Times several cases A B A B …: each case's warm-up frames, then `frames.repeats` rounds that
/// render every case once in turn, so that load from other processes falls on all alike.
pub fn measure_interleaved(cases: &mut [Case<'_>], frames: Frames) -> Result<Vec<Measured>> {
    measure_each(cases.len(), frames, |k| {
        let c = &mut cases[k];
        c.renderer.render(c.mesh, &c.camera)
    })
}

/// The loop itself, over `n` cases that `frame(k)` renders (a renderer, or any other image
/// producer such as a regular-volume ray caster, whose stage times may stay 0: its
/// [`Measured::wall_ms`] is still measured here).
pub fn measure_each(
    n: usize,
    frames: Frames,
    mut frame: impl FnMut(usize) -> Result<Frame>,
) -> Result<Vec<Measured>> {
    for k in 0..n {
        for _ in 0..frames.warmup {
            frame(k)?;
        }
    }
    let mut times: Vec<Vec<FrameTimes>> = vec![Vec::new(); n];
    let mut wall: Vec<Vec<f64>> = vec![Vec::new(); n];
    let mut last: Vec<Frame> = Vec::with_capacity(n);
    for round in 0..frames.repeats.max(1) {
        for k in 0..n {
            let t0 = Instant::now();
            let f = frame(k)?;
            wall[k].push(t0.elapsed().as_secs_f64() * 1e3);
            times[k].push(f.times);
            if round == 0 {
                last.push(f);
            } else {
                last[k] = f;
            }
        }
        if interrupted() {
            break;
        }
    }
    Ok(last
        .into_iter()
        .enumerate()
        .map(|(k, f)| {
            let t = &times[k];
            let med =
                |g: fn(&FrameTimes) -> f64| stats::median(&t.iter().map(g).collect::<Vec<_>>());
            Measured {
                image: f.image,
                counters: f.counters,
                times: FrameTimes {
                    project_ms: med(|t| t.project_ms),
                    sort_ms: med(|t| t.sort_ms),
                    draw_ms: med(|t| t.draw_ms),
                    readback_ms: med(|t| t.readback_ms),
                    total_ms: med(|t| t.total_ms),
                },
                total_min_ms: stats::min(&t.iter().map(|t| t.total_ms).collect::<Vec<_>>()),
                wall_ms: stats::median(&wall[k]),
                frames: t.len(),
            }
        })
        .collect())
}

//! The one frame-timing loop: warm-up frames, then measured repeats; the median of every stage,
//! the fastest total and the median wall-clock time of a frame. `tetbench bench`, `render`,
//! `jbu` and the BCC tables all time frames through [`measure`] (or, for A B A B comparisons
//! inside one run, [`measure_interleaved`], the same loop over several cases in turn).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use algorithms::camera::Camera;
use algorithms::image::Image;
use algorithms::render::{Frame, FrameTimes, Renderer};
use algorithms::{util::alloc, Mesh, Result};

use crate::stats;

/// Set by the Ctrl-C handler that `main` installs; measuring stops at the next frame boundary.
/// The harness's one piece of process-wide state: a signal handler can reach nothing else. Read
/// it through [`interrupted`].
pub static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Whether the user asked to stop.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::Relaxed)
}

/// `prepare`, run under the counting allocator after the process-wide state is built
/// ([`algorithms::warm_process_state`]: counted in whichever variant came first, it made bytes
/// per tet depend on the order of the variants): its result, the heap bytes it left allocated
/// and its peak above the start (see [`alloc::measure`]).
pub fn prepare_counted<T>(renderer: &str, prepare: impl FnOnce() -> T) -> (T, isize, isize) {
    algorithms::warm_process_state(renderer);
    alloc::measure(prepare)
}

/// The heap bytes of the process-wide state kept out of every renderer's `cpu_bytes_per_tet`
/// ([`algorithms::shared_state_bytes`]).
pub fn shared_fixed_bytes() -> usize {
    algorithms::shared_state_bytes()
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
        .map(|(k, f)| summarise(f, &times[k], &wall[k]))
        .collect())
}

/// The medians of one case's measured frames (`last`: the last of them).
fn summarise(last: Frame, t: &[FrameTimes], wall: &[f64]) -> Measured {
    let med = |g: fn(&FrameTimes) -> f64| stats::median(&t.iter().map(g).collect::<Vec<_>>());
    Measured {
        image: last.image,
        counters: last.counters,
        times: FrameTimes {
            project_ms: med(|t| t.project_ms),
            sort_ms: med(|t| t.sort_ms),
            draw_ms: med(|t| t.draw_ms),
            readback_ms: med(|t| t.readback_ms),
            total_ms: med(|t| t.total_ms),
        },
        total_min_ms: stats::min(&t.iter().map(|t| t.total_ms).collect::<Vec<_>>()),
        wall_ms: stats::median(wall),
        frames: t.len(),
    }
}

/// One frame of [`measure_rounds`]: case `k`, warm-up or measured round `round` (0-based in
/// each kind).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Turn {
    pub case: usize,
    pub warmup: bool,
    pub round: usize,
}

/// Times `n` cases in rounds: `frames.warmup` warm-up rounds (A B C …, thrown away), then
/// `frames.repeats` measured rounds A B C …, so that load from other processes and the
/// machine's drift fall on all cases alike (the experiment key `interleave`). A case whose frame
/// fails drops out with its error; the others go on. `turn` is called before every frame, in
/// the order they run (the harness records it in `order.csv`).
pub fn measure_rounds(
    n: usize,
    frames: Frames,
    mut frame: impl FnMut(usize) -> Result<Frame>,
    mut turn: impl FnMut(Turn),
) -> Vec<Result<Measured>> {
    let mut failed: Vec<Option<algorithms::Error>> = (0..n).map(|_| None).collect();
    for round in 0..frames.warmup {
        for (k, fail) in failed.iter_mut().enumerate() {
            if fail.is_none() {
                turn(Turn {
                    case: k,
                    warmup: true,
                    round,
                });
                if let Err(e) = frame(k) {
                    *fail = Some(e);
                }
            }
        }
    }
    let mut times: Vec<Vec<FrameTimes>> = vec![Vec::new(); n];
    let mut wall: Vec<Vec<f64>> = vec![Vec::new(); n];
    let mut last: Vec<Option<Frame>> = (0..n).map(|_| None).collect();
    for round in 0..frames.repeats.max(1) {
        for k in 0..n {
            if failed[k].is_some() {
                continue;
            }
            turn(Turn {
                case: k,
                warmup: false,
                round,
            });
            let t0 = Instant::now();
            match frame(k) {
                Ok(f) => {
                    wall[k].push(t0.elapsed().as_secs_f64() * 1e3);
                    times[k].push(f.times);
                    last[k] = Some(f);
                }
                Err(e) => failed[k] = Some(e),
            }
        }
        if interrupted() {
            break;
        }
    }
    failed
        .into_iter()
        .zip(last)
        .enumerate()
        .map(|(k, (e, f))| match (e, f) {
            (Some(e), _) => Err(e),
            (None, Some(f)) => Ok(summarise(f, &times[k], &wall[k])),
            (None, None) => Err(algorithms::Error::Internal(
                "interrupted before the first measured frame".into(),
            )),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `measure_rounds` runs the warm-up rounds, then the measured rounds, each case once per
    /// round in turn (A B C A B C …); a failing case drops out with its error, the others keep
    /// their place; each case's medians are of its own frames.
    #[test]
    fn rounds_interleave_cases_and_isolate_failures() {
        let frames = Frames {
            warmup: 1,
            repeats: 3,
        };
        let mut calls = [0usize; 3];
        let mut turns = Vec::new();
        let out = measure_rounds(
            3,
            frames,
            |k| {
                calls[k] += 1;
                // Case 2 fails on its third frame (the second measured one).
                if k == 2 && calls[k] == 3 {
                    return Err(algorithms::Error::Input("boom".into()));
                }
                Ok(Frame {
                    image: Image::new(1, 1),
                    times: FrameTimes {
                        total_ms: (10 * k + calls[k]) as f64,
                        ..Default::default()
                    },
                    counters: Vec::new(),
                })
            },
            |t| turns.push((t.case, t.warmup, t.round)),
        );
        let want = vec![
            (0, true, 0),
            (1, true, 0),
            (2, true, 0),
            (0, false, 0),
            (1, false, 0),
            (2, false, 0),
            (0, false, 1),
            (1, false, 1),
            (2, false, 1),
            (0, false, 2),
            (1, false, 2),
        ];
        assert_eq!(turns, want);
        let m0 = out[0].as_ref().unwrap();
        assert_eq!(m0.frames, 3);
        // Case 0's measured frames are its calls 2, 3, 4: median 3.
        assert_eq!(m0.times.total_ms, 3.0);
        assert_eq!(out[1].as_ref().unwrap().times.total_ms, 13.0);
        assert!(out[2].as_ref().unwrap_err().to_string().contains("boom"));
    }
}

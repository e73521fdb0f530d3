//! The transfer-function table looked up a vector of lanes at a time, for `cpu-pt`'s
//! fragments whose tet has no line ([`TfTable::line_over`]): `render/cpu_pt/queue.rs`.

use super::{float_index, floor_in, TfTable};

impl TfTable {
    /// [`TfTable::eval`] at `N` scalars (`N` a multiple of 4), channel-major: `out[c][k]` is
    /// channel `c` at `s[k]`, with `eval`'s operations on each value, so its bits (a NaN `s`,
    /// which `eval` is not given, gives NaN here too). The sample index and weight are computed
    /// a vector at a time ([`floor_in`] and [`float_index`], as `psi_at`); each value is then one
    /// 16-byte lerp, and four are turned into the channel planes by a 4×4 transpose: the
    /// lane-by-lane `eval` took ~95 instructions a `partial` fragment on this path.
    #[inline(always)]
    pub fn eval_lanes<const N: usize>(&self, s: &[f32; N], out: &mut [[f32; N]; 4]) {
        use glam::{Mat4, Vec4};
        const { assert!(N.is_multiple_of(4)) };
        let top = (self.data.len() - 2) as f32;
        let (mut idx, mut t) = ([0u32; N], [0.0f32; N]);
        for k in 0..N {
            let x = ((s[k] - self.lo) * self.scale).clamp(0.0, self.max);
            // `(x as i32 as usize).min(len − 2)` (x ≥ 0: floor is the truncation; NaN: 0).
            let i = floor_in(x, top);
            idx[k] = float_index(i);
            t[k] = x - i;
        }
        let d = &self.data[..];
        let lerp = |k: usize| {
            let i = idx[k] as usize;
            // SAFETY: i ≤ top = len − 2 (the clamp above), so i + 1 < len.
            let (a, b) = unsafe { (*d.get_unchecked(i), *d.get_unchecked(i + 1)) };
            let (a, b) = (Vec4::from_array(a), Vec4::from_array(b));
            a + (b - a) * t[k]
        };
        for k in (0..N).step_by(4) {
            let m = Mat4::from_cols(lerp(k), lerp(k + 1), lerp(k + 2), lerp(k + 3)).transpose();
            for (o, c) in out.iter_mut().zip(m.to_cols_array_2d()) {
                o[k..k + 4].copy_from_slice(&c);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::TF_SAMPLES;
    use super::*;
    use crate::tf::TransferFunction;

    /// The lane-wise look-up gives `eval`'s bits, lane by lane, on every preset: at random
    /// scalars, on and around the samples, at the domain's ends and beyond them, and at ±∞.
    #[test]
    fn tf_eval_lanes_is_eval() {
        let mut rng = crate::util::rng::Rng::new(3);
        let mut rnd = || rng.f() as f32;
        for name in crate::tf::PRESETS {
            let tf = TransferFunction::preset(name).unwrap();
            let t = TfTable::new(&tf, TF_SAMPLES);
            let (lo, scale) = t.domain();
            let hi = lo + t.max / scale;
            let mut xs: Vec<f32> = (0..4000)
                .map(|_| lo - 0.1 + (hi - lo + 0.2) * rnd())
                .collect();
            for i in [0, 1, 2, 100, TF_SAMPLES - 2, TF_SAMPLES - 1] {
                let at = lo + i as f32 / scale;
                xs.extend([at, at.next_up(), at.next_down()]);
            }
            xs.extend([
                lo,
                hi,
                hi.next_up(),
                f32::INFINITY,
                f32::NEG_INFINITY,
                -1e30,
                1e30,
            ]);
            for chunk in xs.chunks(8) {
                let mut s = [0.5f32; 8];
                s[..chunk.len()].copy_from_slice(chunk);
                let mut out = [[0.0f32; 8]; 4];
                t.eval_lanes(&s, &mut out);
                for (k, &x) in s.iter().enumerate() {
                    let got: [u32; 4] = std::array::from_fn(|c| out[c][k].to_bits());
                    assert_eq!(got, t.eval(x).map(f32::to_bits), "{name}: s = {x:e}");
                }
            }
        }
    }
}

//! Tests of the f32 fast paths: the batch kernels against their scalar definition, the TF
//! table and its linear pieces against the TF, exp.

use super::*;

#[test]
fn exp_neg_matches_exp() {
    let mut worst = 0.0f64;
    for k in 0..200_000 {
        let x = k as f32 * 1e-4; // 0..20
        let e = (-(x as f64)).exp();
        let r = ((exp_neg(x) as f64 - e) / e).abs();
        worst = worst.max(r);
    }
    assert!(worst < 2e-6, "worst relative error {worst:e}");
    assert_eq!(exp_neg(0.0), 1.0);
    assert_eq!(exp_neg(f32::INFINITY), exp_neg(1e9));
    assert!(exp_neg(1e9) < 1e-37);
}

/// The vectorised batch kernels give the scalar definition's bits, on ordinary segments and
/// on the edge cases (l ≤ 0, NaN and infinite ends, huge lengths, s outside the TF range).
#[test]
fn shade_batch_matches_scalar() {
    let tf = TransferFunction::preset("default").unwrap();
    let mut seed = 1u64;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 40) as f32 / (1u64 << 24) as f32
    };
    let special = [
        0.0,
        -0.0,
        -1.0,
        f32::NAN,
        f32::INFINITY,
        -f32::INFINITY,
        1e30,
        1e-30,
    ];
    for name in ["average", "partial", "preint"] {
        let integ = FastIntegrator::new(name, &tf).unwrap();
        for round in 0..40 {
            let mut b = ShadeBatch {
                len: if round % 5 == 4 {
                    1 + round % BATCH
                } else {
                    BATCH
                },
                ..Default::default()
            };
            for k in 0..BATCH {
                b.sf[k] = 1.4 * rnd() - 0.2;
                b.sb[k] = 1.4 * rnd() - 0.2;
                b.l[k] = rnd() * rnd() * if round % 3 == 0 { 50.0 } else { 0.05 };
                if round % 2 == 1 && k % 7 == 0 {
                    let v = special[k / 7 % special.len()];
                    match k % 3 {
                        0 => b.sf[k] = v,
                        1 => b.sb[k] = v,
                        _ => b.l[k] = v,
                    }
                }
            }
            // Half the rounds shade from a linear piece of the TF (the ends are then mostly
            // outside it, which the definition extrapolates all the same).
            if let FastIntegrator::Partial(tf, _) = &integ {
                if round % 4 >= 2 {
                    b.piece = (round / 4 % tf.pieces.len()) as u32;
                }
            }
            let mut scalar = b.clone();
            integ.shade_batch_scalar(&mut scalar);
            // The portable lane-wise kernels (the fallback where AVX2 is missing) too.
            let mut lanes = b.clone();
            if !matches!(integ, FastIntegrator::Preint(_)) {
                pulp::Arch::new().dispatch(Lanes {
                    integ: &integ,
                    b: &mut lanes,
                });
            } else {
                integ.shade_batch_scalar(&mut lanes);
            }
            integ.shade_batch(&mut b);
            for c in 0..4 {
                for k in 0..b.len {
                    assert_eq!(lanes.out[c][k].to_bits(), scalar.out[c][k].to_bits());
                }
            }
            for c in 0..4 {
                for k in 0..b.len {
                    assert_eq!(
                        b.out[c][k].to_bits(),
                        scalar.out[c][k].to_bits(),
                        "{name} channel {c} segment {k}: ({}, {}, {})",
                        b.sf[k],
                        b.sb[k],
                        b.l[k]
                    );
                }
            }
        }
    }
}

/// Each linear piece is the table within its range (f32 rounding), and `piece_of` finds the
/// piece of a range inside one and none for a range across a control point.
#[test]
fn tf_pieces_match_table() {
    for name in crate::tf::PRESETS {
        let tf = TransferFunction::preset(name).unwrap();
        let t = TfTable::new(&tf, TF_SAMPLES);
        // The default TF: two constant ends and one piece per segment.
        assert!(
            t.pieces.len() >= tf.points.len(),
            "{name}: {}",
            t.pieces.len()
        );
        for (k, p) in t.pieces.iter().enumerate() {
            let (a, b) = (p.s0.max(-0.5), p.s1.min(1.5));
            for j in 0..=500 {
                let s = a + (b - a) * j as f32 / 500.0;
                let (u, v) = (piece_eval(p, s), t.eval(s));
                for c in 0..4 {
                    let tol = 1e-5 * v[c].abs().max(1.0);
                    assert!((u[c] - v[c]).abs() <= tol, "{name} piece {k} s {s} ch {c}");
                }
            }
            assert_eq!(t.piece_of(a, b), k as u32);
        }
        for q in &tf.points {
            let s = q.s as f32;
            assert_eq!(t.piece_of(s - 0.01, s + 0.01), NO_PIECE, "{name} at {s}");
        }
        assert_eq!(t.piece_of(f32::NAN, 0.5), NO_PIECE);
    }
}

#[test]
fn tf_table_matches_tf() {
    let tf = TransferFunction::preset("default").unwrap();
    let t = TfTable::new(&tf, TF_SAMPLES);
    for k in 0..=2000 {
        let s = -0.2 + 1.4 * k as f64 / 2000.0;
        let (c, tau) = tf.eval(s);
        let v = t.eval(s as f32);
        for ch in 0..3 {
            assert!((v[ch] as f64 - c[ch]).abs() < 1e-3, "s {s}");
        }
        assert!((v[3] as f64 - tau).abs() < 1e-2 * tau.max(1.0), "s {s}");
    }
}

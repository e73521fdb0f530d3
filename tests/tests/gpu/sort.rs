//! gpu-radix and gpu-bitonic against the CPU `centroid-radix` order on the same f32 keys:
//! identical, with many equal keys, +0.0/−0.0, negative keys and sizes that are not multiples of
//! the workgroup (256) or the radix block (1024).

use algorithms::gpu::test_gpu;
use algorithms::sort::gpu::{sort_f32_keys, GpuSortKind};

/// The `centroid-radix` order: key descending in IEEE total order, ties by ascending index.
fn cpu_order(keys: &[f32]) -> Vec<u32> {
    let mut idx: Vec<u32> = (0..keys.len() as u32).collect();
    idx.sort_by(|&a, &b| {
        keys[b as usize]
            .total_cmp(&keys[a as usize])
            .then(a.cmp(&b))
    });
    idx
}

/// A deterministic mix: few distinct values (many ties), ±0, negatives, wide exponents.
fn keys(n: usize, seed: u64) -> Vec<f32> {
    let mut x = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (0..n)
        .map(|_| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let r = (x >> 33) as u32;
            match r % 8 {
                0 => 0.0,
                1 => -0.0,
                2 => ((r >> 3) % 5) as f32 - 2.0,
                3 => -((r >> 3) as f32) * 1e-3,
                4 => f32::from_bits((r >> 3) | 1) * if r & 1 == 0 { 1.0 } else { -1.0 },
                5 => ((r >> 3) % 3) as f32 * 1e30,
                _ => (r >> 3) as f32 * 1e-6 - 100.0,
            }
        })
        .collect()
}

#[test]
fn gpu_sorts_give_the_centroid_radix_order_on_the_same_keys() {
    let Some(gpu) = test_gpu("gpu_sorts_give_the_centroid_radix_order_on_the_same_keys") else {
        return;
    };
    for &n in &[1usize, 2, 255, 256, 257, 1023, 1025, 100_003] {
        let k = keys(n, n as u64);
        assert!(k.iter().all(|v| !v.is_nan()));
        let want = cpu_order(&k);
        for kind in [GpuSortKind::Radix, GpuSortKind::Bitonic] {
            let got = sort_f32_keys(&gpu, kind, &k).unwrap();
            let first_bad = got.iter().zip(&want).position(|(a, b)| a != b);
            assert!(
                first_bad.is_none() && got.len() == want.len(),
                "{} n={n}: first difference at {first_bad:?}",
                kind.name()
            );
        }
    }
    // Equal keys only: the identity order; +0.0 strictly before −0.0.
    let k = vec![1.5f32; 3000];
    let id: Vec<u32> = (0..3000).collect();
    let z = [-0.0f32, 0.0, -0.0, 0.0];
    for kind in [GpuSortKind::Radix, GpuSortKind::Bitonic] {
        assert_eq!(
            sort_f32_keys(&gpu, kind, &k).unwrap(),
            id,
            "{}",
            kind.name()
        );
        assert_eq!(sort_f32_keys(&gpu, kind, &z).unwrap(), vec![1, 3, 0, 2]);
    }
}

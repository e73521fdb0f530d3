//! Sizes and counts that can pass 2³² on a large mesh, computed in 64 bits and narrowed only
//! through a check.
//!
//! A mesh of a few hundred million tets has more than 2³² of several things: bytes in its
//! arrays (16 a tet for the indices alone), tet–tile pairs and fragments of a frame, the
//! invocations of a GPU dispatch over its faces. What must be 32-bit (a GPU workgroup count, an
//! index stored in a `u32`) goes through [`to_u32`] or [`dispatch_grid`], which refuse with one
//! line instead of wrapping; byte counts go through [`array_bytes`].

use crate::error::{Error, Result};

/// `n` as a `u32`, or one line naming `what` when it does not fit.
pub fn to_u32(n: u64, what: &str) -> Result<u32> {
    u32::try_from(n).map_err(|_| {
        Error::Input(format!(
            "{what}: {n} is past the 32-bit limit of {}",
            u32::MAX
        ))
    })
}

/// The bytes of `count` elements of `elem` bytes each, or one line naming `what` when the
/// product passes `u64` (it never does for memory that exists; a lying file header can ask).
pub fn array_bytes(count: u64, elem: u64, what: &str) -> Result<u64> {
    count
        .checked_mul(elem)
        .ok_or_else(|| Error::Input(format!("{what}: {count} elements of {elem} bytes overflow")))
}

/// The workgroup grid `(x, y)` that covers `invocations` invocations in groups of `wg` with at
/// most `max_per_dim` groups along each axis: `x = min(g, max_per_dim)` and `y = ⌈g / x⌉` for
/// `g = ⌈invocations / wg⌉` groups (at least one), so a shader flattens its index as
/// `gid.x + gid.y · x · wg` and skips indices at or past `invocations`. `None` when even the
/// square grid cannot hold them.
pub fn dispatch_grid(invocations: u64, wg: u32, max_per_dim: u32) -> Option<(u32, u32)> {
    let g = invocations.div_ceil(u64::from(wg.max(1))).max(1);
    let max = u64::from(max_per_dim.max(1));
    let x = g.min(max);
    let y = g.div_ceil(x);
    (y <= max).then_some((x as u32, y as u32))
}

#[cfg(test)]
mod tests {
    use super::*;

    const B: u64 = 1 << 32;

    /// The three sizes at the 32-bit boundary: one below, at and one past 2³².
    const EDGE: [u64; 3] = [B - 1, B, B + 1];

    #[test]
    fn to_u32_takes_the_largest_u32_and_refuses_one_more() {
        assert_eq!(to_u32(B - 1, "faces").unwrap(), u32::MAX);
        for n in [B, B + 1, u64::MAX] {
            let e = to_u32(n, "faces").unwrap_err().to_string();
            assert!(
                e.starts_with("faces: ") && e.contains(&n.to_string()),
                "{e}"
            );
            assert!(!e.contains('\n'));
        }
    }

    #[test]
    fn array_bytes_are_exact_past_two_to_the_32() {
        for n in EDGE {
            assert_eq!(array_bytes(n, 16, "tets").unwrap(), 16 * n);
            assert_eq!(array_bytes(n, 1, "types").unwrap(), n);
        }
        // 278M tets of 16 bytes: 4.4 GB, past 2³².
        assert_eq!(array_bytes(278_000_000, 16, "tets").unwrap(), 4_448_000_000);
        assert!(array_bytes(u64::MAX / 8 + 1, 8, "x").is_err());
    }

    /// Every grid covers its invocations, with no axis past the limit and no whole row of
    /// groups beyond what is needed; sizes at 2³² invocations and at 2³² groups.
    #[test]
    fn dispatch_grids_cover_sizes_at_the_32_bit_boundary() {
        let check = |n: u64, wg: u32, max: u32| {
            let (x, y) = dispatch_grid(n, wg, max).unwrap();
            let (x, y, wg) = (u64::from(x), u64::from(y), u64::from(wg));
            assert!(x >= 1 && y >= 1 && x <= u64::from(max) && y <= u64::from(max));
            assert!(x * y * wg >= n, "{n}: {x}×{y}×{wg}");
            // The last row is needed: dropping it would leave invocations out.
            assert!(x * (y - 1) * wg < n.max(1), "{n}: {x}×{y}×{wg}");
        };
        for n in EDGE {
            check(n, 256, 65535);
            check(n, 64, 65535);
            // Groups of one: 2³² ± 1 groups are more than 65535² and are refused.
            assert_eq!(dispatch_grid(n, 1, 65535), None);
            check(n, 1, u32::MAX);
        }
        assert_eq!(dispatch_grid(0, 256, 65535), Some((1, 1)));
        assert_eq!(dispatch_grid(B, 256, 65535), Some((65535, 257)));
        // The square grid's limit: 65535² groups fit, one more does not.
        let most = 65535u64 * 65535;
        assert_eq!(dispatch_grid(most, 1, 65535), Some((65535, 65535)));
        assert_eq!(dispatch_grid(most + 1, 1, 65535), None);
        assert_eq!(dispatch_grid(u64::MAX, 1, 65535), None);
    }
}

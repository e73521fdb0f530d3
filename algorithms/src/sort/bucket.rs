//! `bucket`: PTINT's approximate sort by depth slabs (Marroquim et al., §3.2).
//!
//! The depth of a tet is the axis depth of its centroid, `c · forward`, in ortho and in persp
//! alike: the slabs are perpendicular to the viewing vector, as in PTINT. The range between the
//! smallest and largest centroid depth is split into N equal slabs; slab `s` of a tet is
//! `floor((max − depth) / (max − min) · N)`, clamped to N − 1 (slab 0 is the farthest). The slabs
//! are emitted back to front and the tets of one slab in index order (a counting sort, O(n)).
//! With N = 1 the order is index order.

use super::{centroids, check_prepared, f32x3, KeyFn, Sort, SortInfo, SortStats};
use crate::camera::Camera;
use crate::error::Result;
use crate::plugin::{ParamInfo, Params};
use crate::mesh::Mesh;

#[derive(Debug)]
pub struct BucketSort {
    slabs: usize,
    centroids: Vec<[f32; 3]>,
    keys: Vec<f32>,
    slab_of: Vec<u16>,
    counts: Vec<usize>,
}

impl BucketSort {
    pub fn new(slabs: usize) -> BucketSort {
        BucketSort {
            slabs: slabs.clamp(1, super::MAX_SLABS),
            centroids: Vec::new(),
            keys: Vec::new(),
            slab_of: Vec::new(),
            counts: Vec::new(),
        }
    }
}

/// The slab of depth `k` among `slabs` slabs over [lo, hi]; slab 0 holds `hi` (the farthest).
#[inline]
pub(crate) fn slab(k: f32, lo: f32, hi: f32, slabs: usize) -> usize {
    if hi > lo {
        let s = ((hi - k) * (slabs as f32 / (hi - lo))) as usize;
        s.min(slabs - 1)
    } else {
        0
    }
}

/// `bucket` and `bucket:N`.
pub const BUCKET: SortInfo = SortInfo {
    name: "bucket",
    description: "PTINT's N depth slabs, index order inside a slab (approximate), O(n)",
    params: &[ParamInfo {
        name: "N",
        default: "20",
        doc: "depth slabs, 1..=4096, given as bucket:N",
    }],
    lattice_only: false,
    make: |arg| {
        let given: Vec<(String, String)> = arg
            .map(|n| ("N".to_string(), n.trim().to_string()))
            .into_iter()
            .collect();
        let p = Params::new("sort 'bucket'", BUCKET.params, &given)?;
        let slabs = p.usize_in("N", 1..=super::MAX_SLABS)?;
        Ok(Box::new(BucketSort::new(slabs)))
    },
};

impl Sort for BucketSort {
    fn name(&self) -> String {
        if self.slabs == super::DEFAULT_SLABS {
            "bucket".into()
        } else {
            format!("bucket:{}", self.slabs)
        }
    }

    fn prepare(&mut self, mesh: &Mesh) -> Result<()> {
        self.centroids = centroids(mesh);
        Ok(())
    }

    fn sort(&mut self, mesh: &Mesh, camera: &Camera, order: &mut Vec<u32>) -> Result<SortStats> {
        check_prepared(&self.name(), self.centroids.len(), mesh)?;
        let kf = KeyFn::Axis(f32x3(camera.forward));
        self.keys.clear();
        self.keys.extend(self.centroids.iter().map(|c| kf.key(c)));
        let (lo, hi) = self
            .keys
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &k| {
                (lo.min(k), hi.max(k))
            });
        let n = self.slabs;
        self.counts.clear();
        self.counts.resize(n + 1, 0);
        self.slab_of.clear();
        for &k in &self.keys {
            let s = slab(k, lo, hi, n);
            self.slab_of.push(s as u16);
            self.counts[s + 1] += 1;
        }
        for s in 0..n {
            self.counts[s + 1] += self.counts[s];
        }
        order.clear();
        order.resize(self.keys.len(), 0);
        for (t, &s) in self.slab_of.iter().enumerate() {
            let c = &mut self.counts[s as usize];
            order[*c] = t as u32;
            *c += 1;
        }
        Ok(SortStats::default())
    }
}

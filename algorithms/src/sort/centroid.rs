//! `centroid` and `centroid-par`: comparison sorts of the centroid keys (HAPT's STL sort).

use rayon::prelude::*;

use super::{centroids, check_prepared, KeyFn, Sort, SortInfo, SortStats};
use crate::camera::Camera;
use crate::error::Result;
use crate::mesh::Mesh;

/// Sorts `(key, tet)` pairs with `sort_unstable_by` (one thread) or rayon's
/// `par_sort_unstable_by`: key descending in IEEE total order, then tet index ascending.
#[derive(Debug, Default)]
pub struct CentroidSort {
    parallel: bool,
    centroids: Vec<[f32; 3]>,
    pairs: Vec<(f32, u32)>,
}

impl CentroidSort {
    pub fn new(parallel: bool) -> CentroidSort {
        CentroidSort {
            parallel,
            ..Default::default()
        }
    }
}

/// `centroid`: one thread.
pub const CENTROID: SortInfo = SortInfo {
    name: "centroid",
    description: "centroid depth, sort_unstable_by on one thread, O(n log n)",
    params: &[],
    lattice_only: false,
    make: |_| Ok(Box::new(CentroidSort::new(false))),
};

/// `centroid-par`: the same order with rayon.
pub const CENTROID_PAR: SortInfo = SortInfo {
    name: "centroid-par",
    description: "the centroid order with rayon's par_sort_unstable_by, O(n log n) / threads",
    params: &[],
    lattice_only: false,
    make: |_| Ok(Box::new(CentroidSort::new(true))),
};

/// Farthest first, then by index: the order every centroid sort gives.
#[inline]
pub(crate) fn farthest_first(a: &(f32, u32), b: &(f32, u32)) -> std::cmp::Ordering {
    b.0.total_cmp(&a.0).then(a.1.cmp(&b.1))
}

impl Sort for CentroidSort {
    fn name(&self) -> String {
        if self.parallel {
            "centroid-par".into()
        } else {
            "centroid".into()
        }
    }

    fn prepare(&mut self, mesh: &Mesh) -> Result<()> {
        self.centroids = centroids(mesh);
        self.pairs = Vec::with_capacity(self.centroids.len());
        Ok(())
    }

    fn sort(&mut self, mesh: &Mesh, camera: &Camera, order: &mut Vec<u32>) -> Result<SortStats> {
        check_prepared(&self.name(), self.centroids.len(), mesh)?;
        let kf = KeyFn::for_camera(camera);
        self.pairs.clear();
        if self.parallel {
            self.centroids
                .par_iter()
                .enumerate()
                .map(|(t, c)| (kf.key(c), t as u32))
                .collect_into_vec(&mut self.pairs);
            self.pairs.par_sort_unstable_by(farthest_first);
        } else {
            self.pairs.extend(
                self.centroids
                    .iter()
                    .enumerate()
                    .map(|(t, c)| (kf.key(c), t as u32)),
            );
            self.pairs.sort_unstable_by(farthest_first);
        }
        order.clear();
        order.extend(self.pairs.iter().map(|p| p.1));
        Ok(SortStats::default())
    }
}

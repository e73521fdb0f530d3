//! `cpu-pt-slab16`: `cpu-pt` drawing in the order of PTINT's bucket sort with 16 depth slabs
//! (unsorted inside a slab), the cheapest visibility order there is. It is the worked example of
//! `docs/adding-a-renderer.md`: a variant is this one file plus one line in the registry.

use super::cpu_pt::CpuPt;
use super::{Family, RendererInfo};
use crate::optics::INTEGRATORS;

pub static CPU_PT_SLAB16: RendererInfo = RendererInfo {
    name: "cpu-pt-slab16",
    description: "cpu-pt with PTINT's bucket sort in 16 depth slabs (unsorted within a slab)",
    sorts: &[],
    integrators: &INTEGRATORS,
    family: Family::Pt,
    needs_gpu: false,
    default_sort: "",
    table_sorts: &[],
    default_integrator: "partial",
    params: &[],
    // Measured by the registry-wide test (worst of its two views), ×1.5.
    max_rmse: &[("average", 2.9e-3), ("partial", 4.0e-3), ("preint", 1.7e-3), ("exact", 1.7e-3)],
    make: |_, o| {
        let integrator = o.integrator.as_deref().unwrap_or("partial");
        Ok(Box::new(
            CpuPt::new("bucket:16", integrator)?.named("cpu-pt-slab16"),
        ))
    },
};

//! What the GPU projected-tetrahedra renderers (`ptint`, `hapt`) compose their stages with:
//! the generated classification table ([`super::table_wgsl`]) as the prelude of every stage,
//! and the libraries of the volume's fragment stage they share.

use crate::error::Result;
use crate::gpu::shader::{self, VIEW, VOLUME};
use crate::gpu::Gpu;
use crate::optics::gpu::OPTICS;

/// The libraries of `volume.frag.wgsl` (`gpu::shader::VOLUME_FRAG`).
pub const VOLUME_FRAG_LIBS: &[&str] = &[VIEW, VOLUME, OPTICS];

/// Compiles a stage composed after the classification table (see [`shader::compose`]).
pub fn module(gpu: &Gpu, name: &str, stage: &str, libs: &[&str]) -> Result<wgpu::ShaderModule> {
    shader::module(gpu, name, &super::table_wgsl(), stage, libs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::shader::{CLASSIFY, VOLUME_FRAG};
    use crate::render::{hapt, ptint};

    /// Every stage with the libraries it is composed with.
    fn stages() -> Vec<(&'static str, &'static str, &'static [&'static str])> {
        let mut v = vec![("volume.frag.wgsl", VOLUME_FRAG, VOLUME_FRAG_LIBS)];
        v.extend_from_slice(ptint::STAGES);
        v
    }

    #[test]
    fn every_stage_compiles() {
        let Some(gpu) = crate::gpu::test_gpu("every_stage_compiles") else {
            return;
        };
        for (name, src, libs) in stages() {
            module(&gpu, name, src, libs).unwrap_or_else(|e| panic!("{e}"));
        }
        // A broken stage is reported, naming it.
        let e = module(&gpu, "broken", "fn f() -> u32 { return 1.0; }", &[]).unwrap_err();
        assert!(e.to_string().contains("broken"), "{e}");
    }

    #[test]
    fn composed_source_carries_the_generated_table() {
        let s = shader::compose(&super::super::table_wgsl(), VOLUME_FRAG, VOLUME_FRAG_LIBS);
        assert!(s.starts_with(&super::super::table_wgsl()));
        assert!(s.contains("fn segment(") && s.contains("fn fs_volume("));
        // No function is defined in two files.
        let libs = [
            VIEW,
            CLASSIFY,
            OPTICS,
            VOLUME,
            ptint::PTINT_LIB,
            hapt::HAPT_LIB,
        ];
        let mut seen = std::collections::HashSet::new();
        for src in libs.iter().chain(stages().iter().map(|s| &s.1)) {
            for line in src.lines() {
                if let Some(rest) = line.strip_prefix("fn ") {
                    let name = rest.split('(').next().unwrap().to_string();
                    assert!(seen.insert(name.clone()), "fn {name} defined twice");
                }
            }
        }
    }
}

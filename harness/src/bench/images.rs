//! Images of a sweep: content hashes of meshes and images, saved images under `DIR/images/`,
//! and the image-against-image comparison of variant pairs.

use super::*;

/// With `save_images`: the image as EXR and PNG under `DIR/images/<dataset>/`, and its cached
/// yardstick beside it as PNG.
pub(super) fn save_images(
    exp: &Experiment,
    opts: &RunOptions,
    var: &Variant,
    dataset: &str,
    cell: &Cell,
    img: &Image,
    reference: Option<&Path>,
) -> Result<()> {
    if !exp.save_images {
        return Ok(());
    }
    let dir = opts.out.join("images").join(sanitize(dataset));
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let stem = image_stem(&var.label, cell);
    img.write(&dir.join(format!("{stem}.exr")))?;
    img.write(&dir.join(format!("{stem}.png")))?;
    // The yardstick beside it, named after it (`reference-cached-…` for the exact reference);
    // one that no longer matches its checksum is left out (the row's note says why).
    if let Some(p) = reference {
        let name = format!("{}-cached", var.yardstick.label());
        let rp = dir.join(format!("{}.png", image_stem(&name, cell)));
        if !rp.exists() {
            if let Ok(img) = super::yardsticks::read_entry(p) {
                img.write(&rp)?;
            }
        }
    }
    Ok(())
}

/// The pairs of one dataset, image against image (cells where either image is missing give
/// no row).
pub(super) fn compare_pairs(
    exp: &Experiment,
    cells: &[Cell],
    pair_dir: &Path,
    dataset: &str,
    tets: usize,
) -> Vec<PairRow> {
    let mut out = Vec::new();
    for p in &exp.pairs {
        for cell in cells {
            let img = |label: &str| {
                Image::read(
                    &pair_dir
                        .join(sanitize(label))
                        .join(format!("{}.exr", image_stem(label, cell))),
                )
            };
            let (Ok(ia), Ok(ib)) = (img(&p.test), img(&p.reference)) else {
                continue;
            };
            let Ok(m) = metrics::compare(&ia, &ib) else {
                continue;
            };
            out.push(PairRow {
                dataset: dataset.to_string(),
                tets,
                test: p.test.clone(),
                reference: p.reference.clone(),
                width: cell.size.0,
                height: cell.size.1,
                view_id: cell.view.id.clone(),
                azimuth: cell.view.view.azimuth,
                elevation: cell.view.view.elevation,
                projection: cell.projection.name().to_string(),
                rmse: m.rmse,
                psnr: m.psnr,
                max_abs: m.max_abs,
                diff_pixels_pct: m.diff_pixels_pct,
                max_err_pct: m.max_err_pct,
                avg_err_pct: m.avg_err_pct,
            });
        }
    }
    out
}

/// Hash of what the image depends on in the mesh: positions, tets and the active scalars.
pub fn mesh_hash(mesh: &Mesh) -> blake3::Hash {
    let mut h = blake3::Hasher::new();
    h.update(b"tetbench-mesh-v1");
    h.update(&(mesh.num_vertices() as u64).to_le_bytes());
    for p in mesh.positions() {
        for c in p.to_array() {
            h.update(&c.to_le_bytes());
        }
    }
    h.update(&(mesh.num_tets() as u64).to_le_bytes());
    for t in mesh.tets() {
        for i in t {
            h.update(&i.to_le_bytes());
        }
    }
    for s in mesh.scalars() {
        h.update(&s.to_le_bytes());
    }
    h.finalize()
}

/// A short content hash of an image's f32 pixels (the `image_hash` column): equal hashes mean
/// bit-identical images.
pub fn image_hash(img: &Image) -> String {
    // Fed in blocks: the same bytes as one buffer of them, without a copy of the image.
    let mut h = blake3::Hasher::new();
    h.update(&img.width.to_le_bytes());
    h.update(&img.height.to_le_bytes());
    let mut block = Vec::with_capacity(16 * 4096);
    for chunk in img.pixels.chunks(4096) {
        block.clear();
        block.extend(chunk.iter().flatten().flat_map(|c| c.to_le_bytes()));
        h.update(&block);
    }
    h.finalize().to_hex()[..16].to_string()
}

pub(super) fn image_stem(label: &str, cell: &Cell) -> String {
    format!(
        "{}-{}-{}x{}-{}",
        sanitize(label),
        cell.projection.name(),
        cell.size.0,
        cell.size.1,
        sanitize(&cell.view.id)
    )
}

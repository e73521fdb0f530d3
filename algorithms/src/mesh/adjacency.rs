//! Face adjacency in time linear in the mesh and in bounded memory.
//!
//! Two tets are neighbours across a face when they share its three vertices. Every face is
//! filed under its lowest vertex (a counting sort by vertex: the faces that can match one face
//! are all filed under the same vertex), and the faces under one vertex, ~20 on a tetrahedral
//! mesh, are sorted by their two other vertices and then by face id: equal neighbouring keys
//! are the sides of a shared face. The faces of a range of vertices are filed at a time, the
//! ranges chosen so that at most [`pass_capacity`] faces (4 bytes each, about 4 bytes a tet on
//! a large mesh) are held at once beside the output; each pass reads the tets once more.
//!
//! The pairing is the one of sorting all faces by (sorted vertex triple, `4·tet + face`): a key
//! met by two or more faces glues the first two in that order (the two lowest ids), unless the
//! face repeats a vertex or both sides are of one tet; a key met by three or more faces counts
//! as one non-manifold face, whose further copies stay boundary.

use std::sync::atomic::{AtomicU32, Ordering};

use rayon::prelude::*;

use super::{BOUNDARY, FACE_VERTS};

/// The face links of a mesh: per tet and face, `4 · neighbour + the neighbour's face back`,
/// or [`BOUNDARY`].
pub(crate) struct FaceLinks {
    pub links: Vec<[u32; 4]>,
    /// Faces met by three or more tets.
    pub nonmanifold_faces: usize,
}

/// The most faces filed in one pass: one per tet (4 bytes a tet), and never fewer than 2²⁰
/// (4 MiB), so that meshes up to 2¹⁸ tets take one pass.
fn pass_capacity(tets: usize) -> usize {
    tets.max(1 << 20)
}

/// The face key of face `f` of `tet`: its vertices, ascending.
#[inline]
fn face_key(tet: &[u32; 4], f: usize) -> [u32; 3] {
    let mut k = FACE_VERTS[f].map(|i| tet[i]);
    k.sort_unstable();
    k
}

/// The lowest vertex of face `f` of `tet` (the one the face is filed under).
#[inline]
fn face_low(tet: &[u32; 4], f: usize) -> u32 {
    // Face f leaves out vertex f.
    let [a, b, c] = FACE_VERTS[f].map(|i| tet[i]);
    a.min(b).min(c)
}

/// Views a slice of `u32` as atomics, for writes by several threads at distinct indices.
fn as_atomic(v: &mut [u32]) -> &[AtomicU32] {
    // SAFETY: `AtomicU32` has the same size, alignment and bit validity as `u32`, and the
    // exclusive borrow keeps every other access out while the atomic view lives.
    unsafe { &*(v as *mut [u32] as *const [AtomicU32]) }
}

/// The face links of `tets` over `nverts` vertices (every index below `nverts`; fewer than 2³⁰
/// tets, so that `4 · tet + face` fits in 32 bits below [`BOUNDARY`]).
pub(crate) fn face_links(tets: &[[u32; 4]], nverts: usize) -> FaceLinks {
    face_links_with(tets, nverts, pass_capacity(tets.len()))
}

/// [`face_links`] with at most `cap` faces filed per pass.
pub(crate) fn face_links_with(tets: &[[u32; 4]], nverts: usize, cap: usize) -> FaceLinks {
    assert!(
        tets.len() < 1 << 30,
        "face ids are 32-bit: fewer than 2^30 tets"
    );
    const CHUNK: usize = 1 << 14;
    // Faces filed under each vertex, then (in place) the start of each vertex's run.
    let mut start = vec![0u32; nverts + 1];
    {
        let count = as_atomic(&mut start);
        tets.par_chunks(CHUNK).for_each(|ts| {
            for t in ts {
                for f in 0..4 {
                    count[face_low(t, f) as usize].fetch_add(1, Ordering::Relaxed);
                }
            }
        });
    }
    // At most 4 · (2³⁰ − 1) faces in all: the running sum stays in 32 bits.
    let mut sum = 0u32;
    for s in start.iter_mut() {
        let n = *s;
        *s = sum;
        sum += n;
    }
    let mut links = vec![[BOUNDARY; 4]; tets.len()];
    let mut nonmanifold = 0usize;
    let mut entries: Vec<u32> = Vec::new();
    let mut cursor: Vec<u32> = Vec::new();
    let mut v0 = 0usize;
    while v0 < nverts {
        // The vertex range [v0, v1) of this pass: as many vertices as fit in `cap` faces
        // (at least one, however many faces it has).
        let base = start[v0] as usize;
        let mut v1 = v0 + 1;
        while v1 < nverts && start[v1 + 1] as usize - base <= cap {
            v1 += 1;
        }
        let n = start[v1] as usize - base;
        entries.clear();
        entries.resize(n, 0);
        cursor.clear();
        cursor.extend(start[v0..v1].iter().map(|&s| s - base as u32));
        {
            let (out, cur) = (as_atomic(&mut entries), as_atomic(&mut cursor));
            tets.par_chunks(CHUNK).enumerate().for_each(|(c, ts)| {
                for (i, t) in ts.iter().enumerate() {
                    for f in 0..4 {
                        let v = face_low(t, f) as usize;
                        if (v0..v1).contains(&v) {
                            let id = (4 * (c * CHUNK + i) + f) as u32;
                            let at = cur[v - v0].fetch_add(1, Ordering::Relaxed);
                            out[at as usize].store(id, Ordering::Relaxed);
                        }
                    }
                }
            });
        }
        // Each vertex's run sorted and matched; runs handed out in groups of vertices.
        let mut runs: Vec<&mut [u32]> = Vec::new();
        let mut rest = &mut entries[..];
        for g in (v0..v1).step_by(CHUNK) {
            let g1 = (g + CHUNK).min(v1);
            let (head, tail) = rest.split_at_mut((start[g1] - start[g]) as usize);
            runs.push(head);
            rest = tail;
        }
        let flat = as_atomic(links.as_flattened_mut());
        nonmanifold += runs
            .into_par_iter()
            .enumerate()
            .map(|(k, run)| {
                let g = v0 + k * CHUNK;
                let mut keyed: Vec<([u32; 3], u32)> = Vec::new();
                let mut nm = 0;
                for v in g..(g + CHUNK).min(v1) {
                    let (a, b) = (start[v] - start[g], start[v + 1] - start[g]);
                    keyed.clear();
                    keyed.extend(
                        run[a as usize..b as usize]
                            .iter()
                            .map(|&id| (face_key(&tets[id as usize / 4], id as usize % 4), id)),
                    );
                    keyed.sort_unstable();
                    nm += match_sorted(&keyed, flat);
                }
                nm
            })
            .sum::<usize>();
        v0 = v1;
    }
    FaceLinks {
        links,
        nonmanifold_faces: nonmanifold,
    }
}

/// Glues the faces of `keyed` (sorted by key, then id) as the module docs say, into `links`
/// (flattened: face id → link); returns the non-manifold faces among them.
fn match_sorted(keyed: &[([u32; 3], u32)], links: &[AtomicU32]) -> usize {
    let mut nonmanifold = 0;
    let mut i = 0;
    while i < keyed.len() {
        let k = keyed[i].0;
        let mut j = i + 1;
        while j < keyed.len() && keyed[j].0 == k {
            j += 1;
        }
        if j - i >= 2 {
            let (a, b) = (keyed[i].1, keyed[i + 1].1);
            if k[0] != k[1] && k[1] != k[2] && a / 4 != b / 4 {
                // Each face id is filed once, so each link is written by one thread only.
                links[a as usize].store(b, Ordering::Relaxed);
                links[b as usize].store(a, Ordering::Relaxed);
            }
            if j - i > 2 {
                nonmanifold += 1;
            }
        }
        i = j;
    }
    nonmanifold
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::rng::Rng;

    /// The definition: every face keyed by its sorted vertices and sorted with its id, equal
    /// neighbouring keys glued (the first two of a run), as the module docs say.
    fn by_sorting(tets: &[[u32; 4]]) -> (Vec<[u32; 4]>, usize) {
        let mut faces: Vec<([u32; 3], u32)> = (0..tets.len())
            .flat_map(|t| (0..4).map(move |f| (face_key(&tets[t], f), (4 * t + f) as u32)))
            .collect();
        faces.sort_unstable();
        let mut links = vec![[BOUNDARY; 4]; tets.len()];
        let nm = match_sorted(&faces, as_atomic(links.as_flattened_mut()));
        (links, nm)
    }

    /// Random meshes of a few vertices, so that faces repeat: shared, non-manifold (three or
    /// more tets), duplicate tets and faces with a repeated vertex.
    #[test]
    fn matches_the_sorting_definition_in_one_pass_and_in_many() {
        let mut rng = Rng::new(7);
        for round in 0..200 {
            let nverts = 5 + round % 13;
            let ntets = 1 + (rng.next() % 60) as usize;
            let tets: Vec<[u32; 4]> = (0..ntets)
                .map(|_| std::array::from_fn(|_| (rng.next() % nverts as u64) as u32))
                .collect();
            let (want, want_nm) = by_sorting(&tets);
            for cap in [1, 3, 17, 1 << 20] {
                let got = face_links_with(&tets, nverts, cap);
                assert_eq!(got.links, want, "round {round}, {cap} faces a pass");
                assert_eq!(
                    got.nonmanifold_faces, want_nm,
                    "round {round}, {cap} faces a pass"
                );
            }
        }
    }

    #[test]
    fn a_cube_split_in_five_is_glued_both_ways() {
        let m = crate::mesh::tests::cube5();
        let l = face_links(m.tets(), m.num_vertices()).links;
        for (t, row) in l.iter().enumerate() {
            for (f, &x) in row.iter().enumerate() {
                if x != BOUNDARY {
                    assert_eq!(l[x as usize / 4][x as usize % 4], (4 * t + f) as u32);
                }
            }
        }
        assert_eq!(l.iter().flatten().filter(|&&x| x == BOUNDARY).count(), 12);
    }
}

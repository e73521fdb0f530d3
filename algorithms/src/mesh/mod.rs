//! The shared tetrahedral mesh model (CONVENTIONS §1).
//!
//! Positions are f64; every renderer moves them to the frame centred on the bounding-box centre
//! before it converts to f32. Scalars are named per-vertex fields, each with one or more time
//! steps; one (field, step) pair is active at a time. Derived data — bounding box, scalar range,
//! signed volumes, face adjacency, boundary faces, degenerate count, convexity — is computed on
//! first use and cached; the adjacency is shared by MPVONC and the ray caster.
//!
//! Past 600 lines only with its tests (about 520 lines of code): the mesh is one type.

use std::collections::BTreeMap;
use std::sync::OnceLock;

use glam::DVec3;
use rayon::prelude::*;

use crate::error::{Error, Result};

mod adjacency;

/// The most tets a mesh may have: faces are numbered `4 · tet + face` in 32 bits, below
/// [`BOUNDARY`].
pub const MAX_TETS: usize = (1 << 30) - 1;

/// Marks a face with no neighbouring tet in [`Mesh::adjacency`].
pub const BOUNDARY: u32 = u32::MAX;

// The last face id of a mesh at its largest, `4 · (MAX_TETS − 1) + 3`, stays below `BOUNDARY`.
const _: () = assert!(4 * (MAX_TETS - 1) + 3 < BOUNDARY as usize);

/// Vertex indices (into the tet's own four) of face `f`, the face opposite vertex `f`, ordered so
/// that the normal `(v1 - v0) × (v2 - v0)` points out of a positively oriented tet.
pub const FACE_VERTS: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// Six times the signed volume of the tet `[a, b, c, d]`, `det(b − a, c − a, d − a)`: positive
/// for a positively oriented tet (the orientation of [`FACE_VERTS`]).
#[inline]
pub fn signed_volume6([a, b, c, d]: [DVec3; 4]) -> f64 {
    (b - a).cross(c - a).dot(d - a)
}

/// A named per-vertex scalar field with one or more time steps.
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    pub name: String,
    pub steps: Vec<Vec<f64>>,
}

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: DVec3,
    pub max: DVec3,
}

impl Aabb {
    pub fn center(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }
    /// `L`, the length of the diagonal (CONVENTIONS §1).
    pub fn diagonal(&self) -> f64 {
        (self.max - self.min).length()
    }
}

#[derive(Default, Debug)]
struct Cache {
    bbox: OnceLock<Aabb>,
    volumes: OnceLock<Vec<f64>>,
    adjacency: OnceLock<Adjacency>,
    boundary: OnceLock<Vec<u32>>,
    convex: OnceLock<bool>,
    scalar_range: OnceLock<(f64, f64)>,
}

/// Face adjacency: for every tet, the tet across each of its four faces or [`BOUNDARY`].
#[derive(Debug, Clone)]
pub struct Adjacency {
    pub neighbors: Vec<[u32; 4]>,
    /// Faces met by three or more tets (duplicate tets); their extra copies count as boundary.
    pub nonmanifold_faces: usize,
}

/// A tetrahedral mesh with per-vertex scalars.
#[derive(Debug)]
pub struct Mesh {
    positions: Vec<DVec3>,
    tets: Vec<[u32; 4]>,
    fields: Vec<Field>,
    active: (usize, usize),
    /// Numeric metadata that travels with the mesh (written as VTU field data), e.g. a lattice
    /// description.
    pub field_data: BTreeMap<String, Vec<f64>>,
    cache: Cache,
}

impl Clone for Mesh {
    fn clone(&self) -> Self {
        Mesh {
            positions: self.positions.clone(),
            tets: self.tets.clone(),
            fields: self.fields.clone(),
            active: self.active,
            field_data: self.field_data.clone(),
            cache: Cache::default(),
        }
    }
}

impl Mesh {
    /// Builds a mesh, checking what every renderer relies on: at least one tet, indices in
    /// range, finite coordinates and scalars, every field step with one value per vertex.
    /// `source` names the file (or generator) in error messages.
    pub fn new(
        source: &str,
        positions: Vec<DVec3>,
        tets: Vec<[u32; 4]>,
        fields: Vec<Field>,
    ) -> Result<Mesh> {
        if positions.is_empty() {
            return Err(Error::input(source, "mesh has no vertices"));
        }
        if tets.is_empty() {
            return Err(Error::input(source, "mesh has no tetrahedra"));
        }
        if positions.len() > u32::MAX as usize - 1 {
            return Err(Error::input(source, "more than 2^32 - 2 vertices"));
        }
        if tets.len() > MAX_TETS {
            return Err(Error::input(
                source,
                format!(
                    "{} tets: at most 2^30 - 1 (faces are numbered 4 · tet + face in 32 bits)",
                    tets.len()
                ),
            ));
        }
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::input(
                source,
                format!("vertex {i} has a non-finite coordinate {:?}", positions[i]),
            ));
        }
        let n = positions.len() as u32;
        if let Some(t) = tets.iter().position(|t| t.iter().any(|&v| v >= n)) {
            return Err(Error::input(
                source,
                format!(
                    "tet {t} has vertex index {:?} out of range (vertices: {n})",
                    tets[t]
                ),
            ));
        }
        if fields.is_empty() {
            return Err(Error::input(source, "mesh has no scalar field"));
        }
        for f in &fields {
            if f.steps.is_empty() {
                return Err(Error::input(
                    source,
                    format!("field '{}' has no values", f.name),
                ));
            }
            for (k, s) in f.steps.iter().enumerate() {
                if s.len() != positions.len() {
                    return Err(Error::input(
                        source,
                        format!(
                            "field '{}' step {k} has {} values for {} vertices",
                            f.name,
                            s.len(),
                            positions.len()
                        ),
                    ));
                }
                if let Some(i) = s.iter().position(|v| !v.is_finite()) {
                    return Err(Error::input(
                        source,
                        format!("field '{}' vertex {i}: non-finite scalar {}", f.name, s[i]),
                    ));
                }
            }
        }
        Ok(Mesh {
            positions,
            tets,
            fields,
            active: (0, 0),
            field_data: BTreeMap::new(),
            cache: Cache::default(),
        })
    }

    /// Convenience constructor for one field with one step.
    pub fn with_scalars(
        source: &str,
        positions: Vec<DVec3>,
        tets: Vec<[u32; 4]>,
        name: &str,
        scalars: Vec<f64>,
    ) -> Result<Mesh> {
        Mesh::new(
            source,
            positions,
            tets,
            vec![Field {
                name: name.to_string(),
                steps: vec![scalars],
            }],
        )
    }

    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }
    pub fn tets(&self) -> &[[u32; 4]] {
        &self.tets
    }
    pub fn num_vertices(&self) -> usize {
        self.positions.len()
    }
    pub fn num_tets(&self) -> usize {
        self.tets.len()
    }
    pub fn fields(&self) -> &[Field] {
        &self.fields
    }
    /// Bytes of the mesh's own data, as its arrays hold them: positions, tets, every field
    /// step and the field data (not the derived data cached on first use). What a loader
    /// cannot do with less, and what a mesh's resident bytes are measured against.
    pub fn data_bytes(&self) -> usize {
        use std::mem::size_of_val;
        size_of_val(self.positions.as_slice())
            + size_of_val(self.tets.as_slice())
            + self
                .fields
                .iter()
                .flat_map(|f| &f.steps)
                .map(|s| size_of_val(s.as_slice()))
                .sum::<usize>()
            + self
                .field_data
                .values()
                .map(|v| size_of_val(v.as_slice()))
                .sum::<usize>()
    }
    /// The active field's name and time step.
    pub fn active_field(&self) -> (&str, usize) {
        (&self.fields[self.active.0].name, self.active.1)
    }
    /// The active scalar values, one per vertex.
    pub fn scalars(&self) -> &[f64] {
        &self.fields[self.active.0].steps[self.active.1]
    }

    /// Makes `name` (at time step `step`) the active scalar field.
    pub fn select_field(&mut self, name: &str, step: usize) -> Result<()> {
        let Some(i) = self.fields.iter().position(|f| f.name == name) else {
            let known: Vec<&str> = self.fields.iter().map(|f| f.name.as_str()).collect();
            return Err(Error::Input(format!(
                "unknown scalar field '{name}' (this mesh has: {})",
                known.join(", ")
            )));
        };
        if step >= self.fields[i].steps.len() {
            return Err(Error::Input(format!(
                "field '{name}' has {} time steps, step {step} asked for",
                self.fields[i].steps.len()
            )));
        }
        if self.active != (i, step) {
            self.active = (i, step);
            self.cache.scalar_range = OnceLock::new();
        }
        Ok(())
    }

    /// Adds a field (or replaces one of the same name).
    pub fn add_field(&mut self, field: Field) -> Result<()> {
        if field.steps.is_empty() || field.steps.iter().any(|s| s.len() != self.positions.len()) {
            return Err(Error::Input(format!(
                "field '{}' must have one value per vertex in every step",
                field.name
            )));
        }
        if let Some(s) = field.steps.iter().flatten().find(|v| !v.is_finite()) {
            return Err(Error::Input(format!(
                "field '{}' has a non-finite value {s}",
                field.name
            )));
        }
        match self.fields.iter().position(|f| f.name == field.name) {
            Some(i) => {
                self.fields[i] = field;
                if self.active.0 == i {
                    self.active.1 = 0;
                    self.cache.scalar_range = OnceLock::new();
                }
            }
            None => self.fields.push(field),
        }
        Ok(())
    }

    pub fn bbox(&self) -> Aabb {
        *self.cache.bbox.get_or_init(|| {
            let (min, max) = self
                .positions
                .par_iter()
                .fold(
                    || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                    |(lo, hi), p| (lo.min(*p), hi.max(*p)),
                )
                .reduce(
                    || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                    |a, b| (a.0.min(b.0), a.1.max(b.1)),
                );
            Aabb { min, max }
        })
    }

    /// `L`, the bounding-box diagonal; optical lengths are world lengths divided by it.
    pub fn diagonal(&self) -> f64 {
        self.bbox().diagonal()
    }

    /// (min, max) of the active scalar field.
    pub fn scalar_range(&self) -> (f64, f64) {
        *self.cache.scalar_range.get_or_init(|| {
            self.scalars()
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                    (lo.min(v), hi.max(v))
                })
        })
    }

    /// Positions of tet `t`'s vertices.
    #[inline]
    pub fn tet_points(&self, t: usize) -> [DVec3; 4] {
        let [a, b, c, d] = self.tets[t];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
            self.positions[d as usize],
        ]
    }

    /// Signed volumes, `det(b − a, c − a, d − a) / 6`; positive for the orientation of
    /// [`FACE_VERTS`]. Computed in the frame centred on the bounding box.
    pub fn volumes(&self) -> &[f64] {
        self.cache.volumes.get_or_init(|| {
            let c = self.bbox().center();
            (0..self.tets.len())
                .into_par_iter()
                .map(|t| signed_volume6(self.tet_points(t).map(|p| p - c)) / 6.0)
                .collect()
        })
    }

    /// Tets with |volume| < 1e-14 · L³.
    pub fn degenerate_tets(&self) -> usize {
        let l = self.diagonal();
        let eps = 1e-14 * l * l * l;
        // A mesh collapsed to a point (L = 0) has every tet degenerate.
        self.volumes()
            .iter()
            .filter(|v| v.abs() < eps || **v == 0.0)
            .count()
    }

    /// Tets with negative signed volume (beyond the degenerate threshold).
    pub fn negative_tets(&self) -> usize {
        let l = self.diagonal();
        let eps = 1e-14 * l * l * l;
        self.volumes().iter().filter(|&&v| v < -eps).count()
    }

    /// Face adjacency: each face filed under its lowest vertex and matched there by its two
    /// others, in time linear in the mesh and at most ~4 bytes a tet beside the result
    /// ([`adjacency`]).
    pub fn adjacency(&self) -> &Adjacency {
        self.cache.adjacency.get_or_init(|| build_adjacency(self))
    }

    /// The face adjacency without caching it in the mesh (the cached one if it is already
    /// built), for a renderer that keeps a compact copy of its own and should not pay twice.
    pub fn adjacency_transient(&self) -> std::borrow::Cow<'_, Adjacency> {
        match self.cache.adjacency.get() {
            Some(a) => std::borrow::Cow::Borrowed(a),
            None => std::borrow::Cow::Owned(build_adjacency(self)),
        }
    }

    /// The face links, built now and not cached: per tet and face, `4 · neighbour + the
    /// neighbour's face back to this tet`, or [`BOUNDARY`] (the same gluing as
    /// [`Mesh::adjacency`]). For a renderer that walks from cell to cell and keeps them as its
    /// own 16 bytes a tet.
    pub fn face_links(&self) -> Vec<[u32; 4]> {
        adjacency::face_links(&self.tets, self.positions.len()).links
    }

    /// Neighbour of tet `t` across face `f`, or [`BOUNDARY`].
    #[inline]
    pub fn neighbor(&self, t: usize, f: usize) -> u32 {
        self.adjacency().neighbors[t][f]
    }

    /// Boundary faces as `4 · tet + face`, in tet order.
    pub fn boundary_faces(&self) -> &[u32] {
        self.cache.boundary.get_or_init(|| {
            let adj = &self.adjacency().neighbors;
            let mut out = Vec::new();
            for (t, n) in adj.iter().enumerate() {
                for (f, &nb) in n.iter().enumerate() {
                    if nb == BOUNDARY {
                        out.push((4 * t + f) as u32);
                    }
                }
            }
            out
        })
    }

    /// Vertex indices of face `f` of tet `t`, oriented outwards when the tet is positive.
    #[inline]
    pub fn face_vertices(&self, t: usize, f: usize) -> [u32; 3] {
        let tet = self.tets[t];
        FACE_VERTS[f].map(|k| tet[k])
    }

    /// Whether the boundary surface is convex: it is one closed connected surface and, across
    /// every boundary edge, the neighbouring face does not rise above the face's outward plane
    /// (by more than 1e-6·L). A closed connected surface that is locally convex everywhere is
    /// convex (Tietze's theorem).
    pub fn is_convex(&self) -> bool {
        *self.cache.convex.get_or_init(|| boundary_is_convex(self))
    }
}

/// The face adjacency from the face links ([`adjacency::face_links`]), turned into tet
/// indices in place.
fn build_adjacency(mesh: &Mesh) -> Adjacency {
    let adjacency::FaceLinks {
        mut links,
        nonmanifold_faces,
    } = adjacency::face_links(&mesh.tets, mesh.positions.len());
    links.par_iter_mut().for_each(|row| {
        for l in row {
            if *l != BOUNDARY {
                *l /= 4;
            }
        }
    });
    Adjacency {
        neighbors: links,
        nonmanifold_faces,
    }
}

fn boundary_is_convex(mesh: &Mesh) -> bool {
    let faces = mesh.boundary_faces();
    if faces.is_empty() || mesh.diagonal() == 0.0 {
        return false;
    }
    let c = mesh.bbox().center();
    let l = mesh.diagonal();
    let eps = 1e-6 * l;
    let vols = mesh.volumes();
    let vol_eps = 1e-14 * l * l * l;
    // Oriented triangles (outward for positive tets; flipped for negative ones).
    let tris: Vec<[u32; 3]> = faces
        .iter()
        .map(|&bf| {
            let (t, f) = (bf as usize / 4, bf as usize % 4);
            let mut v = mesh.face_vertices(t, f);
            if vols[t] < 0.0 {
                v.swap(1, 2);
            }
            v
        })
        .collect();
    // Boundary edges: (min, max, face index); each must be met by exactly two faces.
    let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(tris.len() * 3);
    for (fi, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b), fi as u32));
        }
    }
    edges.par_sort_unstable();
    let p = |v: u32| mesh.positions()[v as usize] - c;
    // Union-find for connectivity.
    let mut parent: Vec<u32> = (0..tris.len() as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    let mut i = 0;
    while i < edges.len() {
        if i + 1 >= edges.len() || edges[i + 1].0 != edges[i].0 || edges[i + 1].1 != edges[i].1 {
            return false; // open or non-manifold boundary
        }
        if i + 2 < edges.len() && edges[i + 2].0 == edges[i].0 && edges[i + 2].1 == edges[i].1 {
            return false;
        }
        let (f1, f2) = (edges[i].2 as usize, edges[i + 1].2 as usize);
        let (r1, r2) = (find(&mut parent, f1 as u32), find(&mut parent, f2 as u32));
        parent[r1 as usize] = r2;
        for (fa, fb) in [(f1, f2), (f2, f1)] {
            let bt = faces[fa] as usize / 4;
            if vols[bt].abs() < vol_eps {
                continue; // a flat tet has no outward side to test against
            }
            let t = tris[fa];
            let n = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]));
            let len = n.length();
            if len == 0.0 {
                continue;
            }
            let other = tris[fb]
                .iter()
                .copied()
                .find(|&v| v != edges[i].0 && v != edges[i].1);
            if let Some(o) = other {
                if n.dot(p(o) - p(t[0])) / len > eps {
                    return false;
                }
            }
        }
        i += 2;
    }
    let root = find(&mut parent, 0);
    (0..tris.len() as u32).all(|f| find(&mut parent, f) == root)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::split::{hex_corner, hex_split_pattern};
    use crate::io::Split;

    /// A unit cube split into 5 tets (the conforming "alternating" split, one parity).
    pub(crate) fn cube5() -> Mesh {
        let p: Vec<DVec3> = (0..8)
            .map(|q| DVec3::from(hex_corner(q).map(|x| x as f64)))
            .collect();
        let tets = hex_split_pattern(Split::Five, false)
            .iter()
            .map(|t| t.map(|q| q as u32))
            .collect();
        let s = (0..8).map(|i| i as f64).collect();
        Mesh::with_scalars("cube5", p, tets, "s", s).unwrap()
    }

    #[test]
    fn cube_derived_data() {
        let m = cube5();
        let vols = m.volumes();
        let total: f64 = vols.iter().map(|v| v.abs()).sum();
        assert!((total - 1.0).abs() < 1e-12, "volumes sum to {total}");
        assert!((vols[2].abs() - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(m.degenerate_tets(), 0);
        assert_eq!(m.boundary_faces().len(), 12);
        assert!((m.diagonal() - 3f64.sqrt()).abs() < 1e-15);
        assert_eq!(m.scalar_range(), (0.0, 7.0));
        // The central tet touches all four corner tets.
        let mut n = m.adjacency().neighbors[2];
        n.sort();
        assert_eq!(n, [0, 1, 3, 4]);
        assert!(m.is_convex());
    }

    #[test]
    fn l_shape_is_not_convex() {
        // Two cubes side by side are convex; three in an L are not.
        let mut pos = Vec::new();
        let mut tets = Vec::new();
        for (ox, oy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)] {
            let base = pos.len() as u32;
            for i in 0..8 {
                pos.push(DVec3::new(
                    ox + (i & 1) as f64,
                    oy + ((i >> 1) & 1) as f64,
                    ((i >> 2) & 1) as f64,
                ));
            }
            // 6-tet Kuhn split along the 0-7 diagonal: conforming under translation.
            for t in hex_split_pattern(Split::Six, false) {
                tets.push(t.map(|v| base + v as u32));
            }
        }
        // Merge duplicate corner vertices so the cubes share faces.
        let mut uniq: Vec<DVec3> = Vec::new();
        let remap: Vec<u32> = pos
            .iter()
            .map(|p| match uniq.iter().position(|q| q == p) {
                Some(i) => i as u32,
                None => {
                    uniq.push(*p);
                    (uniq.len() - 1) as u32
                }
            })
            .collect();
        let tets: Vec<[u32; 4]> = tets.iter().map(|t| t.map(|v| remap[v as usize])).collect();
        let n = uniq.len();
        let l3 = Mesh::with_scalars("L", uniq.clone(), tets.clone(), "s", vec![0.0; n]).unwrap();
        assert_eq!(l3.boundary_faces().len(), 3 * 12 - 2 * 4);
        assert!(!l3.is_convex());
        let two = Mesh::with_scalars("2", uniq, tets[..12].to_vec(), "s", vec![0.0; n]).unwrap();
        assert!(two.is_convex());
    }

    #[test]
    fn bad_meshes_are_refused() {
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        assert!(Mesh::with_scalars("m", p.clone(), vec![[0, 1, 2, 4]], "s", vec![0.0; 4]).is_err());
        assert!(Mesh::with_scalars("m", p.clone(), vec![], "s", vec![0.0; 4]).is_err());
        assert!(Mesh::with_scalars("m", p.clone(), vec![[0, 1, 2, 3]], "s", vec![0.0; 3]).is_err());
        let e = Mesh::with_scalars("m", p.clone(), vec![[0, 1, 2, 3]], "s", vec![f64::NAN; 4])
            .unwrap_err();
        assert!(e.to_string().starts_with("m: field 's' vertex 0"), "{e}");
        let mut bad = p;
        bad[2].y = f64::INFINITY;
        assert!(Mesh::with_scalars("m", bad, vec![[0, 1, 2, 3]], "s", vec![0.0; 4]).is_err());
    }

    #[test]
    fn degenerate_and_negative_tets_are_counted() {
        let p = vec![
            DVec3::ZERO,
            DVec3::X,
            DVec3::Y,
            DVec3::Z,
            DVec3::new(1.0, 1.0, 0.0),
        ];
        let m = Mesh::with_scalars(
            "m",
            p,
            vec![[0, 1, 2, 3], [0, 2, 1, 3], [0, 1, 2, 4]],
            "s",
            vec![0.0; 5],
        )
        .unwrap();
        assert_eq!(m.degenerate_tets(), 1);
        assert_eq!(m.negative_tets(), 1);
    }

    #[test]
    fn a_mesh_collapsed_to_a_point_is_all_degenerate() {
        let p = vec![DVec3::ONE; 4];
        let m = Mesh::with_scalars("pt", p, vec![[0, 1, 2, 3]], "s", vec![0.0; 4]).unwrap();
        assert_eq!(m.diagonal(), 0.0);
        assert_eq!(m.degenerate_tets(), 1);
        assert_eq!(m.negative_tets(), 0);
        assert!(!m.is_convex());
    }

    #[test]
    fn field_selection() {
        let mut m = cube5();
        m.add_field(Field {
            name: "t".into(),
            steps: vec![vec![1.0; 8], vec![2.0; 8]],
        })
        .unwrap();
        m.select_field("t", 1).unwrap();
        assert_eq!(m.scalar_range(), (2.0, 2.0));
        assert!(m.select_field("t", 2).is_err());
        assert!(m.select_field("nope", 0).is_err());
        m.select_field("s", 0).unwrap();
        assert_eq!(m.scalar_range(), (0.0, 7.0));
    }
}

//! An edge flip: the geometry of flipping one edge of a triangulation, and
//! the flip applied to the topology cache in place. A boundary edge (one
//! face) has no flip ([`Flip::of`] is `None`); an interior edge next to a
//! boundary flips like any other.
//!
//! A flip replaces the edge a–b, shared by faces (a, b, c) and (b, a, d),
//! with the edge c–d: faces (a, d, c) and (d, b, c). No vertex moves.
//! Metropolis flips ([`crate::remesh::flip`]) price it through the force
//! terms; the fluid model's maintenance flips take it when it makes the
//! mesh more Delaunay.

use crate::mesh::topology::{NO_SLOT, Topology, TopologyError};
use glam::DVec3;

/// A flip of one edge, in dense slots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Flip {
    /// Edge slot of a–b.
    pub edge: u32,
    /// The edge's ends.
    pub a: u32,
    /// See `a`.
    pub b: u32,
    /// Opposite corner of the face (a, b, c).
    pub c: u32,
    /// Opposite corner of the face (b, a, d).
    pub d: u32,
    /// Face slots of (a, b, c) and (b, a, d).
    pub faces: [u32; 2],
}

impl Flip {
    /// The flip of edge slot `edge`, if its two faces exist and c ≠ d.
    pub fn of(t: &Topology, edge: u32) -> Option<Self> {
        let [f0, f1] = t.edge_faces[edge as usize];
        let [p, q] = t.edges[edge as usize];
        let mut abc = None;
        let mut bad = None;
        for f in [f0, f1] {
            let tri = t.faces.get(f as usize)?;
            // The face that traverses p → q is (a, b, c) with a = p.
            for k in 0..3 {
                if tri[k] == p && tri[(k + 1) % 3] == q {
                    abc = Some((f, tri[(k + 2) % 3]));
                } else if tri[k] == q && tri[(k + 1) % 3] == p {
                    bad = Some((f, tri[(k + 2) % 3]));
                }
            }
        }
        let ((fc, c), (fd, d)) = (abc?, bad?);
        (c != d).then_some(Self {
            edge,
            a: p,
            b: q,
            c,
            d,
            faces: [fc, fd],
        })
    }

    /// The two faces after the flip: (a, d, c) and (d, b, c).
    pub fn new_faces(&self) -> [[u32; 3]; 2] {
        [[self.a, self.d, self.c], [self.d, self.b, self.c]]
    }

    /// The two faces before the flip: (a, b, c) and (b, a, d).
    pub fn old_faces(&self) -> [[u32; 3]; 2] {
        [[self.a, self.b, self.c], [self.b, self.a, self.d]]
    }

    /// The flip as a mesh edit: its two faces out, the two new ones in
    /// (entities from `t`, the topology it was found in).
    pub fn edit(&self, t: &Topology) -> crate::mesh::edit::PatchEdit {
        let [a, b, c, d] = [self.a, self.b, self.c, self.d].map(|v| t.vertex_entities[v as usize]);
        crate::mesh::edit::PatchEdit {
            remove_faces: self.faces.map(|f| t.face_entities[f as usize]).to_vec(),
            add_faces: vec![[a, d, c], [d, b, c]],
            ..Default::default()
        }
    }
}

/// Unit normal of a triangle of positions (zero for a degenerate one).
fn normal(p: &[DVec3], f: [u32; 3]) -> DVec3 {
    let [a, b, c] = f.map(|i| p[i as usize]);
    (b - a).cross(c - a).normalize_or_zero()
}

/// Cotangent of the angle at `o` in the triangle (o, p, q).
fn cot_at(o: DVec3, p: DVec3, q: DVec3) -> f64 {
    let (u, v) = (p - o, q - o);
    u.dot(v) / u.cross(v).length().max(f64::MIN_POSITIVE)
}

/// Whether the flip's edge a–b is not locally Delaunay: cot∠c + cot∠d < 0
/// (the opposite angles sum to more than π).
pub fn is_non_delaunay(flip: &Flip, positions: &[DVec3]) -> bool {
    let [a, b, c, d] = [flip.a, flip.b, flip.c, flip.d].map(|v| positions[v as usize]);
    cot_at(c, a, b) + cot_at(d, a, b) < -1e-12
}

/// Angle between the normals of the flip's two faces (radians; 0: flat).
pub fn dihedral(flip: &Flip, positions: &[DVec3]) -> f64 {
    let [a, b, c, d] = [flip.a, flip.b, flip.c, flip.d].map(|v| positions[v as usize]);
    let n1 = (b - a).cross(c - a).normalize_or_zero();
    let n2 = (a - b).cross(d - b).normalize_or_zero();
    n1.dot(n2).clamp(-1.0, 1.0).acos()
}

/// Whether the flip keeps the surface unfolded both ways: the two faces
/// before and the two after each meet at a dihedral angle below 90° from
/// flat (n₁·n₂ > 0). Required in both states, so the rule is symmetric and
/// the reverse flip is allowed exactly when this one is.
pub fn keeps_surface_unfolded(flip: &Flip, positions: &[DVec3]) -> bool {
    let [o0, o1] = flip.old_faces();
    let [n0, n1] = flip.new_faces();
    normal(positions, o0).dot(normal(positions, o1)) > 0.0
        && normal(positions, n0).dot(normal(positions, n1)) > 0.0
}

/// Signed volume of the tetrahedron of a face and `origin` (l̄³).
fn face_volume(p: &[DVec3], f: [u32; 3], origin: DVec3) -> f64 {
    let [a, b, c] = f.map(|i| p[i as usize] - origin);
    a.dot(b.cross(c)) / 6.0
}

/// Area of a face (l̄²).
fn face_area(p: &[DVec3], f: [u32; 3]) -> f64 {
    let [a, b, c] = f.map(|i| p[i as usize]);
    0.5 * (b - a).cross(c - a).length()
}

/// Running totals a flip's penalty terms need (updated as flips are taken).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlipTotals {
    /// Enclosed volume (l̄³).
    pub volume: f64,
    /// Area (l̄²).
    pub area: f64,
}

impl FlipTotals {
    /// Volume and area of a closed mesh, as the penalties measure them.
    pub fn of(positions: &[DVec3], faces: &[[u32; 3]]) -> Self {
        let origin = positions.first().copied().unwrap_or(DVec3::ZERO);
        Self {
            volume: crate::mesh::geometry::enclosed_volume(positions, faces, origin),
            area: crate::mesh::geometry::total_area(positions, faces),
        }
    }
}

impl Flip {
    /// The change of the area and the enclosed volume the flip causes at
    /// `positions` (l̄², l̄³). The four faces share one boundary, so ΔV does
    /// not depend on the origin (here a corner, for round-off).
    pub fn totals_change(&self, positions: &[DVec3]) -> FlipTotals {
        let p = positions;
        let old = self.old_faces();
        let new = self.new_faces();
        let o = p[self.a as usize];
        let volume = face_volume(p, new[0], o) + face_volume(p, new[1], o)
            - face_volume(p, old[0], o)
            - face_volume(p, old[1], o);
        let area = face_area(p, new[0]) + face_area(p, new[1])
            - face_area(p, old[0])
            - face_area(p, old[1]);
        FlipTotals { volume, area }
    }
}

/// What [`Topology::apply_flip`] overwrote, to put back with
/// [`Topology::undo_flip`].
#[derive(Clone, Debug)]
pub struct FlipUndo {
    flip: Flip,
    epoch: u64,
    faces: [([u32; 3], [u32; 3]); 2],
    edges: [(u32, [u32; 2], [u32; 2]); 3],
    rings: [SavedRing; 4],
}

/// A vertex's ring block as it was: the vertex, its valence and the
/// block's neighbours, edges and faces.
#[derive(Clone, Debug)]
struct SavedRing {
    vertex: u32,
    valence: u32,
    ring: Vec<u32>,
    edges: Vec<u32>,
    faces: Vec<u32>,
}

/// Structure epochs of flipped scratch views: far above any membrane's
/// (which count edits from 0), and never the same twice.
static SCRATCH_EPOCH: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1 << 63);

/// The slot of the edge of face `f` that leaves corner `from`.
fn edge_leaving(t: &Topology, f: u32, from: u32) -> u32 {
    let face = t.faces[f as usize];
    let k = (0..3)
        .find(|&k| face[k] == from)
        .expect("corner of the face");
    t.face_edges[f as usize][k]
}

impl Topology {
    /// Applies `flip` (found in this topology) to the cache in place, in
    /// O(valence): the two faces keep their slots and become (a, d, c) and
    /// (d, b, c), the edge keeps its slot and becomes c–d, and the rings of
    /// a, b, c and d are rebuilt. The structure epoch becomes one no other
    /// topology has had (caches keyed by it rebuild). Entities are not touched (the flipped
    /// faces and edge keep their old entities), so this is a scratch view
    /// of the flipped mesh for pricing a flip, not an edit of the world
    /// (that is [`Flip::edit`]). On error (a ring outgrew its block) the
    /// cache is unchanged.
    pub fn apply_flip(&mut self, flip: &Flip) -> Result<FlipUndo, TopologyError> {
        let [fc, fd] = flip.faces;
        let (a, b, c, d) = (flip.a, flip.b, flip.c, flip.d);
        let e = flip.edge;
        let bc = edge_leaving(self, fc, b);
        let ca = edge_leaving(self, fc, c);
        let ad = edge_leaving(self, fd, a);
        let db = edge_leaving(self, fd, d);
        let stride = self.ring_stride;
        let save_ring = |t: &Topology, v: u32| {
            let lo = v as usize * stride;
            SavedRing {
                vertex: v,
                valence: t.ring_len[v as usize],
                ring: t.ring[lo..lo + stride].to_vec(),
                edges: t.ring_edges[lo..lo + stride].to_vec(),
                faces: t.ring_faces[lo..lo + stride].to_vec(),
            }
        };
        let undo = FlipUndo {
            flip: *flip,
            epoch: self.epoch,
            faces: [fc, fd].map(|f| (self.faces[f as usize], self.face_edges[f as usize])),
            edges: [e, ad, bc].map(|x| (x, self.edges[x as usize], self.edge_faces[x as usize])),
            rings: [a, b, c, d].map(|v| save_ring(self, v)),
        };
        // Fans after the flip: a leaves (d, b, c), b leaves (a, d, c), and
        // c and d gain the face they were not in.
        let fan = |t: &Topology, v: u32, drop: Option<u32>, add: Option<u32>| {
            let mut f: Vec<u32> = t
                .ring_faces_of(v as usize)
                .iter()
                .copied()
                .filter(|&x| x != NO_SLOT && Some(x) != drop)
                .chain(add)
                .collect();
            f.sort_unstable();
            f
        };
        let fans = [
            (a, fan(self, a, Some(fd), None)),
            (b, fan(self, b, Some(fc), None)),
            (c, fan(self, c, None, Some(fd))),
            (d, fan(self, d, None, Some(fc))),
        ];
        // A structure epoch of its own, so a term's caches keyed by the
        // epoch (the dihedral bending's edge quads) see a new mesh.
        self.epoch = SCRATCH_EPOCH.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.faces[fc as usize] = [a, d, c];
        self.face_edges[fc as usize] = [ad, e, ca];
        self.faces[fd as usize] = [d, b, c];
        self.face_edges[fd as usize] = [db, bc, e];
        self.edges[e as usize] = [c, d];
        // (d, b, c) traverses c → d, (a, d, c) d → c.
        self.edge_faces[e as usize] = [fd, fc];
        for f in &mut self.edge_faces[ad as usize] {
            if *f == fd {
                *f = fc;
            }
        }
        for f in &mut self.edge_faces[bc as usize] {
            if *f == fc {
                *f = fd;
            }
        }
        for (v, fan) in &fans {
            if let Err(err) = self.write_ring(*v as usize, fan) {
                self.undo_flip(undo);
                return Err(err);
            }
        }
        Ok(undo)
    }

    /// Puts back what [`Topology::apply_flip`] changed.
    pub fn undo_flip(&mut self, undo: FlipUndo) {
        self.epoch = undo.epoch;
        for (f, (corners, edges)) in undo.flip.faces.iter().zip(undo.faces) {
            self.faces[*f as usize] = corners;
            self.face_edges[*f as usize] = edges;
        }
        for (x, ends, faces) in undo.edges {
            self.edges[x as usize] = ends;
            self.edge_faces[x as usize] = faces;
        }
        let stride = self.ring_stride;
        for saved in undo.rings {
            let lo = saved.vertex as usize * stride;
            self.ring_len[saved.vertex as usize] = saved.valence;
            self.ring[lo..lo + stride].copy_from_slice(&saved.ring);
            self.ring_edges[lo..lo + stride].copy_from_slice(&saved.edges);
            self.ring_faces[lo..lo + stride].copy_from_slice(&saved.faces);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::membrane::Membrane;

    /// Neighbour sets from the faces alone.
    fn neighbour_sets(t: &Topology) -> Vec<std::collections::BTreeSet<u32>> {
        let mut s = vec![std::collections::BTreeSet::new(); t.vertex_count()];
        for f in &t.faces {
            for k in 0..3 {
                s[f[k] as usize].insert(f[(k + 1) % 3]);
                s[f[(k + 1) % 3] as usize].insert(f[k]);
            }
        }
        s
    }

    #[test]
    fn a_flip_in_place_is_a_consistent_topology_and_undoes_exactly() {
        let mesh = crate::mesh::icosphere(2, 1.0);
        let membrane = Membrane::from_mesh(&mesh, false).unwrap();
        let original = membrane.cached_topology().clone();
        let mut t = original.clone();
        let mut flipped = 0;
        for edge in 0..t.edges.len() as u32 {
            let Some(flip) = Flip::of(&t, edge) else {
                continue;
            };
            if t.edge_between(flip.c, flip.d).is_some() {
                continue;
            }
            let undo = t.apply_flip(&flip).unwrap();
            flipped += 1;
            let sets = neighbour_sets(&t);
            for v in 0..t.vertex_count() {
                let ring: std::collections::BTreeSet<u32> =
                    t.neighbours(v).iter().copied().collect();
                assert_eq!(ring, sets[v], "edge {edge}, vertex {v}");
                for (k, &f) in t.ring_faces_of(v).iter().enumerate() {
                    let n = t.neighbours(v);
                    let face = t.faces[f as usize];
                    let i = (0..3).find(|&i| face[i] as usize == v).unwrap();
                    assert_eq!(face[(i + 1) % 3], n[k]);
                    assert_eq!(face[(i + 2) % 3], n[(k + 1) % n.len()]);
                    assert!(t.edges[t.ring_edges_of(v)[k] as usize].contains(&n[k]));
                }
            }
            for (x, ends) in t.edges.iter().enumerate() {
                let [l, r] = t.edge_faces[x];
                let traverses = |f: u32, p: u32, q: u32| {
                    let face = t.faces[f as usize];
                    (0..3).any(|k| face[k] == p && face[(k + 1) % 3] == q)
                };
                assert!(traverses(l, ends[0], ends[1]), "edge {x}");
                assert!(traverses(r, ends[1], ends[0]), "edge {x}");
            }
            for (f, edges) in t.face_edges.iter().enumerate() {
                let face = t.faces[f];
                for k in 0..3 {
                    let ends = t.edges[edges[k] as usize];
                    assert!(ends.contains(&face[k]) && ends.contains(&face[(k + 1) % 3]));
                }
            }
            // The incidence of the flipped view is rebuilt for it.
            if flipped % 16 == 1 {
                use crate::util::parallel::Incidence;
                let n = t.vertex_count();
                assert_eq!(*t.face_incidence(), Incidence::from_items(&t.faces, n));
                assert_eq!(*t.edge_incidence(), Incidence::from_items(&t.edges, n));
            }
            t.undo_flip(undo);
            assert!(t.same_as(&original), "undo of edge {edge}");
        }
        assert!(flipped > 100);
    }
}

//! The mesh invariant checker shared by tests, the debug mode and file import.
//!
//! A valid membrane mesh is edge- and vertex-manifold and consistently
//! oriented, has no duplicate or degenerate faces, finite coordinates and
//! valences within a given range, and every connected component is a
//! topological sphere with b ≥ 0 holes (Euler characteristic 2 − b, b its
//! boundary loops). A closed component (b = 0) is oriented outward (positive
//! enclosed volume). An open one has boundary edges (one face each), and
//! each of its boundary vertices lies on exactly one boundary fan: two loops
//! touching at a vertex (a bow-tie) are not manifold. The first violation
//! found is returned as a [`MeshError`] naming the offending element.

use glam::DVec3;
// Integer keys; every iteration over a map is sorted first.
use rustc_hash::FxHashMap as HashMap;

/// A face whose area is below this fraction of the squared mean edge length
/// is degenerate (zero-area up to round-off).
pub const DEGENERATE_AREA_RATIO: f64 = 1e-10;

/// Inclusive vertex valence limits (the paper's default is 5..=8, fusion 5..=10).
/// They are an interior vertex's; a boundary vertex, whose fan spans half a
/// turn (a flat lattice's has 4 neighbours where an interior one has 6), is
/// held to `max(min − 2, 2)..=max − 2` ([`ValenceRange::for_boundary`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValenceRange {
    /// Smallest allowed number of 1-ring neighbours.
    pub min: u32,
    /// Largest allowed number of 1-ring neighbours.
    pub max: u32,
}

impl ValenceRange {
    /// The limits for a boundary vertex: `max(min − 2, 2)..=max − 2`.
    pub fn for_boundary(self) -> Self {
        Self {
            min: self.min.saturating_sub(2).max(2),
            max: self.max.saturating_sub(2),
        }
    }
}

impl Default for ValenceRange {
    fn default() -> Self {
        Self { min: 5, max: 8 }
    }
}

/// A violated mesh invariant, naming the element (0-based indices).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// The mesh has no faces.
    #[error("mesh has no faces")]
    Empty,
    /// A coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate {position:?}")]
    NonFiniteVertex {
        /// Vertex index.
        vertex: usize,
        /// Its position.
        position: [f64; 3],
    },
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {index}, but the mesh has {count} vertices")]
    FaceIndexOutOfRange {
        /// Face index.
        face: usize,
        /// The bad vertex index.
        index: u32,
        /// Number of vertices.
        count: usize,
    },
    /// A face uses the same vertex twice.
    #[error("face {face} {vertices:?} repeats a vertex")]
    RepeatedVertexInFace {
        /// Face index.
        face: usize,
        /// Its vertices.
        vertices: [u32; 3],
    },
    /// A face has (numerically) zero area.
    #[error("face {face} {vertices:?} is degenerate (area {area:e})")]
    DegenerateFace {
        /// Face index.
        face: usize,
        /// Its vertices.
        vertices: [u32; 3],
        /// Its area.
        area: f64,
    },
    /// Two faces use the same three vertices.
    #[error("faces {first} and {second} are duplicates (vertices {vertices:?})")]
    DuplicateFace {
        /// First face index.
        first: usize,
        /// Second face index.
        second: usize,
        /// Shared vertices.
        vertices: [u32; 3],
    },
    /// An edge has more than two incident faces.
    #[error("edge ({a}, {b}) has {count} incident faces: the mesh is not manifold there")]
    NonManifoldEdge {
        /// First vertex.
        a: u32,
        /// Second vertex.
        b: u32,
        /// Number of incident faces.
        count: usize,
    },
    /// Two faces traverse their shared edge in the same direction.
    #[error("faces {first} and {second} both traverse edge {a}->{b}: inconsistent orientation")]
    InconsistentOrientation {
        /// Edge start.
        a: u32,
        /// Edge end.
        b: u32,
        /// First face.
        first: usize,
        /// Second face.
        second: usize,
    },
    /// A vertex belongs to no face.
    #[error("vertex {vertex} belongs to no face")]
    IsolatedVertex {
        /// Vertex index.
        vertex: usize,
    },
    /// The faces around a vertex do not form a single disc.
    #[error("vertex {vertex} is not manifold: its faces form {fans} separate fans")]
    NonManifoldVertex {
        /// Vertex index.
        vertex: usize,
        /// Number of separate face fans.
        fans: usize,
    },
    /// A component is not a topological sphere (with holes).
    #[error(
        "component {component} (containing vertex {vertex}) has Euler characteristic {chi}, \
         expected {} (a sphere with {boundary_loops} boundary loops)",
        2 - *boundary_loops as i64
    )]
    WrongEulerCharacteristic {
        /// Component index.
        component: usize,
        /// A vertex in it.
        vertex: u32,
        /// V − E + F of the component.
        chi: i64,
        /// Its number of boundary loops.
        boundary_loops: usize,
    },
    /// A component's faces are oriented inward (negative enclosed volume).
    #[error(
        "component {component} (containing vertex {vertex}) is oriented inward (signed volume {volume:e})"
    )]
    InwardOrientation {
        /// Component index.
        component: usize,
        /// A vertex in it.
        vertex: u32,
        /// Its signed volume.
        volume: f64,
    },
    /// A vertex has too few or too many neighbours (a boundary vertex's
    /// limits are the range's shifted down by 2, see [`ValenceRange`]).
    #[error(
        "{} {vertex} has valence {valence}, outside the allowed {min}..={max}",
        if *boundary { "boundary vertex" } else { "vertex" }
    )]
    ValenceOutOfRange {
        /// Whether the vertex lies on a boundary loop.
        boundary: bool,
        /// Vertex index.
        vertex: usize,
        /// Its valence.
        valence: u32,
        /// Allowed minimum.
        min: u32,
        /// Allowed maximum.
        max: u32,
    },
}

/// Summary of a mesh that passed every check.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshReport {
    /// Number of vertices.
    pub vertices: usize,
    /// Number of unique edges.
    pub edges: usize,
    /// Number of faces.
    pub faces: usize,
    /// Number of connected components.
    pub components: usize,
    /// Valence (number of neighbours) of every vertex.
    pub valences: Vec<u32>,
    /// Number of boundary loops (0: closed).
    pub boundary_loops: usize,
}

/// Checks every invariant of a membrane mesh, closed or open (see the module
/// docs). `valence` = `None` skips the valence limits (used on import; scenes
/// apply their own limits later).
pub fn check_mesh(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    valence: Option<ValenceRange>,
) -> Result<MeshReport, MeshError> {
    check_indices(positions, faces)?;
    let n = positions.len();
    check_degenerate_faces(positions, faces)?;
    check_duplicate_faces(faces)?;
    let (edge_keys, boundary) = check_edges(faces)?;
    let (valences, on_boundary) = check_vertex_links(n, faces)?;
    let (components, boundary_loops) = check_components(positions, faces, &edge_keys, &boundary)?;
    if let Some(interior) = valence {
        for (vertex, &valence) in valences.iter().enumerate() {
            let boundary = on_boundary[vertex];
            let range = if boundary {
                interior.for_boundary()
            } else {
                interior
            };
            if valence < range.min || valence > range.max {
                return Err(MeshError::ValenceOutOfRange {
                    boundary,
                    vertex,
                    valence,
                    min: range.min,
                    max: range.max,
                });
            }
        }
    }

    Ok(MeshReport {
        vertices: n,
        edges: edge_keys.len(),
        faces: faces.len(),
        components,
        valences,
        boundary_loops,
    })
}

/// Non-empty, finite positions, indices in range, three distinct corners.
fn check_indices(positions: &[DVec3], faces: &[[u32; 3]]) -> Result<(), MeshError> {
    let n = positions.len();
    if faces.is_empty() {
        return Err(MeshError::Empty);
    }
    for (vertex, p) in positions.iter().enumerate() {
        if !p.is_finite() {
            return Err(MeshError::NonFiniteVertex {
                vertex,
                position: p.to_array(),
            });
        }
    }
    for (face, f) in faces.iter().enumerate() {
        if let Some(&index) = f.iter().find(|&&v| v as usize >= n) {
            return Err(MeshError::FaceIndexOutOfRange {
                face,
                index,
                count: n,
            });
        }
        if f[0] == f[1] || f[1] == f[2] || f[0] == f[2] {
            return Err(MeshError::RepeatedVertexInFace { face, vertices: *f });
        }
    }

    Ok(())
}

/// No face with an area below [`DEGENERATE_AREA_RATIO`] of the squared mean
/// edge length.
fn check_degenerate_faces(positions: &[DVec3], faces: &[[u32; 3]]) -> Result<(), MeshError> {
    // Degenerate faces, relative to the mean edge length.
    let mut edge_sum = 0.0;
    for f in faces {
        for k in 0..3 {
            edge_sum += positions[f[k] as usize].distance(positions[f[(k + 1) % 3] as usize]);
        }
    }
    let mean_edge = edge_sum / (3 * faces.len()) as f64;
    let min_area = DEGENERATE_AREA_RATIO * mean_edge * mean_edge;
    for (face, f) in faces.iter().enumerate() {
        let [a, b, c] = f.map(|v| positions[v as usize]);
        let area = 0.5 * (b - a).cross(c - a).length();
        if area.is_nan() || area <= min_area {
            return Err(MeshError::DegenerateFace {
                face,
                vertices: *f,
                area,
            });
        }
    }

    Ok(())
}

/// No two faces on the same three vertices.
fn check_duplicate_faces(faces: &[[u32; 3]]) -> Result<(), MeshError> {
    // Duplicate faces (same vertex set in any order).
    let mut seen: HashMap<[u32; 3], usize> =
        HashMap::with_capacity_and_hasher(faces.len(), Default::default());
    for (face, f) in faces.iter().enumerate() {
        let mut key = *f;
        key.sort_unstable();
        if let Some(&first) = seen.get(&key) {
            return Err(MeshError::DuplicateFace {
                first,
                second: face,
                vertices: *f,
            });
        }
        seen.insert(key, face);
    }

    Ok(())
}

/// Every edge in one face (a boundary edge) or two, traversed once each
/// way; returns the edges as sorted (low, high) pairs and the boundary edges
/// directed as their face traverses them.
type EdgeLists = (Vec<(u32, u32)>, Vec<(u32, u32)>);
fn check_edges(faces: &[[u32; 3]]) -> Result<EdgeLists, MeshError> {
    // Edge incidence and orientation.
    let mut undirected: HashMap<(u32, u32), Vec<(usize, bool)>> =
        HashMap::with_capacity_and_hasher(faces.len() * 3 / 2, Default::default());
    for (face, f) in faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            undirected
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push((face, a < b));
        }
    }
    let mut edge_keys: Vec<_> = undirected.keys().copied().collect();
    edge_keys.sort_unstable();
    let mut boundary = Vec::new();
    for &(a, b) in &edge_keys {
        let uses = &undirected[&(a, b)];
        match uses.len() {
            1 => boundary.push(if uses[0].1 { (a, b) } else { (b, a) }),
            2 => {
                if uses[0].1 == uses[1].1 {
                    let (a, b) = if uses[0].1 { (a, b) } else { (b, a) };
                    return Err(MeshError::InconsistentOrientation {
                        a,
                        b,
                        first: uses[0].0,
                        second: uses[1].0,
                    });
                }
            }
            count => return Err(MeshError::NonManifoldEdge { a, b, count }),
        }
    }

    Ok((edge_keys, boundary))
}

/// Every vertex in a face, its faces one fan (closed, or open between two
/// boundary edges); returns the valences (neighbour counts) and whether
/// each vertex is on the boundary.
fn check_vertex_links(n: usize, faces: &[[u32; 3]]) -> Result<(Vec<u32>, Vec<bool>), MeshError> {
    // Vertex manifoldness: the link of every vertex is a single cycle or a
    // single path. link[v] holds (a, b) for each face (v, a, b) in
    // counter-clockwise order.
    let mut link: Vec<Vec<(u32, u32)>> = vec![Vec::new(); n];
    for f in faces {
        for k in 0..3 {
            link[f[k] as usize].push((f[(k + 1) % 3], f[(k + 2) % 3]));
        }
    }
    let mut valences = vec![0u32; n];
    let mut on_boundary = vec![false; n];
    for (vertex, l) in link.iter().enumerate() {
        if l.is_empty() {
            return Err(MeshError::IsolatedVertex { vertex });
        }
        // Edge-manifold + orientable guarantee each neighbour appears at
        // most once as a start and once as an end; count the paths (from
        // starts that are no end) and then the cycles of the successor map
        // (a link has a handful of pairs: searched, not hashed).
        let next = |a: u32| l.iter().find(|(s, _)| *s == a).map(|&(_, b)| b);
        let heads: Vec<u32> = l
            .iter()
            .map(|&(s, _)| s)
            .filter(|&s| !l.iter().any(|&(_, e)| e == s))
            .collect();
        let mut visited: Vec<u32> = Vec::with_capacity(l.len());
        let mut fans = heads.len();
        let walk = |start: u32, visited: &mut Vec<u32>| {
            let mut cur = start;
            while !visited.contains(&cur) {
                visited.push(cur);
                match next(cur) {
                    Some(nx) => cur = nx,
                    None => break,
                }
            }
        };
        for &h in &heads {
            walk(h, &mut visited);
        }
        for &(start, _) in l {
            if !visited.contains(&start) {
                fans += 1;
                walk(start, &mut visited);
            }
        }
        if fans != 1 {
            return Err(MeshError::NonManifoldVertex { vertex, fans });
        }
        valences[vertex] = (l.len() + heads.len()) as u32;
        on_boundary[vertex] = !heads.is_empty();
    }

    Ok((valences, on_boundary))
}

/// Every connected component a sphere with b holes (χ = 2 − b, b its
/// boundary loops), a closed one enclosing a positive volume; returns how
/// many components and boundary loops there are. `boundary` holds the
/// boundary edges directed as their faces traverse them (each boundary
/// vertex starts exactly one: the links were checked first).
fn check_components(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    edge_keys: &[(u32, u32)],
    boundary: &[(u32, u32)],
) -> Result<(usize, usize), MeshError> {
    let n = positions.len();
    // Connected components (union-find over vertices through faces).
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    for f in faces {
        for k in 1..3 {
            let (ra, rb) = (find(&mut parent, f[0]), find(&mut parent, f[k]));
            if ra != rb {
                parent[ra.max(rb) as usize] = ra.min(rb);
            }
        }
    }
    let mut component_of_root: HashMap<u32, usize> = HashMap::default();
    let mut roots = Vec::new();
    let mut comp = vec![0usize; n];
    for v in 0..n as u32 {
        let r = find(&mut parent, v);
        let next_id = component_of_root.len();
        let c = *component_of_root.entry(r).or_insert_with(|| {
            roots.push(v);
            next_id
        });
        comp[v as usize] = c;
    }
    let components = roots.len();
    let mut chi = vec![0i64; components];
    let mut volume = vec![0.0f64; components];
    for v in 0..n {
        chi[comp[v]] += 1;
    }
    for &(a, _) in edge_keys {
        chi[comp[a as usize]] -= 1;
    }
    for f in faces {
        let c = comp[f[0] as usize];
        chi[c] += 1;
        // Signed volume relative to the component's first vertex (translation
        // invariant for closed surfaces, better conditioned than the origin).
        let o = positions[roots[c] as usize];
        let [a, b, d] = f.map(|v| positions[v as usize] - o);
        volume[c] += a.dot(b.cross(d)) / 6.0;
    }
    let loops = count_boundary_loops(boundary, &comp, components);
    for c in 0..components {
        if chi[c] + loops[c] as i64 != 2 {
            return Err(MeshError::WrongEulerCharacteristic {
                component: c,
                vertex: roots[c],
                chi: chi[c],
                boundary_loops: loops[c],
            });
        }
        // An open component encloses no volume: its orientation is the
        // one its faces agree on.
        if loops[c] == 0 && (volume[c].is_nan() || volume[c] <= 0.0) {
            return Err(MeshError::InwardOrientation {
                component: c,
                vertex: roots[c],
                volume: volume[c],
            });
        }
    }

    Ok((components, loops.iter().sum()))
}

/// The number of boundary loops of each component: the cycles of the
/// successor map of the directed boundary edges.
fn count_boundary_loops(boundary: &[(u32, u32)], comp: &[usize], components: usize) -> Vec<usize> {
    let mut loops = vec![0usize; components];
    if boundary.is_empty() {
        return loops;
    }
    let next: HashMap<u32, u32> = boundary.iter().copied().collect();
    let mut starts: Vec<u32> = boundary.iter().map(|&(a, _)| a).collect();
    starts.sort_unstable();
    let mut seen: rustc_hash::FxHashSet<u32> = Default::default();
    for s in starts {
        if !seen.insert(s) {
            continue;
        }
        loops[comp[s as usize]] += 1;
        let mut cur = next[&s];
        while seen.insert(cur) {
            cur = next[&cur];
        }
    }
    loops
}

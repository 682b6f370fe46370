//! Two-vesicle docking for the fusion scene (SPEC §1, reference §7b).

use super::{SurfaceMesh, icosphere};
use glam::DVec3;

/// Two icospheres of `level` subdivisions (mean edge length 1) placed side by
/// side along +x so that their facing vertices touch, glued through a single
/// triangular neck: the closest pair of faces around the facing vertices is
/// removed and its three vertex pairs are merged at their midpoints.
///
/// At level 2 this gives 321 vertices, 957 edges and 638 faces. The gluing
/// pairs the two triangles in opposite cyclic order so the result stays
/// consistently outward-oriented.
pub fn docked_pair(level: u32) -> SurfaceMesh {
    let first = icosphere(level, 1.0);
    let radius = first
        .positions
        .iter()
        .map(|p| p.length())
        .fold(0.0, f64::max);
    let mut second = first.clone();
    second.translate(DVec3::new(2.0 * radius, 0.0, 0.0));

    let facing_first = argmax_by(&first.positions, |p| p.x);
    let facing_second = argmax_by(&second.positions, |p| -p.x);
    let centroid = |m: &SurfaceMesh, f: &[u32; 3]| {
        f.iter().map(|&v| m.positions[v as usize]).sum::<DVec3>() / 3.0
    };

    // Closest pair of faces incident to the two facing vertices.
    let mut best: Option<(f64, usize, usize)> = None;
    for (i, fa) in first.faces.iter().enumerate() {
        if !fa.contains(&(facing_first as u32)) {
            continue;
        }
        for (j, fb) in second.faces.iter().enumerate() {
            if !fb.contains(&(facing_second as u32)) {
                continue;
            }
            let d = centroid(&first, fa).distance(centroid(&second, fb));
            if best.is_none_or(|(bd, _, _)| d < bd) {
                best = Some((d, i, j));
            }
        }
    }
    let (_, face_first, face_second) = best.expect("an icosphere vertex always has incident faces");
    let fa = first.faces[face_first];
    let fb = second.faces[face_second];

    // Pair fa = (a, b, c) with fb taken in reverse cyclic order, choosing the
    // rotation with the least total distance.
    let reversed = [fb[0], fb[2], fb[1]];
    let mut pairing = [0u32; 3];
    let mut best_cost = f64::INFINITY;
    for shift in 0..3 {
        let candidate = [0, 1, 2].map(|k| reversed[(k + shift) % 3]);
        let cost: f64 = (0..3)
            .map(|k| {
                first.positions[fa[k] as usize].distance(second.positions[candidate[k] as usize])
            })
            .sum();
        if cost < best_cost {
            best_cost = cost;
            pairing = candidate;
        }
    }

    let n_first = first.positions.len() as u32;
    let mut positions = first.positions.clone();
    for k in 0..3 {
        let a = fa[k] as usize;
        positions[a] = 0.5 * (first.positions[a] + second.positions[pairing[k] as usize]);
    }
    // Index map for the second sphere: merged vertices map onto the first.
    let mut remap = vec![u32::MAX; second.positions.len()];
    for k in 0..3 {
        remap[pairing[k] as usize] = fa[k];
    }
    let mut next = n_first;
    for (v, p) in second.positions.iter().enumerate() {
        if remap[v] == u32::MAX {
            remap[v] = next;
            positions.push(*p);
            next += 1;
        }
    }
    let mut faces: Vec<[u32; 3]> = first
        .faces
        .iter()
        .enumerate()
        .filter(|&(i, _)| i != face_first)
        .map(|(_, f)| *f)
        .collect();
    faces.extend(
        second
            .faces
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != face_second)
            .map(|(_, f)| f.map(|v| remap[v as usize])),
    );
    SurfaceMesh { positions, faces }
}

fn argmax_by(points: &[DVec3], key: impl Fn(&DVec3) -> f64) -> usize {
    let mut best = 0;
    for (i, p) in points.iter().enumerate() {
        if key(p) > key(&points[best]) {
            best = i;
        }
    }
    best
}

//! Checking a step of the vertex positions: the first face whose
//! orientation reversed within it (a vertex crossed the opposite edge: the
//! step was too large for the forces), and the enclosed volume after it, in
//! one pass over the faces. The integrator undoes and halves such a step;
//! the minimiser undoes it too.

/// Checks a step: the first face (slot) whose orientation reverses between
/// `before` and `after` (a vertex crossed the opposite edge within one
/// step: the step was too large for the forces), and the enclosed volume
/// after the step (l̄³), in one pass over the faces.
pub fn check_step(
    faces: &[[u32; 3]],
    before: &[glam::DVec3],
    after: &[glam::DVec3],
) -> (Option<usize>, f64) {
    check_step_with(faces, before, after, &mut Vec::new())
}

/// [`check_step`] with a reusable per-face buffer for the parallel form:
/// each face's signed volume term and whether it turned in parallel, the
/// volume summed in face order.
pub fn check_step_with(
    faces: &[[u32; 3]],
    before: &[glam::DVec3],
    after: &[glam::DVec3],
    per_face: &mut Vec<(f64, bool)>,
) -> (Option<usize>, f64) {
    let face_check = |k: usize| {
        let [a0, b0, c0] = faces[k].map(|v| before[v as usize]);
        let [a, b, c] = faces[k].map(|v| after[v as usize]);
        let n = (b - a).cross(c - a);
        (a.dot(n), (b0 - a0).cross(c0 - a0).dot(n) < 0.0)
    };
    if crate::util::parallel::splits(faces.len()) {
        crate::util::parallel::fill_vec(per_face, faces.len(), face_check);
        let turned = crate::util::parallel::position_first(faces.len(), |k| per_face[k].1);
        let mut six_volume = 0.0;
        for (v, _) in per_face.iter() {
            six_volume += v;
        }
        return (turned, six_volume / 6.0);
    }
    let mut turned = None;
    let mut six_volume = 0.0;
    for (k, f) in faces.iter().enumerate() {
        let [a0, b0, c0] = f.map(|v| before[v as usize]);
        let [a, b, c] = f.map(|v| after[v as usize]);
        let n = (b - a).cross(c - a);
        six_volume += a.dot(n);
        if turned.is_none() && (b0 - a0).cross(c0 - a0).dot(n) < 0.0 {
            turned = Some(k);
        }
    }
    (turned, six_volume / 6.0)
}

//! The candidate patches of a split or merge, and the choice among them by
//! valence and edge lengths.

use super::*;

/// The candidate re-triangulations of one split or merge: the edit they
/// share (faces removed, vertices added, removed or moved, faces added
/// outside the quadrilaterals) and each quadrilateral's faces with its old
/// and its new diagonal. Candidate `bits` takes quad q's new diagonal when
/// bit q is set. Candidates are built on demand, not stored.
#[derive(Clone, Debug)]
pub struct Candidates {
    pub(super) base: PatchEdit,
    pub(super) quads: Vec<Quad>,
}

impl Candidates {
    /// The number of candidates, 2^(quadrilaterals).
    pub fn len(&self) -> usize {
        1 << self.quads.len()
    }

    /// Always false: every split or merge has candidates.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Candidate `bits`, built in full.
    pub fn get(&self, bits: usize) -> Candidate {
        Candidate {
            diagonals: self.diagonals(bits),
            edit: self.edit(bits),
            diagonal_edges: self.diagonal_edges(bits).collect(),
        }
    }

    /// The edit of candidate `bits`.
    pub fn edit(&self, bits: usize) -> PatchEdit {
        let mut edit = self.base.clone();
        edit.add_faces.reserve_exact(2 * self.quads.len());
        self.push_quad_faces(bits, &mut edit.add_faces);
        edit
    }

    /// Per quadrilateral: whether candidate `bits` takes the new diagonal.
    pub fn diagonals(&self, bits: usize) -> Vec<bool> {
        (0..self.quads.len())
            .map(|q| bits & (1 << q) != 0)
            .collect()
    }

    /// The diagonal candidate `bits` takes in each quadrilateral.
    pub fn diagonal_edges(&self, bits: usize) -> impl Iterator<Item = (Entity, Entity)> + '_ {
        self.quads.iter().enumerate().map(
            move |(q, quad)| {
                if bits & (1 << q) != 0 { quad.3 } else { quad.2 }
            },
        )
    }

    /// Appends the faces candidate `bits` adds inside the quadrilaterals.
    pub(super) fn push_quad_faces(&self, bits: usize, faces: &mut Vec<[Entity; 3]>) {
        for (q, quad) in self.quads.iter().enumerate() {
            faces.extend_from_slice(if bits & (1 << q) != 0 {
                &quad.1
            } else {
                &quad.0
            });
        }
    }

    /// Rewrites `edit`, a copy of the shared edit, into candidate `bits`'s.
    pub(super) fn write_edit(&self, bits: usize, edit: &mut PatchEdit) {
        edit.add_faces.truncate(self.base.add_faces.len());
        self.push_quad_faces(bits, &mut edit.add_faces);
    }
}

/// The faces of region `r` that exist (a boundary's missing ones left out).
fn region_faces(r: &EdgeRegion) -> Vec<Entity> {
    r.central
        .iter()
        .chain(&r.outer)
        .copied()
        .filter(|&f| f != Entity::DANGLING)
        .collect()
}

/// Sorts quadrilaterals into `Candidates`: a quadrilateral whose far apex
/// is missing (`None`, beyond a boundary edge) is the one face left of it,
/// the same in every candidate, added to `base`.
fn candidates_of(mut base: PatchEdit, quads: Vec<(Quad, Option<[Entity; 3]>)>) -> Candidates {
    let mut kept = Vec::with_capacity(quads.len());
    for (quad, fixed) in quads {
        match fixed {
            None => kept.push(quad),
            Some(face) => base.add_faces.push(face),
        }
    }
    Candidates { base, quads: kept }
}

/// The split candidates for region `r` with new vertex `n` at `position`:
/// 16 inside, fewer next to a boundary (see [`EdgeRegion`]).
pub fn split_candidates(r: &EdgeRegion, n: Entity, position: DVec3) -> Candidates {
    let [i1, i2] = r.i;
    let [j1, j2] = r.j;
    let [k1, k2, k3, k4] = r.k;
    let missing = |k: Entity| k == Entity::DANGLING;
    // Per quadrilateral: (old-diagonal faces, new-diagonal faces, old and
    // new diagonal), and its one face if its far apex is missing.
    let mut quads = vec![
        (
            (
                [[i1, n, j1], [i1, j1, k1]],
                [[n, j1, k1], [n, k1, i1]],
                (i1, j1),
                (n, k1),
            ),
            missing(k1).then_some([i1, n, j1]),
        ),
        (
            (
                [[n, i2, j1], [j1, i2, k2]],
                [[n, i2, k2], [n, k2, j1]],
                (i2, j1),
                (n, k2),
            ),
            missing(k2).then_some([n, i2, j1]),
        ),
    ];
    if !r.on_boundary() {
        quads.extend([
            (
                (
                    [[i2, n, j2], [i2, j2, k3]],
                    [[n, j2, k3], [n, k3, i2]],
                    (i2, j2),
                    (n, k3),
                ),
                missing(k3).then_some([i2, n, j2]),
            ),
            (
                (
                    [[n, i1, j2], [j2, i1, k4]],
                    [[n, i1, k4], [n, k4, j2]],
                    (i1, j2),
                    (n, k4),
                ),
                missing(k4).then_some([n, i1, j2]),
            ),
        ]);
    }
    let base = PatchEdit {
        remove_faces: region_faces(r),
        add_vertices: vec![(n, position)],
        ..Default::default()
    };
    candidates_of(base, quads)
}

/// The merge candidates: i1 survives as i at `at`, i2 is removed. Inside,
/// 4; next to a boundary fewer (see [`EdgeRegion`]).
pub fn merge_candidates(m: &Membrane, r: &EdgeRegion, at: DVec3) -> Candidates {
    let [i, i2] = r.i;
    let [j1, j2] = r.j;
    let [k1, k2, k3, k4] = r.k;
    // Other faces of i2's fan, relabelled to i.
    let t = m.cached_topology();
    let patch = region_faces(r);
    let s2 = t.slot(i2).expect("live vertex") as usize;
    let mut relabelled_remove = Vec::new();
    let mut relabelled_add = Vec::new();
    for &f in t.ring_faces_of(s2) {
        if f == NO_SLOT {
            continue; // the open end of a boundary vertex's fan
        }
        let fe = t.face_entities[f as usize];
        if patch.contains(&fe) {
            continue;
        }
        relabelled_remove.push(fe);
        let tri = t.faces[f as usize].map(|v| t.vertex_entities[v as usize]);
        relabelled_add.push(tri.map(|v| if v == i2 { i } else { v }));
    }
    let mut base = PatchEdit {
        remove_faces: [patch.as_slice(), relabelled_remove.as_slice()].concat(),
        add_faces: relabelled_add,
        remove_vertices: vec![i2],
        move_vertices: vec![(i, at)],
        ..Default::default()
    };
    let mut quads = Vec::with_capacity(2);
    let sides = [(j1, k1, k2), (j2, k3, k4)];
    for (q, &(j, ka, kb)) in sides.iter().enumerate() {
        if q == 1 && r.on_boundary() {
            break;
        }
        let old = [[i, j, ka], [j, i, kb]];
        match (ka == Entity::DANGLING, kb == Entity::DANGLING) {
            (false, false) => quads.push((old, [[ka, i, kb], [kb, j, ka]], (i, j), (ka, kb))),
            (true, false) => base.add_faces.push(old[1]),
            (false, true) => base.add_faces.push(old[0]),
            // Both sides on the boundary: j is left without faces, which
            // the edit layer refuses.
            (true, true) => {}
        }
    }
    Candidates { base, quads }
}

/// A candidate's score: (valence variance, std of the diagonal lengths).
/// The variance comes from integer sums, so it is exact up to one rounding
/// and equal for candidates whose valences are the same multiset.
pub(super) fn score(valences: &ValenceSums, lengths: &[f64]) -> (f64, f64) {
    let lm = lengths.iter().sum::<f64>() / lengths.len().max(1) as f64;
    let spread = (lengths.iter().map(|l| (l - lm).powi(2)).sum::<f64>()
        / lengths.len().max(1) as f64)
        .sqrt();
    (valences.variance(), spread)
}

/// Count, sum and sum of squares of a candidate's valences after the edit.
#[derive(Default)]
pub(super) struct ValenceSums {
    pub(super) count: u64,
    pub(super) sum: u64,
    pub(super) sum_of_squares: u64,
}

impl ValenceSums {
    pub(super) fn add(&mut self, valence: usize) {
        let v = valence as u64;
        self.count += 1;
        self.sum += v;
        self.sum_of_squares += v * v;
    }

    /// The population variance, (n Σv² − (Σv)²) / n² (0 for no valences).
    pub(super) fn variance(&self) -> f64 {
        if self.count == 0 {
            return 0.0;
        }
        let n = self.count as f64;
        (self.count * self.sum_of_squares - self.sum * self.sum) as f64 / (n * n)
    }
}

/// Picks the valid candidate with the least valence variance (ties: most
/// uniform diagonal lengths at `position_of`; full ties: the first), or the
/// last rejection.
///
/// Every candidate is scored from its valences after the edit, which need
/// no check ([`KeptFaces`], as [`Membrane::valences_after`]); the
/// candidates are then checked best first and the first valid one is
/// taken. That is the candidate a check of every candidate would pick, for
/// one full check instead of one per candidate in the usual case. Returns
/// the candidate's `bits` (see [`Candidates`]).
pub fn choose(
    m: &Membrane,
    candidates: &Candidates,
    valence: ValenceRange,
    position_of: impl Fn(Entity) -> DVec3,
) -> Result<usize, RemeshError> {
    choose_checked(m, candidates, valence, position_of).map(|(bits, _)| bits)
}

/// Most quadrilaterals of a split or merge (a split has 4, a merge 2), so
/// at most 16 candidates.
pub(super) const MAX_QUADS: usize = 4;

/// [`choose`], also returning the chosen candidate's edit, checked on `m`.
pub(super) fn choose_checked(
    m: &Membrane,
    candidates: &Candidates,
    valence: ValenceRange,
    position_of: impl Fn(Entity) -> DVec3,
) -> Result<(usize, PatchEdit), RemeshError> {
    assert!(
        candidates.quads.len() <= MAX_QUADS,
        "at most {MAX_QUADS} quadrilaterals"
    );
    let base = &candidates.base;
    // The candidates remove the same faces: what each vertex keeps is
    // counted once (`None`: a face to remove is not live).
    let kept = KeptFaces::of(m, &base.remove_faces);
    let mut faces: Vec<[Entity; 3]> =
        Vec::with_capacity(base.add_faces.len() + 2 * candidates.quads.len());
    let mut lengths = [0.0; MAX_QUADS];
    let mut scores: [Option<(f64, f64)>; 1 << MAX_QUADS] = [None; 1 << MAX_QUADS];
    // Without the kept faces (a face to remove is not live) nothing is
    // scored.
    if let Some(kept) = &kept {
        for (bits, score_of) in scores.iter_mut().enumerate().take(candidates.len()) {
            faces.clear();
            faces.extend_from_slice(&base.add_faces);
            candidates.push_quad_faces(bits, &mut faces);
            let mut valences = ValenceSums::default();
            // A boundary vertex counts as its interior equivalent (a fan of
            // half a turn has two neighbours fewer).
            kept.for_each_valence(m, &faces, &base.remove_vertices, |_, v, open| {
                valences.add(v + 2 * usize::from(open))
            });
            for (l, (a, b)) in lengths.iter_mut().zip(candidates.diagonal_edges(bits)) {
                *l = position_of(a).distance(position_of(b));
            }
            *score_of = Some(score(&valences, &lengths[..candidates.quads.len()]));
        }
    }
    // s beats the best so far (candidates taken in index order).
    let better = |s: (f64, f64), best: Option<(f64, f64)>| {
        best.is_none_or(|bs| s.0 < bs.0 - 1e-12 || (s.0 <= bs.0 + 1e-12 && s.1 < bs.1))
    };
    // Bit c: candidate c is not checked yet.
    let mut unchecked: u32 = (1 << candidates.len()) - 1;
    let mut last_error: Option<(usize, EditError)> = None;
    let mut edit = base.clone();
    while unchecked != 0 {
        // The best unchecked candidate; unscored ones (a face to remove is
        // not live) are checked last, only to report their error.
        let mut pick: Option<(Option<(f64, f64)>, usize)> = None;
        for c in (0..candidates.len()).filter(|&c| unchecked & (1 << c) != 0) {
            let replace = match (scores[c], pick) {
                (_, None) => true,
                (Some(s), Some((bs, _))) => better(s, bs),
                (None, Some(_)) => false,
            };
            if replace {
                pick = Some((scores[c], c));
            }
        }
        let (_, c) = pick.expect("unchecked is not empty");
        unchecked &= !(1 << c);
        candidates.write_edit(c, &mut edit);
        match m.validate_patch(&edit, valence, true) {
            Ok(_) => return Ok((c, edit)),
            Err(e) => {
                if last_error.as_ref().is_none_or(|(i, _)| c > *i) {
                    last_error = Some((c, e));
                }
            }
        }
    }
    Err(RemeshError::NoValidOption(
        last_error.map_or(EditError::BrokenFan(Entity::DANGLING), |(_, e)| e),
    ))
}

pub(super) fn position(m: &Membrane, v: Entity) -> DVec3 {
    m.world
        .get::<&Position>(v)
        .map(|p| p.0)
        .unwrap_or(DVec3::NAN)
}

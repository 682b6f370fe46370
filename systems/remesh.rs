//! Free-energy remeshing (SPEC §4): every abnormal edge (outside [l_−, l_+])
//! is processed once per tick, in a seeded random order, until none remain
//! or `max_events_per_tick` is reached (an overflow, counted).
//!
//! Stage: Remesh. Reads: [`VinSegmentation`], [`RemeshParams`],
//! [`ValenceRange`], [`DynamicsParams`] (mobility), [`Seed`], [`Clock`],
//! [`CheckInvariants`]. Writes: [`DensePositions`] and [`DenseLipid`] (patch
//! relaxation, split/merge policies), the mesh entities in [`Membrane`]
//! (splits and merges through the mesh-edit layer), [`AbnormalEdges`] (what
//! is left), [`RemeshStats`], [`RemeshTriggered`].
//!
//! Per edge: pre-relax the patch (edge ends and their 1-ring move, the
//! 2-ring is fixed) under V_in plus Lévy kicks, extending (split) or
//! compressing (merge) the edge. Success → split/merge with the best valid
//! triangulation, then relax the new vertex's 1-ring into the normal range;
//! no valid triangulation, cancel or failure → restore and push the edge
//! back into range by moving its two ends. An edge still abnormal at the end
//! of the tick is counted as unresolved (never dropped silently). In the
//! fluid model every move is tangential, and with direct edits
//! ([`remembrane_core::params::FluidEdits::Direct`]) the pre-relaxation is skipped.
//!
//! On an open membrane with `Pinned` or `Roller` loops it also reads and
//! writes [`PinnedVertices`] (the held vertices, by entity): held vertices
//! are never moveable in a relaxation or push-back, a merge with both ends
//! held (or one held and the other on a boundary) is refused as impossible,
//! one with a held end keeps that end where it is, a split of a boundary
//! edge between two held vertices holds the new vertex at the split point,
//! and the dense slots of the held vertices are re-read after the edits.

use glam::DVec3;
use hecs::Entity;
use rand::{RngExt, SeedableRng};
use remembrane_core::energy::vin::VinSegmentation;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::shared_resources::PinnedVertices;
use remembrane_core::engine::shared_resources::{AbnormalEdges, RemeshTriggered};
use remembrane_core::engine::simulation::{
    CheckInvariants, Clock, DenseLipid, DensePositions, Seed, SimError,
};
use remembrane_core::mesh::ValenceRange;
use remembrane_core::mesh::components::Position;
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::params::{DynamicsParams, HeldDirections, RemeshParams};
use remembrane_core::remesh::relax::{
    Goal, KickTable, Patch, RelaxOutcome, RelaxSettings, relax, rings,
};
use remembrane_core::remesh::{EdgeOp, RemeshStats};
use remembrane_core::util::rng::stream_seed;
use std::collections::HashSet;

/// Stream id of the remeshing randomness (edge order, kicks).
const REMESH_STREAM: u64 = 0x7265_6d65_7368_0001;

/// Stream id of the pre-sampled Lévy kick table.
const KICK_TABLE_STREAM: u64 = 0x7265_6d65_7368_0002;

/// The remesh system. Holds the run's table of pre-sampled Lévy kicks
/// (drawn from the scene seed on the first remesh).
#[derive(Default)]
pub struct Remesh {
    kicks: Option<KickTable>,
}

/// What every relaxation of the remesh steps below uses: V_in's segments,
/// the as-run relaxation settings, the run's Lévy-kick table and the
/// tick's random stream.
struct Relaxing<'a, R> {
    seg: &'a remembrane_core::energy::vin::Segmentation,
    settings: &'a RelaxSettings,
    kicks: &'a KickTable,
    rng: &'a mut R,
}

/// What the remesh steps below work on: borrowed resources.
struct State<'a> {
    membrane: &'a mut Membrane,
    positions: &'a mut Vec<DVec3>,
    lipid: &'a mut Vec<f64>,
    remesh_stats: &'a mut RemeshStats,
    remesh: RemeshParams,
    valence: ValenceRange,
    iteration: u64,
    check_invariants: bool,
    /// The fluid model: relaxations move vertices only tangentially.
    tangential: bool,
    /// The fluid model's direct edits: no pre-relaxation.
    direct: bool,
    /// The held vertices of an open membrane's pinned and roller loops.
    pinned: Option<&'a mut PinnedVertices>,
}

impl System for Remesh {
    type Data<'a> = (
        (
            Res<'a, VinSegmentation>,
            Res<'a, RemeshParams>,
            Res<'a, ValenceRange>,
            Res<'a, DynamicsParams>,
            Res<'a, Seed>,
            Res<'a, Clock>,
            Res<'a, CheckInvariants>,
            Option<Res<'a, remembrane_core::params::MembraneModel>>,
        ),
        (
            ResMut<'a, Membrane>,
            ResMut<'a, DensePositions>,
            ResMut<'a, DenseLipid>,
            ResMut<'a, AbnormalEdges>,
            ResMut<'a, RemeshStats>,
            ResMut<'a, RemeshTriggered>,
            Option<ResMut<'a, PinnedVertices>>,
        ),
    );

    fn name(&self) -> &str {
        "remesh"
    }

    fn run(
        &mut self,
        (
            (seg, params, valence, dynamics, seed, clock, check, model),
            (
                mut membrane,
                mut positions,
                mut lipid,
                mut abnormal,
                mut stats,
                mut triggered,
                mut pinned,
            ),
        ): Self::Data<'_>,
    ) -> Result<(), SimError> {
        triggered.0 = !abnormal.0.is_empty();
        if !triggered.0 {
            return Ok(());
        }
        let seg = seg.0.clone();
        let p = *params;
        let settings = RelaxSettings {
            normal: p.normal_range,
            kick_scale: p.kick_scale,
            mobility: dynamics.mobility,
            max_iterations: p.relax_iterations,
        };
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(stream_seed(
            seed.0,
            REMESH_STREAM,
            clock.iteration,
        ));
        let seed = seed.0;
        let kicks = self.kicks.get_or_insert_with(|| {
            KickTable::new(&mut rand::rngs::Xoshiro256PlusPlus::seed_from_u64(
                stream_seed(seed, KICK_TABLE_STREAM, 0),
            ))
        });
        let state = &mut State {
            membrane: &mut membrane,
            positions: &mut positions.0,
            lipid: &mut lipid.0,
            remesh_stats: &mut stats,
            remesh: p,
            valence: *valence,
            iteration: clock.iteration,
            check_invariants: check.0,
            tangential: model.as_ref().is_some_and(|m| m.is_fluid()),
            direct: model.is_some_and(|m| m.direct_edits()),
            pinned: pinned.as_deref_mut(),
        };
        let mut attempted: HashSet<(Entity, Entity)> = HashSet::new();
        let mut events = 0;
        loop {
            let candidates = abnormal_edges(state, &p, &attempted);
            if candidates.is_empty() {
                break;
            }
            if events >= p.max_events_per_tick {
                state.remesh_stats.overflow_ticks += 1;
                break;
            }
            let (edge, op) = candidates[rng.random_range(0..candidates.len())];
            let t = state.membrane.cached_topology();
            let [a, b] = t.edges[edge as usize];
            attempted.insert(ordered(
                t.vertex_entities[a as usize],
                t.vertex_entities[b as usize],
            ));
            events += 1;
            process(
                state,
                edge,
                op,
                &mut Relaxing {
                    seg: &seg,
                    settings: &settings,
                    kicks,
                    rng: &mut rng,
                },
            )?;
        }
        let left: Vec<u32> = abnormal_edges(state, &p, &HashSet::new())
            .into_iter()
            .map(|(e, _)| e)
            .collect();
        if !left.is_empty() && events < p.max_events_per_tick {
            state.remesh_stats.unresolved_ticks += 1;
            state.remesh_stats.unresolved_edges += left.len() as u64;
        }
        abnormal.0 = left;
        reslot_held(state);
        Ok(())
    }
}

/// Re-reads the dense slots of the held vertices after the edits.
fn reslot_held(state: &mut State<'_>) {
    let t = state.membrane.cached_topology();
    if let Some(pinned) = state.pinned.as_deref_mut() {
        pinned.vertices = pinned
            .entities
            .iter()
            .map(|&e| {
                t.vertex_slot(e)
                    .expect("a held vertex is never merged away")
            })
            .collect();
    }
}

/// The index in [`PinnedVertices`] of the vertex at `slot`, if it is held.
fn held_index(state: &State<'_>, slot: u32) -> Option<usize> {
    let pinned = state.pinned.as_deref()?;
    let e = state.membrane.cached_topology().vertex_entities[slot as usize];
    pinned.entities.iter().position(|&x| x == e)
}

/// `slots` without the held vertices (a relaxation never moves them).
fn unheld(state: &State<'_>, mut slots: Vec<u32>) -> Vec<u32> {
    if state.pinned.is_some() {
        slots.retain(|&s| held_index(state, s).is_none());
    }
    slots
}

/// Whether a merge of edge slot `edge` (ends at slots a, b) keeps every
/// held vertex where it is: not both ends held, and a held end survives in
/// place, which the mesh layer does on an edge from the boundary inward.
/// With direct edits (no pre-relaxation) the held survivor must also leave
/// no edge longer than `longer_than` to the other end's neighbours: else
/// the next tick splits that edge, V_in draws the new vertex back to the
/// rim, and merge and split alternate without end (measured on the
/// generated disc's six rim corners: 408 splits and 408 merges in 1600
/// iterations, every one at a corner).
fn merge_keeps_held(state: &State<'_>, edge: u32, [a, b]: [u32; 2]) -> bool {
    let t = state.membrane.cached_topology();
    let (survivor, other) = match (held_index(state, a), held_index(state, b)) {
        (None, None) => return true,
        (Some(_), Some(_)) => return false,
        (Some(_), None) => (a, b),
        (None, Some(_)) => (b, a),
    };
    let kept = state.positions[survivor as usize];
    let too_long = state.direct
        && t.neighbours(other as usize)
            .iter()
            .any(|&w| state.positions[w as usize].distance(kept) > state.remesh.longer_than);
    let survivor = t.vertex_entities[survivor as usize];
    !too_long
        && !t.is_boundary_vertex(other as usize)
        && remembrane_core::remesh::merge_region(state.membrane, edge)
            .is_ok_and(|(r, _)| r.i[0] == survivor)
}

/// The condition a split of edge slot `edge` (ends a, b) passes to its new
/// vertex: a boundary edge between two held vertices (one loop).
fn split_inherits(
    state: &State<'_>,
    edge: u32,
    op: EdgeOp,
    [a, b]: [u32; 2],
) -> Option<HeldDirections> {
    let pinned = state.pinned.as_deref()?;
    let t = state.membrane.cached_topology();
    if op != EdgeOp::Split || !t.is_boundary_edge(edge as usize) {
        return None;
    }
    held_index(state, b)?;
    Some(pinned.held[held_index(state, a)?])
}

fn ordered(a: Entity, b: Entity) -> (Entity, Entity) {
    if a.to_bits() < b.to_bits() {
        (a, b)
    } else {
        (b, a)
    }
}

/// Abnormal edges not yet attempted this tick, with the operation each
/// calls for.
fn abnormal_edges(
    state: &State<'_>,
    p: &RemeshParams,
    attempted: &HashSet<(Entity, Entity)>,
) -> Vec<(u32, EdgeOp)> {
    let t = state.membrane.cached_topology();
    let pos = &state.positions;
    let mut out = Vec::new();
    for (e, &[a, b]) in t.edges.iter().enumerate() {
        let l = pos[a as usize].distance(pos[b as usize]);
        let Some(op) = EdgeOp::for_length(l, p.shorter_than, p.longer_than) else {
            continue;
        };
        if attempted.contains(&ordered(
            t.vertex_entities[a as usize],
            t.vertex_entities[b as usize],
        )) {
            continue;
        }
        out.push((e as u32, op));
    }
    out
}

/// With `check_invariants` (debug builds, every test, and
/// `--check-invariants`), the full invariant check after each topology edit.
fn debug_check_invariants(state: &State<'_>) -> Result<(), SimError> {
    if state.check_invariants {
        let t = state.membrane.cached_topology();
        if let Err(e) =
            remembrane_core::mesh::check_mesh(state.positions, &t.faces, Some(state.valence))
        {
            return Err(SimError::Output(format!(
                "mesh invariant broken after a remesh edit at iteration {}: {e}",
                state.iteration + 1
            )));
        }
    }
    Ok(())
}

/// Writes a patch's moveable positions back (dense mirror and world).
fn write_back(state: &mut State<'_>, patch: &Patch, slots: &[u32]) {
    let t = state.membrane.cached_topology();
    let entities: Vec<Entity> = slots[..patch.moveable]
        .iter()
        .map(|&s| t.vertex_entities[s as usize])
        .collect();
    for (k, e) in entities.into_iter().enumerate() {
        let p = patch.positions[k];
        state.positions[slots[k] as usize] = p;
        if let Ok(mut pos) = state.membrane.world.get::<&mut Position>(e) {
            pos.0 = p;
        }
    }
}

/// Re-gathers the dense mirror after a topology change.
fn refresh(state: &mut State<'_>) -> Result<(), SimError> {
    state.membrane.topology()?;
    state.membrane.gather_positions(state.positions);
    state.membrane.gather_lipid(state.lipid);
    Ok(())
}

fn process(
    state: &mut State<'_>,
    edge: u32,
    op: EdgeOp,
    tools: &mut Relaxing<'_, impl RngExt>,
) -> Result<(), SimError> {
    let p = state.remesh;
    let valence = state.valence;
    let t = state.membrane.cached_topology();
    let [a, b] = t.edges[edge as usize];
    let (ea, eb) = (t.vertex_entities[a as usize], t.vertex_entities[b as usize]);
    let feasible = op.check_feasible(state.membrane, edge, valence).is_ok()
        && (op != EdgeOp::Merge || merge_keeps_held(state, edge, [a, b]));
    if !feasible {
        state.remesh_stats.counts_mut(op).impossible += 1;
        push_back(state, a, b, tools);
        return Ok(());
    }
    let inherit = split_inherits(state, edge, op, [a, b]);
    if state.direct {
        return direct_edit(state, edge, op, inherit, tools);
    }
    // Pre-relaxation with the 1-ring moveable; under tension the fixed 2-ring
    // may leave no room, so a failure is retried with the 2-ring moveable
    // (the reference code's fallback after repeated failures), and then
    // with only the edge's two ends moving: in a cluster of abnormal edges
    // the larger patches contain the neighbours' abnormal edges, which must
    // all be normal at once, and never succeed (measured: a stiffened RBC
    // stuck for good with 8 long edges until this fallback). Last, the
    // 1-ring with the paper's normal range (see `ladder`).
    let goal = match op {
        EdgeOp::Split => Goal::Extend(p.split_done),
        EdgeOp::Merge => Goal::Compress(p.merge_done),
    };
    let (outcome, patch, slots, iterations) = relax_around_edge(
        state,
        [a, b],
        &ladder(&[1, 2, 0], tools.settings, &p),
        goal,
        tools,
    );
    let spent = &mut state.remesh_stats.relax_iterations;
    *match outcome {
        RelaxOutcome::Success => &mut spent.pre_success,
        RelaxOutcome::Cancel => &mut spent.pre_cancel,
        RelaxOutcome::Failure => &mut spent.pre_failure,
    } += iterations;
    match outcome {
        RelaxOutcome::Cancel | RelaxOutcome::Failure => {
            let counts = state.remesh_stats.counts_mut(op);
            if outcome == RelaxOutcome::Cancel {
                counts.cancel += 1;
            } else {
                counts.failure += 1;
            }
            // The patch was relaxed on a copy: the world is as before. Push
            // the edge back into range by moving only its two ends.
            push_back(state, a, b, tools);
            return Ok(());
        }
        RelaxOutcome::Success => {}
    }
    let saved: Vec<glam::DVec3> = slots[..patch.moveable]
        .iter()
        .map(|&s| state.positions[s as usize])
        .collect();
    write_back(state, &patch, &slots);
    // The edge's slot is unchanged until the topology changes.
    let result = op.apply(state.membrane, edge, valence);
    match result {
        Ok(out) => finish_edit(state, op, &out, inherit, tools)?,
        Err(_) => {
            state.remesh_stats.counts_mut(op).impossible += 1;
            // Restore the pre-relaxation positions, then push the edge back.
            let restore = Patch {
                positions: saved,
                moveable: patch.moveable,
                ..Default::default()
            };
            write_back(state, &restore, &slots);
            push_back_entities(state, [ea, eb], tools);
        }
    }
    Ok(())
}

/// After a successful edit: counts and records the event, re-gathers the
/// dense mirror, holds the new vertex of a split held boundary edge
/// (`inherit`) at the split point, checks the invariants (when asked) and
/// post-relaxes the new vertex's 1-ring.
fn finish_edit(
    state: &mut State<'_>,
    op: EdgeOp,
    out: &remembrane_core::remesh::RemeshOutcome,
    inherit: Option<HeldDirections>,
    tools: &mut Relaxing<'_, impl RngExt>,
) -> Result<(), SimError> {
    state.remesh_stats.counts_mut(op).success += 1;
    state
        .remesh_stats
        .events
        .push(remembrane_core::remesh::RemeshEvent {
            iteration: state.iteration,
            op,
            position: out.position.to_array(),
        });
    refresh(state)?;
    if let (Some(held), Some(pinned)) = (inherit, state.pinned.as_deref_mut()) {
        pinned.entities.push(out.vertex);
        pinned.positions.push(out.position);
        pinned.held.push(held);
    }
    debug_check_invariants(state)?;
    post_relax(state, out.vertex, tools);
    Ok(())
}

/// Post-relaxation: the new (or surviving) vertex of an edit and its 1-ring
/// relax into the normal range (kept unless the relaxation fails).
fn post_relax(state: &mut State<'_>, vertex: Entity, tools: &mut Relaxing<'_, impl RngExt>) {
    let t = state.membrane.cached_topology();
    let v = t.vertex_slot(vertex).expect("the edit keeps this vertex");
    let mut moveable = vec![v];
    moveable.extend_from_slice(t.neighbours(v as usize));
    let moveable = unheld(state, moveable);
    if moveable.is_empty() {
        return;
    }
    let t = state.membrane.cached_topology();
    let (mut post, post_slots) = Patch::around(
        state.membrane.cached_topology(),
        state.positions,
        &moveable,
        None,
    );
    if state.tangential {
        post.freeze_normals(t, state.positions, &post_slots);
    }
    let relaxed = relax(
        &mut post,
        Goal::Normalize,
        tools.seg,
        tools.settings,
        tools.kicks,
        tools.rng,
    );
    state.remesh_stats.relax_iterations.post += u64::from(relaxed.iterations);
    if relaxed.outcome != RelaxOutcome::Failure {
        write_back(state, &post, &post_slots);
    }
}

/// The fluid model's direct edit ([`remembrane_core::params::FluidEdits::Direct`]):
/// the split or merge is applied at once (the new vertex at the edge's
/// midpoint), then its 1-ring relaxes tangentially into the normal range.
/// An edit the mesh cannot take (valence, a fold) is counted as impossible
/// and the edge pushed back into range, as in the paper's event.
fn direct_edit(
    state: &mut State<'_>,
    edge: u32,
    op: EdgeOp,
    inherit: Option<HeldDirections>,
    tools: &mut Relaxing<'_, impl RngExt>,
) -> Result<(), SimError> {
    let t = state.membrane.cached_topology();
    let [a, b] = t.edges[edge as usize];
    let (ea, eb) = (t.vertex_entities[a as usize], t.vertex_entities[b as usize]);
    match op.apply(state.membrane, edge, state.valence) {
        Ok(out) => finish_edit(state, op, &out, inherit, tools)?,
        Err(_) => {
            state.remesh_stats.counts_mut(op).impossible += 1;
            push_back_entities(state, [ea, eb], tools);
        }
    }
    Ok(())
}

/// The relaxation attempts of a ladder: the rings of `depths` moveable in
/// turn (0: the two ends only) with the as-run normal range, then, if the
/// normal range is narrower than the triggers, the 1-ring once more with the
/// paper's normal range [l_−, l_+]. Under tension every edge of a region
/// can sit just above the as-run 1.2 (measured: the soft RBC near iteration
/// 10^4, its patch edges at 1.20-1.25), where no patch relaxes into
/// [0.8, 1.2]; the paper's range still leaves no abnormal edge behind.
fn ladder(
    depths: &[usize],
    settings: &RelaxSettings,
    p: &RemeshParams,
) -> Vec<(usize, RelaxSettings)> {
    let mut attempts: Vec<(usize, RelaxSettings)> =
        depths.iter().map(|&depth| (depth, *settings)).collect();
    let triggers = (p.shorter_than, p.longer_than);
    if triggers.0 < settings.normal.0 || triggers.1 > settings.normal.1 {
        attempts.push((
            1,
            RelaxSettings {
                normal: triggers,
                ..*settings
            },
        ));
    }
    attempts
}

/// Relaxes the patch around edge (a, b) toward `goal` with each attempt of
/// `attempts` (moveable ring depth, settings) in turn until one does not
/// fail. Returns the last attempt's outcome, patch and slots, and the
/// iterations of all attempts.
fn relax_around_edge(
    state: &State<'_>,
    [a, b]: [u32; 2],
    attempts: &[(usize, RelaxSettings)],
    goal: Goal,
    tools: &mut Relaxing<'_, impl RngExt>,
) -> (RelaxOutcome, Patch, Vec<u32>, u64) {
    let t = state.membrane.cached_topology();
    let mut iterations = 0;
    let mut last = (RelaxOutcome::Failure, Patch::default(), Vec::new());
    for (depth, settings) in attempts {
        let moveable = unheld(state, rings(t, &[a, b], *depth));
        if moveable.is_empty() {
            continue;
        }
        let (mut patch, slots) = Patch::around(t, state.positions, &moveable, Some([a, b]));
        if state.tangential {
            patch.freeze_normals(t, state.positions, &slots);
        }
        let relaxed = relax(
            &mut patch,
            goal,
            tools.seg,
            settings,
            tools.kicks,
            tools.rng,
        );
        iterations += u64::from(relaxed.iterations);
        last = (relaxed.outcome, patch, slots);
        if relaxed.outcome != RelaxOutcome::Failure {
            break;
        }
    }
    (last.0, last.1, last.2, iterations)
}

/// [`push_back`] of the edge between the vertices `ends` (entities, kept
/// through an edit that moved their slots).
fn push_back_entities(
    state: &mut State<'_>,
    ends: [hecs::Entity; 2],
    tools: &mut Relaxing<'_, impl RngExt>,
) {
    let t = state.membrane.cached_topology();
    let [a, b] = ends.map(|e| t.vertex_slot(e).expect("live"));
    push_back(state, a, b, tools);
}

/// Pushes the edge back into range: moves only its two ends (their
/// neighbours fixed) until every incident edge is in the normal range; if
/// that fails (a crowded neighbourhood), retries with the ends' 1-ring
/// moveable too (the reference's wider-ring fallback), and then with the
/// paper's normal range (see `ladder`). Keeps the result unless all fail.
fn push_back(state: &mut State<'_>, a: u32, b: u32, tools: &mut Relaxing<'_, impl RngExt>) {
    let p = state.remesh;
    let (outcome, patch, slots, iterations) = relax_around_edge(
        state,
        [a, b],
        &ladder(&[0, 1], tools.settings, &p),
        Goal::Normalize,
        tools,
    );
    state.remesh_stats.relax_iterations.push_back += iterations;
    if outcome != RelaxOutcome::Failure {
        write_back(state, &patch, &slots);
    }
}

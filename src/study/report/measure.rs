//! Reading a case's run directory and measuring it against its reference
//! (static closed forms, the axisymmetric solver, DJP, a peer engine).

use super::*;

/// Why a case could not be read or measured against its reference.
#[derive(Debug, thiserror::Error)]
pub enum MeasureError {
    /// The case was run with other settings than the study's.
    #[error("not run with these settings")]
    NotRun,
    /// The run directory's summary or series is unreadable.
    #[error(transparent)]
    Run(#[from] crate::io::run_dir::RunDirError),
    /// The final mesh is unreadable.
    #[error(transparent)]
    Mesh(#[from] crate::mesh::io::MeshIoError),
    /// The axisymmetric reference could not be solved.
    #[error("reference at v = {v}: {source}")]
    Reference {
        /// The reduced volume.
        v: f64,
        /// Why.
        source: crate::analysis::axisymmetric::SolveError,
    },
    /// The scene has no continuum adhered vesicle.
    #[error(transparent)]
    Substrate(#[from] crate::scene::NoSubstrate),
    /// The adhered vesicle could not be measured.
    #[error(transparent)]
    Adhesion(#[from] crate::analysis::axisymmetric::contact_fit::ContactFitError),
    /// A peer's result cannot be measured (the reason says why).
    #[error("{0}")]
    Peer(&'static str),
    /// The summary's `adhesion` section does not read as an adhesion
    /// report.
    #[error("summary.json: section `adhesion`: {0}")]
    Section(#[from] serde_json::Error),
}

/// A run directory's outputs needed here.
pub(super) struct RunData {
    pub(super) summary: crate::io::summary::RunSummary,
    /// Every row of series.csv by column name, the first included.
    pub(super) rows: Vec<HashMap<String, f64>>,
    /// The vertex count of the first row.
    pub(super) vertices: f64,
    /// The bending energy of the first row (NaN without a bending term).
    pub(super) initial_bending: f64,
}

pub(super) fn read_run(dir: &Path) -> Result<RunData, MeasureError> {
    let summary = crate::io::summary::RunSummary::read(dir)?;
    let series = crate::io::run_dir::Series::read(dir)?;
    let vertices = series.first("vertices")?;
    let initial_bending = series.first("energy_bending").unwrap_or(f64::NAN);
    let rows = series
        .rows
        .iter()
        .map(|row| {
            series
                .columns
                .iter()
                .cloned()
                .zip(row.iter().copied())
                .collect()
        })
        .collect();
    Ok(RunData {
        summary,
        rows,
        vertices,
        initial_bending,
    })
}

/// The final bending energy in a summary (NaN without a bending term).
pub(super) fn final_bending(summary: &crate::io::summary::RunSummary) -> f64 {
    summary
        .last
        .energies
        .iter()
        .find(|t| t.term == "bending")
        .map_or(f64::NAN, |t| t.energy)
}

pub(super) fn quantity(summary: &crate::io::summary::RunSummary, q: Quantity) -> f64 {
    match q {
        Quantity::ReducedVolume => summary.last.reduced_volume.unwrap_or(f64::NAN),
        Quantity::BendingEnergy => final_bending(summary),
        Quantity::TotalEnergy => summary.last.total_energy,
        Quantity::Area => summary.last.area,
        Quantity::Volume => summary.last.volume.unwrap_or(f64::NAN),
    }
}

pub(super) fn measure(quantity: &str, measured: f64, reference: Value) -> Measurement {
    Measurement {
        quantity: quantity.into(),
        measured,
        reference: reference.value,
        reference_error: reference.error,
        error: ((measured - reference.value) / reference.value).abs(),
    }
}

/// The axisymmetric reference's measurements of a final mesh: the
/// reference is solved at the mesh's reduced volume `v`; R0 = √(A/4π).
pub(super) fn axisymmetric_measurements(
    mesh_path: &Path,
    energy_bending: f64,
    area: f64,
    v: f64,
    kappa: f64,
) -> Result<(Vec<Measurement>, String), MeasureError> {
    let r0 = (area / (4.0 * PI)).sqrt();
    let exact = crate::analysis::axisymmetric::converged(v)
        .map_err(|source| MeasureError::Reference { v, source })?;
    let mesh = crate::mesh::io::read_mesh(mesh_path)?;
    let t = crate::analysis::shape::axial_thickness(&mesh.positions, &mesh.faces);
    let class = crate::analysis::shape::shape_metrics(&mesh.positions, &mesh.faces).class;
    let value = |x: crate::analysis::axisymmetric::Extrapolated| Value {
        value: x.value,
        error: x.error,
    };
    let note = format!(
        "solved at the case's v = {v:.4}; shape: mesh {}, reference {}",
        serde_json::to_value(class)
            .ok()
            .and_then(|c| c.as_str().map(str::to_string))
            .unwrap_or_default(),
        if exact.biconcave {
            "discocyte"
        } else {
            "convex"
        }
    );
    let measurements = vec![
        measure(
            "E_b/8πκ",
            energy_bending / (8.0 * PI * kappa),
            value(exact.energy_over_8pi_kappa),
        ),
        measure("D/R0", t.diameter / r0, value(exact.diameter)),
        measure("t_max/R0", t.max / r0, value(exact.max_thickness)),
        measure("t_centre/R0", t.centre / r0, value(exact.centre_thickness)),
    ];
    Ok((measurements, note))
}

/// Equilibrium tolerance on the bending energy: within this fraction of its
/// final value (the RBC's E_b moves by ±0.4 % between frames at rest).
pub(super) const EQUILIBRIUM_ENERGY_TOLERANCE: f64 = 0.01;
/// Equilibrium tolerance on the reduced volume (absolute).
pub(super) const EQUILIBRIUM_V_TOLERANCE: f64 = 1e-3;

/// When a run reached equilibrium: the first frame from which on every frame
/// has E_b within [`EQUILIBRIUM_ENERGY_TOLERANCE`] and v within
/// [`EQUILIBRIUM_V_TOLERANCE`] of the final frame's, as a sentence with its
/// simulated time and iteration.
pub(super) fn equilibration(rows: &[HashMap<String, f64>]) -> String {
    let get = |r: &HashMap<String, f64>, k: &str| r.get(k).copied().unwrap_or(f64::NAN);
    let Some(last) = rows.last() else {
        return String::new();
    };
    let (e_end, v_end) = (get(last, "energy_bending"), get(last, "reduced_volume"));
    let settled = |r: &HashMap<String, f64>| {
        (get(r, "energy_bending") - e_end).abs() <= EQUILIBRIUM_ENERGY_TOLERANCE * e_end.abs()
            && (get(r, "reduced_volume") - v_end).abs() <= EQUILIBRIUM_V_TOLERANCE
    };
    let first = rows.len() - rows.iter().rev().take_while(|r| settled(r)).count();
    let tolerance = format!(
        "E_b within {} % and v within {EQUILIBRIUM_V_TOLERANCE:e} of their final values",
        EQUILIBRIUM_ENERGY_TOLERANCE * 100.0
    );
    if first + 1 >= rows.len() {
        return format!("not shown at equilibrium: only the last frame has {tolerance}");
    }
    format!(
        "at equilibrium ({tolerance} from then on) from t = {:.4} s, iteration {} (of {} frames, {})",
        get(&rows[first], "time"),
        get(&rows[first], "iteration"),
        rows.len(),
        if first == 0 {
            "already at the first"
        } else {
            "resolution one frame"
        }
    )
}

/// The exact bending energy of a static problem's initial shape (None for
/// other references, or a spheroid problem whose membrane is not one).
pub(super) fn static_reference(reference: Reference, case: &Case) -> Option<Value> {
    let kappa = case.scene.bending_kappa().unwrap_or(f64::NAN);
    match (reference, &case.scene.membrane) {
        (Reference::SphereBending, _) => Some(sphere_bending(kappa)),
        (
            Reference::SpheroidBending,
            crate::scene::MembraneSource::Ellipsoid {
                semi_axes: (a, _, c),
                ..
            },
        ) => Some(spheroid_bending(*a, *c, kappa)),
        _ => None,
    }
}

/// A peer's measurements against the problem's reference.
pub(super) fn peer_measurements(
    reference: Reference,
    case: &Case,
    output: &PeerOutput,
) -> Result<(Vec<Measurement>, String), MeasureError> {
    let kappa = case.scene.bending_kappa().unwrap_or(f64::NAN);
    match reference {
        Reference::SphereBending | Reference::SpheroidBending => {
            let exact =
                static_reference(reference, case).ok_or(MeasureError::Peer("not an ellipsoid"))?;
            Ok((
                vec![measure("E_b", output.energy_bending, exact)],
                String::new(),
            ))
        }
        Reference::Axisymmetric => {
            let mesh = output
                .mesh
                .as_ref()
                .ok_or(MeasureError::Peer("the peer wrote no final mesh"))?;
            axisymmetric_measurements(
                mesh,
                output.energy_bending,
                output.area.unwrap_or(f64::NAN),
                output.reduced_volume.unwrap_or(f64::NAN),
                kappa,
            )
        }
        Reference::FinestRung(_) => Err(MeasureError::Peer(
            "a time-step problem has no peer version",
        )),
        Reference::Tether => Err(MeasureError::Peer("the tether problem has no peer version")),
        Reference::Adhesion => Err(MeasureError::Peer(
            "the adhesion problem has no peer version",
        )),
    }
}

/// The tether's radius and force over the second half of the frames
/// (medians) against Derényi-Jülicher-Prost, r0 = √(κ/2σ) and
/// f0 = 2π√(2σκ).
pub(super) fn tether_measurements(
    scene: &crate::scene::Scene,
    d: &RunData,
) -> (Vec<Measurement>, String) {
    let kappa = scene.bending_kappa().unwrap_or(f64::NAN);
    let sigma = scene
        .energy
        .iter()
        .find_map(|t| match t {
            crate::scene::EnergyTerm::Tension(p) => Some(p.sigma),
            _ => None,
        })
        .unwrap_or(f64::NAN);
    let r0 = (kappa / (2.0 * sigma)).sqrt();
    let f0 = 2.0 * std::f64::consts::PI * (2.0 * sigma * kappa).sqrt();
    let late = &d.rows[d.rows.len() / 2..];
    let median = |mut v: Vec<f64>| {
        v.retain(|x| x.is_finite());
        v.sort_by(f64::total_cmp);
        match v.len() {
            0 => f64::NAN,
            n if n % 2 == 1 => v[n / 2],
            n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
        }
    };
    let radius_column = scene
        .tube_radius
        .first()
        .map(|p| format!("radius_{}", p.name))
        .unwrap_or_default();
    let force_columns: Vec<String> = scene
        .control_points
        .iter()
        .filter_map(|c| c.name.as_ref().map(|n| format!("force_{n}")))
        .collect();
    let value = |row: &HashMap<String, f64>, c: &String| row.get(c).copied().unwrap_or(f64::NAN);
    let radius = median(late.iter().map(|r| value(r, &radius_column)).collect());
    let force = median(
        late.iter()
            .map(|r| {
                force_columns.iter().map(|c| value(r, c)).sum::<f64>() / force_columns.len() as f64
            })
            .collect(),
    );
    let exact = |v: f64| Value {
        value: v,
        error: 0.0,
    };
    (
        vec![
            measure("r", radius, exact(r0)),
            measure("f", force, exact(f0)),
        ],
        format!(
            "sigma = {sigma}, r0 = {r0:.4}, f0 = {f0:.4}; medians over {} frames",
            late.len()
        ),
    )
}

/// The adhered vesicle's contact curvature (fitted near the contact line to
/// the continuum family, [`crate::analysis::adhesion`]) against √(2W/κ), its
/// height above the bound membrane and its contact area against the
/// continuum vesicle's at the scene's W. NaN marks the contact curvature
/// and area unmeasured when no member of the family fits (the columns stay
/// in place). The run's own `summary.json` report is used when it has one;
/// a run written without it is measured from its `final.ply`.
pub(super) fn adhesion_measurements(
    scene: &crate::scene::Scene,
    mesh_path: &Path,
    summary: &crate::io::summary::RunSummary,
) -> Result<(Vec<Measurement>, String), MeasureError> {
    let v = summary.last.reduced_volume.unwrap_or(f64::NAN);
    let report = summary.section::<crate::analysis::adhesion::AdhesionReport>(
        crate::analysis::adhesion::ADHESION_SECTION,
    )?;
    let r = match report {
        Some(r) => r,
        None => {
            let mesh = crate::mesh::io::read_mesh(mesh_path)?;
            let positions: Vec<[f64; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
            let (substrate, kappa) = scene.adhesion_substrate()?;
            crate::analysis::adhesion::measure(
                (&substrate, kappa),
                &positions,
                summary.last.area,
                v,
            )?
        }
    };
    let exact = |value: f64| Value { value, error: 0.0 };
    let measurements = vec![
        measure(
            "c_contact",
            r.contact_curvature.unwrap_or(f64::NAN),
            exact(r.contact_condition),
        ),
        measure("height", r.height, exact(r.continuum_height)),
        measure(
            "A_contact",
            r.contact_area.unwrap_or(f64::NAN),
            exact(r.continuum_contact_area),
        ),
    ];
    let error = r
        .contact_curvature_error
        .map_or(String::new(), |e| format!("c_contact ± {e:.1e} (fit); "));
    let note = format!(
        "W R0^2/kappa = {:.3}, v = {v:.4}; {error}{}",
        r.reduced_adhesion, r.fit
    );
    Ok((measurements, note))
}

//! A run's flicker spectrum on disk: `remembrane spectrum RUN_DIR` reads
//! the frames its summary lists ([`RunSummary::read`]), fits them by
//! [`crate::analysis::spectrum`] and writes `spectrum.csv`,
//! `spectrum_fit.json` and `spectrum.png` beside them.

use crate::analysis::spectrum::{
    FitError, Spectrum, discrete_mode_stiffness, fit_against, model_power, power_by_l, project,
};
use crate::io::plot::{Series, line_chart};
use crate::io::summary::RunSummary;
use glam::DVec3;
use std::path::PathBuf;

/// Options of `remembrane spectrum`.
#[derive(Clone, Debug, PartialEq)]
pub struct SpectrumOptions {
    /// Frames before this simulated time are discarded (s).
    pub equilibration: f64,
    /// Lowest and highest l fitted.
    pub l_min: usize,
    /// See `l_min`.
    pub l_max: usize,
    /// Blocks for the error bars.
    pub blocks: usize,
    /// k_BT (Ē).
    pub kbt: f64,
    /// The input κ (Ē), drawn for comparison if given.
    pub kappa_input: Option<f64>,
    /// Fit against the discrete bending energy's own stiffness against each
    /// mode, measured on the last frame's mesh
    /// ([`discrete_mode_stiffness`]), instead of the continuum's.
    pub discrete: bool,
}

/// Why a run's spectrum could not be analysed or written.
#[derive(Debug, thiserror::Error)]
pub enum SpectrumError {
    /// The run's summary is unreadable.
    #[error(transparent)]
    Summary(#[from] crate::io::run_dir::RunDirError),
    /// A frame file is unreadable or not a triangle mesh.
    #[error("{}: cannot read frame: {reason}", path.display())]
    Frame {
        /// The frame file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// The frames could not be fitted.
    #[error("{}: {source}", dir.display())]
    Fit {
        /// The run directory.
        dir: PathBuf,
        /// Why.
        source: FitError,
    },
    /// An output file could not be written.
    #[error("{}: cannot write: {source}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The fit could not be serialized.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
}

/// Reads a frame file (VTK PolyData) as positions and triangles.
pub fn read_frame(path: &std::path::Path) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), SpectrumError> {
    use vtkio::model::{DataSet, VertexNumbers};
    let fail = |e: &dyn std::fmt::Display| SpectrumError::Frame {
        path: path.to_owned(),
        reason: e.to_string(),
    };
    let vtk = vtkio::Vtk::import(path).map_err(|e| fail(&e))?;
    let DataSet::PolyData { pieces, .. } = vtk.data else {
        return Err(fail(&"not PolyData"));
    };
    let piece = pieces
        .first()
        .ok_or_else(|| fail(&"no piece"))?
        .load_piece_data(None)
        .map_err(|e| fail(&e))?;
    let points: Vec<f64> = piece.points.cast_into().ok_or_else(|| fail(&"no points"))?;
    let positions = points
        .chunks_exact(3)
        .map(|p| DVec3::new(p[0], p[1], p[2]))
        .collect();
    let Some(VertexNumbers::XML { connectivity, .. }) = &piece.polys else {
        return Err(fail(&"no triangles"));
    };
    let faces = connectivity
        .chunks_exact(3)
        .map(|f| [f[0] as u32, f[1] as u32, f[2] as u32])
        .collect();
    Ok((positions, faces))
}

/// Analyses the frames of the run in `dir` (its `summary.json` lists them
/// with their times) and writes `spectrum.csv`, `spectrum_fit.json` and
/// `spectrum.png` there.
pub fn analyse_run(
    dir: &std::path::Path,
    options: &SpectrumOptions,
) -> Result<Spectrum, SpectrumError> {
    let summary = RunSummary::read(dir)?;
    let mut powers = Vec::new();
    let mut last_mesh = None;
    for f in &summary.frames {
        // Frames before the equilibration time are skipped.
        if f.time.is_nan() || f.time < options.equilibration {
            continue;
        }
        let (positions, faces) = read_frame(&dir.join(&f.file))?;
        let shape = project(&positions, &faces, options.l_max);
        powers.push((shape.mean_radius, power_by_l(&shape.modes, options.l_max)));
        last_mesh = Some((positions, faces));
    }
    let stiffness: Vec<f64> = match (&last_mesh, options.discrete) {
        (Some((positions, faces)), true) => (0..=options.l_max)
            .map(|l| {
                if l < options.l_min.max(2) {
                    1.0
                } else {
                    discrete_mode_stiffness(positions, faces, l)
                }
            })
            .collect(),
        _ => Vec::new(),
    };
    let spectrum = fit_against(
        &powers,
        options.blocks,
        options.l_min,
        options.l_max,
        options.kbt,
        &stiffness,
    )
    .map_err(|source| SpectrumError::Fit {
        dir: dir.to_owned(),
        source,
    })?;
    write_outputs(dir, &spectrum, options)?;
    Ok(spectrum)
}

fn write_outputs(
    dir: &std::path::Path,
    s: &Spectrum,
    options: &SpectrumOptions,
) -> Result<(), SpectrumError> {
    let r = s.mean_radius;
    let mut csv = String::from("l,power,power_error,fit,input_kappa\n");
    for l in s.l_min..=s.l_max {
        let input = options.kappa_input.map_or(f64::NAN, |k| {
            model_power(l, s.kbt, k, s.sigma, r, s.stiffness_of(l))
        });
        csv += &format!(
            "{l},{:e},{:e},{:e},{:e}\n",
            s.power[l],
            s.power_error[l],
            model_power(l, s.kbt, s.kappa, s.sigma, r, s.stiffness_of(l)),
            input
        );
    }
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.join(name);
        crate::atomic_write(&path, bytes).map_err(|source| SpectrumError::Write { path, source })
    };
    write("spectrum.csv", csv.as_bytes())?;
    let json = serde_json::to_string_pretty(s)?;
    write("spectrum_fit.json", json.as_bytes())?;
    let ls: Vec<usize> = (s.l_min..=s.l_max).collect();
    let log = |v: f64| v.log10();
    let measured = Series {
        name: "measured".into(),
        points: ls.iter().map(|&l| (l as f64, log(s.power[l]))).collect(),
        errors: ls
            .iter()
            .map(|&l| s.power_error[l] / (s.power[l] * std::f64::consts::LN_10))
            .collect(),
        markers: true,
        color: 0,
        ..Default::default()
    };
    let curve = |name: String, kappa: f64, color: usize| Series {
        name,
        points: ls
            .iter()
            .map(|&l| {
                let p = model_power(l, s.kbt, kappa, s.sigma, r, s.stiffness_of(l));
                (l as f64, log(p))
            })
            .collect(),
        lines: true,
        color,
        ..Default::default()
    };
    let mut series = vec![measured, curve(format!("fit k={:.3}", s.kappa), s.kappa, 1)];
    if let Some(k) = options.kappa_input {
        series.push(curve(format!("input k={k:.3}"), k, 2));
    }
    let png = line_chart("flicker spectrum", "l", "log10 <|u_lm|^2>", &series);
    write("spectrum.png", &png)
}

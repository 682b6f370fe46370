//! From a scene to a simulation: its initial mesh (generated, imported or
//! a saved state), and the built-in and declared plugins assembled into
//! one build.

use super::*;

impl Scene {
    /// The initial mesh (jittered with the scene seed if requested).
    pub fn initial_mesh(&self, scene_path: &Path) -> Result<SurfaceMesh, SceneError> {
        Ok(self.initial_state(scene_path)?.0)
    }

    /// The initial mesh and, when starting from a saved state that has
    /// them, the lipid densities.
    pub fn initial_state(
        &self,
        scene_path: &Path,
    ) -> Result<(SurfaceMesh, Option<Vec<f64>>), SceneError> {
        let mut lipid = None;
        let mut mesh = match &self.membrane {
            MembraneSource::Icosphere {
                level,
                mean_edge_length,
                jitter,
            } => {
                let mut m = icosphere(*level, *mean_edge_length);
                if *jitter > 0.0 {
                    m.jitter(*jitter, self.seed);
                }
                m
            }
            MembraneSource::Ellipsoid {
                level,
                semi_axes: (a, b, c),
                jitter,
                tilt,
            } => crate::mesh::ellipsoid_tilted(*level, [*a, *b, *c], *jitter, *tilt, self.seed),
            MembraneSource::Capsule {
                radius,
                length,
                mean_edge_length,
            } => crate::mesh::capsule(*radius, *length, *mean_edge_length),
            MembraneSource::Axisymmetric {
                branch,
                reduced_volume,
                area,
                mean_edge_length,
            } => axisymmetric_mesh(
                scene_path,
                *branch,
                *reduced_volume,
                *area,
                *mean_edge_length,
            )?,
            MembraneSource::Disc {
                radius,
                mean_edge_length,
            } => crate::mesh::disc(*radius, *mean_edge_length),
            MembraneSource::SphericalCap {
                sphere_radius,
                opening_angle,
                mean_edge_length,
            } => crate::mesh::spherical_cap(*sphere_radius, *opening_angle, *mean_edge_length),
            MembraneSource::DockedPair { level } => docked_pair(*level),
            MembraneSource::File { path, scale } => {
                let base = scene_path.parent().unwrap_or(Path::new("."));
                let mut m = read_mesh(&base.join(path)).map_err(|source| SceneError::MeshFile {
                    path: scene_path.to_owned(),
                    source,
                })?;
                m.scale(*scale);
                m
            }
            MembraneSource::State { path, refine } => {
                let (mesh, saved) = state_mesh(scene_path, path, *refine)?;
                lipid = saved;
                mesh
            }
            MembraneSource::Mesh { positions, faces } => SurfaceMesh {
                positions: positions.clone(),
                faces: faces.clone(),
            },
        };
        // Generated meshes are valid by construction; this also applies the
        // scene's valence limits to files and docked pairs.
        let report =
            check_mesh(&mesh.positions, &mesh.faces, Some(self.valence)).map_err(|source| {
                let field = if matches!(source, MeshError::ValenceOutOfRange { .. }) {
                    "valence"
                } else {
                    "membrane"
                };
                SceneError::Mesh {
                    path: scene_path.to_owned(),
                    field,
                    source,
                }
            })?;
        if report.boundary_loops > 0 {
            self.refuse_on_open_mesh(scene_path, report.boundary_loops)?;
        }
        mesh.positions.shrink_to_fit();
        Ok((mesh, lipid))
    }

    /// Builds the world and the systems this scene declares, sealed.
    pub fn build(&self, scene_path: &Path) -> Result<Simulation, SceneError> {
        self.builder(scene_path)?
            .build()
            .map_err(|e| SceneError::Invalid {
                path: scene_path.to_owned(),
                field: "systems".into(),
                reason: e.to_string(),
            })
    }

    /// The builder of [`Scene::build`], holding every plugin this scene
    /// declares (and frame output), for a caller that adds its own
    /// plugins or force terms before [`SimBuilder::build`].
    pub fn builder(&self, scene_path: &Path) -> Result<SimBuilder, SceneError> {
        if let Some(reason) = self.ladder_reason("a single build (`energy`, Python)") {
            return Err(SceneError::Invalid {
                path: scene_path.to_owned(),
                field: "resolution".into(),
                reason,
            });
        }
        let (mesh, saved_lipid) = self.initial_state(scene_path)?;
        let h = self.resolution.edge_length(mesh.mean_edge_length());
        if h != 1.0 {
            return self
                .at_resolution(h)
                .builder_from(mesh, saved_lipid, scene_path);
        }
        self.builder_from(mesh, saved_lipid, scene_path)
    }

    /// Builds from the initial mesh (and saved lipid density), with this
    /// scene's parameters as they stand (already at its resolution).
    fn builder_from(
        &self,
        mesh: SurfaceMesh,
        saved_lipid: Option<Vec<f64>>,
        scene_path: &Path,
    ) -> Result<SimBuilder, SceneError> {
        let lipid_total = match (&saved_lipid, self.lipid_density) {
            (Some(rho), true) => rho.iter().sum(),
            _ => mesh.vertex_count() as f64,
        };
        let initial = InitialState {
            vertices: mesh.vertex_count(),
            lipid_total,
            area: total_area(&mesh.positions, &mesh.faces),
            volume: enclosed_volume(&mesh.positions, &mesh.faces, mesh.positions[0]),
        };
        let invalid = |reason: String| SceneError::Invalid {
            path: scene_path.to_owned(),
            field: "membrane".into(),
            reason,
        };
        let mut membrane =
            Membrane::from_mesh(&mesh, self.lipid_density).map_err(|e| invalid(e.to_string()))?;
        if let (Some(rho), true) = (&saved_lipid, self.lipid_density) {
            membrane.topology().map_err(|e| invalid(e.to_string()))?;
            membrane.scatter_lipid(rho);
        }
        use crate::scene::plugins;
        let mut builder = SimBuilder::new(membrane, initial);
        let build_err = |e: BuildError| invalid(e.to_string());
        let invalid_at = |field: String, e: BuildError| SceneError::Invalid {
            path: scene_path.to_owned(),
            field,
            reason: e.to_string(),
        };
        builder
            .add_plugin(plugins::core(plugins::CoreSettings {
                dynamics: self.dynamics_resolved(),
                seed: self.seed,
                penalty_smoothing: self.penalty_smoothing,
                remesh: self.remesh,
            }))
            .map_err(build_err)?;
        if let crate::params::MembraneModel::Fluid(f) = self.model {
            builder
                .add_plugin(plugins::fluid(f))
                .map_err(|e| invalid_at("model".into(), e))?;
        }
        if let Some(c) = self.constraints {
            builder
                .add_plugin(plugins::constraints(c))
                .map_err(|e| invalid_at("constraints".into(), e))?;
        }
        builder
            .add_plugin(plugins::recorders(
                self.tube_radius.clone(),
                self.control_points
                    .iter()
                    .enumerate()
                    .filter_map(|(i, cp)| Some((cp.name.clone()?, i as u32)))
                    .collect(),
                self.energy
                    .iter()
                    .filter_map(|t| match t {
                        EnergyTerm::Adhesion(p) => Some(p.clone()),
                        _ => None,
                    })
                    .collect(),
                self.adhesion_substrate().ok(),
            ))
            .map_err(build_err)?;
        let spring_stiffness = self.add_energy_terms(&mut builder, scene_path)?;
        if let Some(set) = &self.species {
            let base = self
                .energy
                .iter()
                .find_map(|t| match t {
                    EnergyTerm::Bending(p) => Some(crate::species::free_energy::BaseBending {
                        kappa: p.kappa,
                        c0: p.c0,
                        discretisation: p.discretisation,
                    }),
                    _ => None,
                })
                .unwrap_or(crate::species::free_energy::BaseBending {
                    kappa: 0.0,
                    c0: 0.0,
                    discretisation: Default::default(),
                });
            let tolerance = match self.dynamics_resolved().method {
                crate::params::Method::Minimise(m) => m.field_tolerance,
                _ => crate::params::MinimiserParams::default().field_tolerance,
            };
            let relax = crate::species::relax::RelaxSettings {
                tolerance,
                max_iterations: 100,
            };
            builder
                .add_plugin(plugins::species(set.clone(), base, relax))
                .map_err(|e| match e {
                    BuildError::Invalid { field, reason } => SceneError::Invalid {
                        path: scene_path.to_owned(),
                        field: format!("species.{field}"),
                        reason,
                    },
                    e => invalid_at("species".into(), e),
                })?;
        }
        let points = self
            .control_points
            .iter()
            .map(|cp| {
                let (x, y, z) = cp.position;
                ControlPoint {
                    position: DVec3::new(x, y, z),
                    stiffness: cp.stiffness.unwrap_or(spring_stiffness),
                }
            })
            .collect();
        builder
            .add_plugin(plugins::control_points(
                points,
                self.control_point_schedule.clone(),
            ))
            .map_err(build_err)?;
        if !self.boundary.is_empty() {
            builder
                .add_plugin(plugins::boundary_conditions(self.boundary.clone()))
                .map_err(|e| invalid_at("boundary".into(), e))?;
        }
        self.add_remeshing_and_systems(&mut builder, scene_path)?;
        builder
            .add_plugin(crate::io::output::frame_output)
            .map_err(build_err)?;
        Ok(builder)
    }

    /// Adds the energy terms' plugins in declaration order; returns the
    /// control points' default stiffness (the last term declaring one,
    /// [`crate::energy::builtin::TermNeeds::control_point_stiffness`]).
    fn add_energy_terms(
        &self,
        builder: &mut SimBuilder,
        scene_path: &Path,
    ) -> Result<f64, SceneError> {
        let invalid_at = |field: String, e: BuildError| SceneError::Invalid {
            path: scene_path.to_owned(),
            field,
            reason: e.to_string(),
        };
        let context = crate::energy::builtin::TermContext {
            remesh_mode: self.remesh.mode,
        };
        for (i, term) in self.energy.iter().enumerate() {
            term.add_to(builder, &context, |c, b| add_declared(&c.0, b).map(|_| ()))
                .map_err(|e| invalid_at(format!("energy[{i}]"), e))?;
        }
        let spring_stiffness = self
            .energy
            .iter()
            .rev()
            .find_map(|t| t.needs().control_point_stiffness);
        Ok(spring_stiffness.unwrap_or(SpringParams::default().stiffness))
    }

    /// Adds the maintenance flips, remeshing, Metropolis flips and lipid
    /// diffusion the scene declares, then its declared systems.
    fn add_remeshing_and_systems(
        &self,
        builder: &mut SimBuilder,
        scene_path: &Path,
    ) -> Result<(), SceneError> {
        use crate::scene::plugins;
        let invalid_at = |field: String, e: BuildError| SceneError::Invalid {
            path: scene_path.to_owned(),
            field,
            reason: e.to_string(),
        };
        let build_err = |e: BuildError| invalid_at("membrane".into(), e);
        if let crate::params::MembraneModel::Fluid(crate::params::FluidParams {
            flips: Some(flips),
            ..
        }) = self.model
        {
            builder
                .add_plugin(plugins::maintenance_flips(flips, self.valence))
                .map_err(|e| invalid_at("model.flips".into(), e))?;
        }
        if self.remesh.mode != crate::params::RemeshMode::Off {
            builder
                .add_plugin(plugins::remesh(self.valence))
                .map_err(build_err)?;
        }
        if let Some(flips) = self.edge_flips {
            builder
                .add_plugin(plugins::edge_flips(flips, self.valence))
                .map_err(|e| invalid_at("edge_flips".into(), e))?;
        }
        if let Some(d) = &self.diffusion {
            builder
                .add_plugin(plugins::diffusion(d.clone()))
                .map_err(build_err)?;
        }
        for (i, SystemDecl::Custom(c)) in self.systems.iter().enumerate() {
            add_declared(&c.0, builder).map_err(|e| invalid_at(format!("systems[{i}]"), e))?;
        }
        Ok(())
    }
}

/// Adds a scene-declared plugin (resolved when the scene was parsed).
fn add_declared<'b>(
    decl: &crate::scene::plugin_decl::PluginDecl,
    builder: &'b mut SimBuilder,
) -> Result<&'b mut SimBuilder, BuildError> {
    let entry = decl.entry().ok_or_else(|| BuildError::Invalid {
        field: "Custom.name".into(),
        reason: format!("plugin \"{}\" was not resolved by a registry", decl.name),
    })?;
    entry.build(&decl.params, decl.stage, builder)?;
    Ok(builder)
}

/// The mesh of a scene's `Axisymmetric` membrane: the solver's shape on
/// `branch` at reduced volume `v`, scaled to `area` and revolved at
/// `edge_length`.
fn axisymmetric_mesh(
    scene_path: &Path,
    branch: crate::analysis::axisymmetric::Branch,
    reduced_volume: f64,
    area: f64,
    mean_edge_length: f64,
) -> Result<SurfaceMesh, SceneError> {
    let invalid = |field: &str, reason: String| SceneError::Invalid {
        path: scene_path.to_owned(),
        field: field.to_string(),
        reason,
    };
    let shape = crate::analysis::axisymmetric::solve_on_branch(reduced_volume, 200, branch)
        .map_err(|e| {
            invalid(
                "membrane.reduced_volume",
                format!("no {branch} shape at v = {reduced_volume}: {e}"),
            )
        })?;
    let r0 = (area / (4.0 * std::f64::consts::PI)).sqrt();
    let profile: Vec<(f64, f64)> = shape
        .profile
        .iter()
        .map(|&(r, z)| (r0 * r, r0 * z))
        .collect();
    crate::mesh::revolution(&profile, mean_edge_length)
        .map_err(|e| invalid("membrane", e.to_string()))
}

/// The mesh of a scene's `State` membrane, refined `refine` times, and its
/// lipid densities when it is not refined.
fn state_mesh(
    scene_path: &Path,
    path: &Path,
    refine: u32,
) -> Result<(SurfaceMesh, Option<Vec<f64>>), SceneError> {
    let base = scene_path.parent().unwrap_or(Path::new("."));
    let state =
        crate::io::state::SavedState::read(&base.join(path)).map_err(|e| SceneError::Invalid {
            path: scene_path.to_owned(),
            field: "membrane".into(),
            reason: format!("state file {e}"),
        })?;
    let mut mesh = state.mesh();
    let lipid = (refine == 0).then(|| state.lipid_density.clone()).flatten();
    for _ in 0..refine {
        mesh = mesh.subdivided();
    }
    Ok((mesh, lipid))
}

impl Scene {
    /// The dynamics with the defaults that depend on the rest of the scene
    /// resolved: a Sobolev preconditioner's normal scale is the sum of the
    /// bending rigidities (1 without bending).
    fn dynamics_resolved(&self) -> crate::params::DynamicsParams {
        let mut d = self.dynamics;
        if let crate::params::Method::Minimise(m) = &mut d.method
            && let crate::params::Preconditioner::Sobolev(p) = &mut m.preconditioner
            && p.normal_scale.is_none()
        {
            let kappa: f64 = self
                .energy
                .iter()
                .filter_map(|t| t.needs().bending_rigidity)
                .sum();
            p.normal_scale = Some(if kappa > 0.0 { kappa } else { 1.0 });
        }
        d
    }
}

//! D3's executor: runs a deck's commands (`d3::deck`) against the model and a backend (`d3::cpu`, `d3::gpu`),
//! writing the run log as the 1985 program did (a `>` before each echoed command, `TIMESTEP =`
//! and `CURRENT CYCLE COUNT =` after each CYCLE, the PRINT tables of `d3::output`).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use glam::DVec3;

use super::backend::Backend;
use super::cpu::CpuBackend;
use super::deck::{Command, DampMode, Located, PrintItem, PropKey, Range3};
use super::geometry;
use super::model::{Block, Material, Model};
use super::output;
use crate::deck::DeckError;
use crate::driver::run::{Pieces, RunOptions, Ticker};
use crate::driver::{CycleError, CycleReport};
use crate::output::format::fmt_e;

/// Why a run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A command that cannot be carried out (its file, line and why).
    #[error("{0}")]
    Input(DeckError),
    /// A numerical failure during the CYCLE at `line` of `file` (named as 2D's are); the model
    /// holds the last good state.
    #[error("{file}:{line}: {failure}")]
    Cycle { file: String, line: usize, failure: CycleError },
    /// Ctrl-C or SIGTERM stopped the run at an energy check.
    #[error("interrupted at cycle {0}")]
    Interrupted(u64),
    #[error("cannot write the run log: {0}")]
    Io(#[from] std::io::Error),
}

impl RunError {
    pub fn is_interrupted(&self) -> bool {
        matches!(self, RunError::Interrupted(_))
    }
}

/// Runs D3 decks.
pub struct Executor<'a> {
    pub model: Model,
    backend: Box<dyn Backend>,
    log: Box<dyn Write + 'a>,
    file: String,
    /// The chassis's run options (as 2D's): `--out` (SAVE and RESTART files named without a
    /// folder, VTK frames, running restart files), progress, Ctrl-C, `--checkpoint-every`,
    /// `--vtk-every`.
    options: RunOptions,
    /// After a BLOCK or BOX: the number of blocks, the last block's id and the largest id then,
    /// so that a deck of 10⁵ BOXes does not look through every block for the largest id at each
    /// (taken where the count and the last id are still those; any other command drops it).
    id_hint: Option<(usize, u32, u32)>,
}

/// SAVE's and RESTART's file when the command names none (as in 2D).
pub const DEFAULT_SAVE_FILE: &str = "blockdem.sav";
/// The folder of the output folder VTK frames go into, and the running restart file (as in 2D).
pub use crate::driver::run::{CHECKPOINT_FILE, VTK_DIR};

impl<'a> Executor<'a> {
    /// An executor writing its log to `log`; `file` names the deck in error messages.
    pub fn new(log: Box<dyn Write + 'a>, file: &str) -> Self {
        Self::with_backend(log, file, Box::new(CpuBackend::new()))
    }

    /// An executor running its CYCLEs on `backend` (the CPU's or the GPU's).
    pub fn with_backend(log: Box<dyn Write + 'a>, file: &str, backend: Box<dyn Backend>) -> Self {
        Executor { model: Model::default(), backend, log, file: file.to_string(), options: RunOptions::default(), id_hint: None }
    }

    /// The backend in words.
    pub fn backend_name(&self) -> String {
        self.backend.describe()
    }

    /// The run's options (`--out`, progress, Ctrl-C, `--checkpoint-every`, `--vtk-every`).
    pub fn set_options(&mut self, options: RunOptions) {
        self.options = options;
    }

    /// The folder SAVE and RESTART files named without a folder are in.
    pub fn set_out_dir(&mut self, dir: &Path) {
        self.options.out_dir = dir.to_path_buf();
    }

    /// The path of a SAVE or RESTART file: `name` (or [`DEFAULT_SAVE_FILE`]) in the output folder
    /// when it names no folder.
    fn resolve(&self, name: &Option<String>) -> PathBuf {
        crate::output::resolve_in(&self.options.out_dir, name.as_deref(), DEFAULT_SAVE_FILE)
    }

    /// Writes the model as a save file RESTART reads (SAVE's, and the last good state `blockdem
    /// run` keeps after a failure or an interrupt).
    pub fn save_state(&self, path: &Path) -> Result<(), super::restart::RestartError> {
        let resumable = self.backend.resumes_from(&self.model);
        let device = if resumable { self.backend.device_state() } else { None };
        let saved = super::restart::SaveFile { model: self.model.clone(), resumable, device };
        super::restart::save(path, &saved)
    }

    /// A flag that, once set, stops a CYCLE at its next energy check.
    pub fn set_interrupt(&mut self, flag: Arc<AtomicBool>) {
        self.options.interrupt = Some(flag);
    }

    fn echo(&mut self, line: &str) -> Result<(), RunError> {
        writeln!(self.log, "{line}")?;
        Ok(())
    }

    fn error(&self, cmd: &Located, message: impl Into<String>) -> RunError {
        RunError::Input(DeckError::new(&self.file, cmd.line, 0, message))
    }

    /// Runs the commands in order, up to STOP or END.
    pub fn run(&mut self, commands: &[Located]) -> Result<(), RunError> {
        for cmd in commands {
            self.echo(&format!(">{}", cmd.source))?;
            let stop = matches!(cmd.command, Command::Stop | Command::End);
            self.execute(cmd)?;
            self.log.flush()?;
            if stop {
                break;
            }
        }
        Ok(())
    }

    fn execute(&mut self, cmd: &Located) -> Result<(), RunError> {
        if !matches!(cmd.command, Command::Block { .. } | Command::Box { .. }) {
            self.id_hint = None;
        }
        match &cmd.command {
            Command::Start => {
                self.echo("PROGRAM D3: THREE-DIMENSIONAL DISTINCT ELEMENT CODE (VERSION 1.0)")?;
                self.echo("THIS IS A START RUN")?;
            }
            Command::Block { material, constitutive, faces } => {
                let typed: Vec<[[f64; 3]; 3]> = faces.iter().map(|f| f.vertices).collect();
                let line_of = |face: usize| faces.get(face - 1).map_or(cmd.line, |f| f.line);
                self.add_block(cmd, &typed, *material, *constitutive, line_of)?;
            }
            Command::Box { range, material, constitutive } => {
                let typed = geometry::box_faces(range.min, range.max);
                self.add_block(cmd, &typed, *material, *constitutive, |_| cmd.line)?;
            }
            Command::Property { material, values } => self.property(cmd, *material, values)?,
            Command::Gravity { g } => self.model.gravity = DVec3::from_array(*g),
            Command::Fix { range } => {
                for b in self.in_range(range) {
                    let blk = &mut self.model.blocks[b];
                    // A held block (BOUNDARY VELOCITY) is held at rest instead.
                    blk.fixed = true;
                    blk.held = false;
                    blk.velocity = DVec3::ZERO;
                    blk.angular_momentum = DVec3::ZERO;
                    blk.angular_velocity = DVec3::ZERO;
                }
                self.model.neighbours_stale = true;
            }
            Command::Free { range } => {
                for b in self.in_range(range) {
                    // A held block (BOUNDARY VELOCITY) goes on from its velocity, free.
                    self.model.blocks[b].fixed = false;
                    self.model.blocks[b].held = false;
                }
                self.model.neighbours_stale = true;
            }
            Command::Load { range, force } => {
                for b in self.in_range(range) {
                    self.model.blocks[b].load = DVec3::from_array(*force);
                }
            }
            Command::Velocity { range, velocity, angular } => {
                // Each block's kinetic energy may be finite and their sum not: the ledger would
                // book ∞. The energy now plus what the command gives must stay finite.
                let blocks = self.in_range(range);
                let (v, w) = (DVec3::from_array(*velocity), DVec3::from_array(angular.unwrap_or([0.0; 3])));
                let given: f64 = blocks
                    .iter()
                    .map(|&b| &self.model.blocks[b])
                    .filter(|blk| !blk.fixed)
                    .map(|blk| 0.5 * blk.mass * v.length_squared() + 0.5 * w.dot(blk.inertia() * w))
                    .sum();
                if !(given + self.model.energies().kinetic + self.model.external_work.abs()).is_finite() {
                    return Err(self.error(
                        cmd,
                        "VELOCITY: the blocks would move so fast together that their kinetic energy overflows f64; check the values and the units",
                    ));
                }
                for b in blocks {
                    let blk = &mut self.model.blocks[b];
                    if blk.fixed {
                        continue;
                    }
                    let before = blk.kinetic_energy();
                    blk.velocity = DVec3::from_array(*velocity);
                    let w = DVec3::from_array(angular.unwrap_or([0.0; 3]));
                    blk.angular_momentum = blk.inertia() * w;
                    blk.angular_velocity = w;
                    // The kinetic energy given is input, booked with the work of the loads.
                    let after = blk.kinetic_energy();
                    if !after.is_finite() {
                        let id = blk.id;
                        return Err(self.error(cmd, format!("VELOCITY: block {id} would move so fast that its kinetic energy overflows f64")));
                    }
                    self.model.external_work += after - before;
                }
            }
            Command::BoundaryStress { range, stress } => self.boundary_stress(range, stress)?,
            Command::BoundaryVelocity { range, velocity, angular } => self.boundary_velocity(cmd, range, velocity, angular)?,
            Command::Damping { fcrit, freq, mode } => {
                // Rayleigh damping with its least ξ at ω = 2πf: α = ξω, β = ξ/ω (as in 2D).
                let omega = 2.0 * std::f64::consts::PI * freq;
                let (alpha, beta) = (fcrit * omega, fcrit / omega);
                if !(alpha.is_finite() && beta.is_finite()) {
                    return Err(self.error(cmd, format!("DAMPING: fcrit {fcrit:e} at freq {freq:e} gives damping constants that are not finite numbers")));
                }
                let d = &mut self.model.damping;
                match mode {
                    DampMode::Full => (d.alpha, d.beta) = (alpha, beta),
                    DampMode::Mass => {
                        (d.alpha, d.beta) = (alpha, 0.0);
                        self.echo("STIFFNESS-DAMPING TERM SET TO ZERO")?;
                    }
                    DampMode::Stiffness => {
                        (d.alpha, d.beta) = (0.0, beta);
                        self.echo("MASS-DAMPING TERM SET TO ZERO")?;
                    }
                    DampMode::Internal => {
                        // The strain's own mass damping (ALPB); the blocks' Rayleigh damping is
                        // left as it was (as in 2D).
                        d.alpha_internal = alpha;
                        self.echo("NOTE - ONLY MASS-DAMPING USED")?;
                    }
                }
            }
            Command::Change { range, sdef, material, constitutive } => self.change(cmd, range, *sdef, *material, *constitutive)?,
            Command::Fraction { f } => self.model.frac = *f,
            Command::Cycle { n } => self.cycle(cmd, *n)?,
            Command::Print { items } => {
                for item in items {
                    let table = match item {
                        PrintItem::Blocks => output::blocks_table(&self.model),
                        PrintItem::Faces => output::faces_table(&self.model),
                        PrintItem::Velocities => output::velocities_table(&self.model),
                        PrintItem::Vertices => output::vertices_table(&self.model),
                        PrintItem::Contacts => output::contacts_table(&self.model),
                        PrintItem::Energy => output::energy_table(&self.model),
                    };
                    self.log.write_all(table.as_bytes())?;
                }
            }
            Command::Split { point, normal, material, constitutive } => {
                let outcome = super::split::split(&mut self.model, DVec3::from_array(*point), DVec3::from_array(*normal), *material, *constitutive);
                if let Some(n) = material {
                    if self.model.material(*n).density <= 0.0 && !outcome.split.is_empty() {
                        self.echo(&format!("WARNING: SPLIT: material {n} has no DENSITY yet: the pieces have no mass until PROPERTY gives it"))?;
                    }
                }
                for (id, why) in &outcome.rejected {
                    self.echo(&format!("WARNING: SPLIT: block {id} left whole: {why}"))?;
                }
                if outcome.split.is_empty() {
                    if outcome.rejected.is_empty() {
                        self.echo("WARNING: SPLIT: the plane crosses no block")?;
                    }
                } else {
                    let list: Vec<String> = outcome.split.iter().map(|(a, b)| format!("{a} -> {a} + {b}")).collect();
                    self.echo(&format!("SPLIT: {} BLOCKS CUT ({})", outcome.split.len(), list.join(", ")))?;
                }
            }
            Command::Restart { file } => {
                let path = self.resolve(file);
                let saved = super::restart::load(&path).map_err(|e| self.error(cmd, format!("RESTART: {e}")))?;
                self.model = saved.model;
                self.backend.forget();
                if saved.resumable {
                    self.backend.resume_from(&self.model, saved.device.as_ref());
                }
                self.echo("PROGRAM D3: THREE-DIMENSIONAL DISTINCT ELEMENT CODE (VERSION 1.0)")?;
                self.echo(&format!("THIS IS A RESTART RUN (FROM {}, CYCLE {})", path.display(), self.model.cycle))?;
            }
            Command::Save { file } => {
                let path = self.resolve(file);
                if let Some(dir) = path.parent() {
                    let _ = std::fs::create_dir_all(dir);
                }
                self.save_state(&path).map_err(|e| self.error(cmd, format!("SAVE: {e}")))?;
                self.echo(&format!("STATE SAVED TO {}", path.display()))?;
            }
            Command::Dump { .. } => output::dump(&self.model, &mut self.log)?,
            Command::Vtk => {
                let dir = self.options.out_dir.join(VTK_DIR);
                let path = super::vtk::write_frame(&self.model, &dir).map_err(|e| self.error(cmd, format!("VTK: {e}")))?;
                self.echo(&format!("VTK FRAME WRITTEN TO {} (AND ITS CONTACTS BESIDE IT)", path.display()))?;
            }
            Command::Stop | Command::End => {}
        }
        Ok(())
    }

    /// BLOCK and BOX: the surface checked, the block added with its material's density.
    fn add_block(
        &mut self,
        cmd: &Located,
        typed: &[[[f64; 3]; 3]],
        material: u32,
        constitutive: u32,
        line_of: impl Fn(usize) -> usize,
    ) -> Result<(), RunError> {
        let (shape, props) = match geometry::shape_from_faces(typed) {
            Ok(ok) => ok,
            Err(e) => {
                let (line, message) = match e.face {
                    Some(face) => (line_of(face), format!("BLOCK: face {face}: {}", e.message)),
                    None => (cmd.line, format!("BLOCK: {}", e.message)),
                };
                return Err(RunError::Input(DeckError::new(&self.file, line, 0, message)));
            }
        };
        let density = self.model.material(material).density;
        // Ids from 1 in the order built; SPLIT's pieces take ids past the largest.
        let largest = match self.id_hint {
            Some((count, last, largest)) if count == self.model.blocks.len() && self.model.blocks.last().map(|b| b.id) == Some(last) => largest,
            _ => self.model.blocks.iter().map(|b| b.id).max().unwrap_or(0),
        };
        let id = largest + 1;
        // A concave block (¶13) is cut once into the convex parts contact detection sees.
        let parts = super::decompose::parts_if_concave(&shape, props.volume)
            .map_err(|why| self.error(cmd, format!("BLOCK: block {id} is concave and cannot be made of convex parts: {why}")))?;
        let block = Block::new(id, material, constitutive, shape, &props, density).with_parts(parts);
        if !(block.mass.is_finite() && block.inertia_ref.is_finite()) {
            return Err(self.error(cmd, density_overflow_text("BLOCK", &block, density, material)));
        }
        self.model.blocks.push(block);
        self.id_hint = Some((self.model.blocks.len(), id, id));
        self.model.neighbours_stale = true;
        Ok(())
    }

    /// The error for the first of `blocks` whose mass or inertia would overflow f64 at density
    /// `new` (its material's now `old`): CYCLE would take an infinite mass, and a fixed block's
    /// angular velocity I⁻¹·0 would be NaN (found by tests/suite/d3_random_decks.rs). As 2D's
    /// `mass_overflow`; the command fails whole.
    fn density_overflow(&self, cmd: &Located, what: &str, blocks: impl Iterator<Item = usize>, material: u32, old: f64, new: f64) -> Option<RunError> {
        let b = blocks.into_iter().find(|&b| {
            let (mass, inertia) = self.model.blocks[b].at_density(old, new);
            !(mass.is_finite() && inertia.is_finite())
        })?;
        Some(self.error(cmd, density_overflow_text(what, &self.model.blocks[b], new, material)))
    }

    /// PROPERTY: the material's values; blocks of the material take a new density's mass (a
    /// density that would overflow one's mass or inertia is refused, the material left as it was).
    fn property(&mut self, cmd: &Located, material: u32, values: &[(PropKey, f64)]) -> Result<(), RunError> {
        let n = material as usize;
        if self.model.materials.len() < n {
            self.model.materials.resize(n, Material::default());
        }
        let old_density = self.model.materials[n - 1].density;
        if let Some(&(_, density)) = values.iter().rev().find(|(key, _)| *key == PropKey::Density) {
            let own = (0..self.model.blocks.len()).filter(|&b| self.model.blocks[b].material == material);
            if let Some(e) = self.density_overflow(cmd, "PROPERTY", own, material, old_density, density) {
                return Err(e);
            }
        }
        let m = &mut self.model.materials[n - 1];
        for &(key, v) in values {
            match key {
                PropKey::Bulk => m.bulk = v,
                PropKey::Shear => m.shear = v,
                PropKey::Density => m.density = v,
                PropKey::Kn => m.kn = v,
                PropKey::Ks => m.ks = v,
                PropKey::Cohesion => m.cohesion = v,
                PropKey::Friction => m.friction = v,
                PropKey::Jkn => m.jkn = v,
                PropKey::Jks => m.jks = v,
                PropKey::Jcohesion => m.jcohesion = v,
                PropKey::Jfriction => m.jfriction = v,
                PropKey::Tf => m.tf = v,
                // The fluid keys: d3::deck refuses them at their line (D3 has no fluid flow).
                PropKey::Jperm | PropKey::Cperm | PropKey::Azero | PropKey::Ares => {}
            }
        }
        let density = m.density;
        if density != old_density {
            for b in self.model.blocks.iter_mut().filter(|b| b.material == material) {
                b.set_density(old_density, density);
            }
        }
        Ok(())
    }

    /// CHANGE: the blocks in the range take the material and constitutive numbers given (a new
    /// material's density their mass) and, with SDEF, become simply deformable from the state
    /// they are in (no strain, no stress: their present shape is the unstrained one).
    fn change(&mut self, cmd: &Located, range: &Range3, sdef: bool, material: Option<u32>, constitutive: Option<u32>) -> Result<(), RunError> {
        let chosen = self.in_range(range);
        if chosen.is_empty() {
            self.echo("WARNING: CHANGE: no block has its centroid in the range")?;
            return Ok(());
        }
        if sdef {
            // The strain needs both moduli (checked before anything changes). A concave block
            // may take one: its uniform strain maps every point of it by the one affine map
            // c + (I + ε)·R·x, so its convex parts stay convex and still fill it, face to face
            // (`Block::place_parts`).
            for &b in &chosen {
                let n = material.unwrap_or(self.model.blocks[b].material);
                let m = self.model.material(n);
                if !(m.bulk > 0.0 && m.shear > 0.0) {
                    let id = self.model.blocks[b].id;
                    return Err(self.error(
                        cmd,
                        format!("CHANGE SDEF: block {id}'s material {n} has no BULK and G (a simply-deformable block's strain needs both moduli): give them with PROPERTY first"),
                    ));
                }
            }
        }
        if let Some(n) = material {
            let new = self.model.material(n).density;
            for &b in &chosen {
                let old = self.model.material(self.model.blocks[b].material).density;
                if let Some(e) = self.density_overflow(cmd, "CHANGE", std::iter::once(b), n, old, new) {
                    return Err(e);
                }
            }
        }
        if let Some(n) = material {
            let density = self.model.material(n).density;
            if density <= 0.0 {
                self.echo(&format!("WARNING: CHANGE: material {n} has no DENSITY yet: the blocks have no mass until PROPERTY gives it"))?;
            }
        }
        for b in chosen {
            if let Some(n) = material {
                let old = self.model.material(self.model.blocks[b].material).density;
                let new = self.model.material(n).density;
                let blk = &mut self.model.blocks[b];
                blk.material = n;
                if new != old {
                    blk.set_density(old, new);
                }
            }
            let blk = &mut self.model.blocks[b];
            if let Some(m) = constitutive {
                blk.constitutive = m;
            }
            if sdef && blk.sdef.is_none() {
                // The strain is measured from the shape the block has now: its vertices are
                // already placed, so nothing moves.
                blk.sdef = Some(super::sdef::Sdef::default());
            }
        }
        self.model.neighbours_stale = true;
        Ok(())
    }

    /// BOUNDARY STRESS (extension, ¶35e): every face of every block whose centroid (as the
    /// vertices are placed now) lies in the open range takes the stress σ; a face loaded before
    /// has its stress replaced, and the log says how many were.
    fn boundary_stress(&mut self, range: &Range3, stress: &[f64; 6]) -> Result<(), RunError> {
        let (mut faces, mut blocks, mut replaced) = (0usize, 0usize, 0usize);
        for b in &mut self.model.blocks {
            let caught: Vec<u32> = (0..b.shape.faces.len() as u32)
                .filter(|&f| {
                    let [p0, p1, p2] = b.shape.faces[f as usize].map(|k| b.vertices[k as usize]);
                    range.contains(((p0 + p1 + p2) / 3.0).to_array())
                })
                .collect();
            if caught.is_empty() {
                continue;
            }
            blocks += 1;
            faces += caught.len();
            for face in caught {
                match b.boundary_stress.binary_search_by_key(&face, |l| l.face) {
                    Ok(k) => {
                        b.boundary_stress[k].stress = *stress;
                        replaced += 1;
                    }
                    Err(k) => b.boundary_stress.insert(k, super::model::FaceStress { face, stress: *stress }),
                }
            }
        }
        if faces == 0 {
            self.echo("WARNING: BOUNDARY STRESS: no face has its centroid in the range")?;
        } else {
            let again = if replaced > 0 { format!(", {replaced} OF THEM LOADED BEFORE: THEIR STRESS REPLACED") } else { String::new() };
            self.echo(&format!("BOUNDARY STRESS ON {faces} FACES OF {blocks} BLOCKS{again}"))?;
        }
        Ok(())
    }

    /// BOUNDARY VELOCITY (extension, ¶35e): the blocks whose centroid lies in the range, fixed or
    /// free, are held at the velocity and spin (`motion::held_motion`); the kinetic energy this
    /// gives them is booked as external work, as VELOCITY's is.
    fn boundary_velocity(&mut self, cmd: &Located, range: &Range3, velocity: &[f64; 3], angular: &Option<[f64; 3]>) -> Result<(), RunError> {
        let chosen = self.in_range(range);
        if chosen.is_empty() {
            self.echo("WARNING: BOUNDARY VELOCITY: no block has its centroid in the range")?;
            return Ok(());
        }
        if let Some(&b) = chosen.iter().find(|&&b| self.model.blocks[b].mass.is_nan() || self.model.blocks[b].mass <= 0.0) {
            let (id, mat) = (self.model.blocks[b].id, self.model.blocks[b].material);
            return Err(self.error(cmd, format!("BOUNDARY VELOCITY: block {id} has no mass: give its material (MATERIAL {mat}) a DENSITY first")));
        }
        for &b in &chosen {
            let blk = &mut self.model.blocks[b];
            // The kinetic energy it had, its strain modes' too (their rate is stopped).
            let mut before = if blk.fixed { 0.0 } else { blk.kinetic_energy() };
            if let (Some(s), false) = (&blk.sdef, blk.fixed || blk.held) {
                let j = super::sdef::strain_inertia(super::sdef::second_moments(blk.inertia()));
                before += super::sdef::internal_kinetic_energy(s.strain_rate, j);
            }
            blk.fixed = false;
            blk.held = true;
            blk.velocity = DVec3::from_array(*velocity);
            let w = DVec3::from_array(angular.unwrap_or([0.0; 3]));
            blk.angular_momentum = blk.inertia() * w;
            blk.angular_velocity = w;
            if let Some(s) = &mut blk.sdef {
                s.strain_rate = [0.0; 6];
            }
            let after = blk.kinetic_energy();
            if !after.is_finite() {
                let id = blk.id;
                return Err(self.error(cmd, format!("BOUNDARY VELOCITY: block {id} would move so fast that its kinetic energy overflows f64")));
            }
            self.model.external_work += after - before;
        }
        self.echo(&format!("BOUNDARY VELOCITY: {} BLOCKS HELD", chosen.len()))?;
        self.model.neighbours_stale = true;
        Ok(())
    }

    /// The blocks whose centroid lies in the open range.
    fn in_range(&self, range: &Range3) -> Vec<usize> {
        (0..self.model.blocks.len()).filter(|&b| range.contains(self.model.blocks[b].centroid.to_array())).collect()
    }

    /// CYCLE n through the backend, with its log lines.
    fn cycle(&mut self, cmd: &Located, n: u64) -> Result<(), RunError> {
        if self.model.blocks.is_empty() {
            return Err(self.error(cmd, "CYCLE: there are no blocks (BLOCK or BOX first)"));
        }
        let Some(_) = self.model.critical_timestep() else {
            // The step comes from the blocks that give at their contacts: with none free there is
            // none to find (2D's step reads every block's mass; D3's the free blocks' modes).
            if self.model.blocks.iter().all(|b| b.fixed || b.held) {
                return Err(self.error(
                    cmd,
                    "CYCLE: every block is fixed (FIX) or held (BOUNDARY VELOCITY): there is no free block to take the time step from; FREE x1 x2 y1 y2 z1 z2 the blocks that are to move",
                ));
            }
            return Err(self.error(
                cmd,
                "CYCLE: the time step cannot be found: the free blocks need a DENSITY and the contacts the stiffnesses KN and KS (PROPERTY MATERIAL n ...)",
            ));
        };
        // Griffith's law reads a block's stress: a rigid block has none (as in 2D).
        if let Some(b) = self.model.blocks.iter().find(|b| !b.is_sdef() && super::sdef::griffith_applies(b.constitutive, self.model.material(b.material).tf)) {
            let (id, cons, mat) = (b.id, b.constitutive, b.material);
            let tf = self.model.material(mat).tf;
            return Err(self.error(
                cmd,
                format!(
                    "CYCLE: block {id} is rigid, but its constitutive number {cons} cracks it by Griffith's criterion (material {mat} has TF = {tf}), \
                     which needs the block's stress: make it simply deformable (CHANGE x1 x2 y1 y2 z1 z2 SDEF) or give it constitutive number 1 or 2"
                ),
            ));
        }
        // The joint law's stiffnesses are per unit area: a block whose constitutive number
        // asks for it needs them (its strength, JCOHESION and JFRICTION, may be zero).
        if let Some(b) = self.model.blocks.iter().find(|b| {
            let m = self.model.material(b.material);
            super::model::joint_contacts(b.constitutive) && !(m.jkn > 0.0 && m.jks > 0.0)
        }) {
            let (id, cons, mat) = (b.id, b.constitutive, b.material);
            return Err(self.error(
                cmd,
                format!(
                    "CYCLE: block {id}'s constitutive number {cons} gives its face contacts the joint law, whose stiffnesses are per unit area: \
                     material {mat} needs JKN and JKS (PROPERTY MAT {mat} JKN k JKS k; JCOHESION and JFRICTION its strength), or give the block constitutive number 1 or 3"
                ),
            ));
        }
        let mut ticker = Ticker::new(&self.options, n);
        self.log.flush()?;
        let start_cycle = self.model.cycle;
        let (report, result) = crate::driver::run::run_in_pieces(self, n, &mut ticker);
        let stopped = ticker.finish();
        // The cracks, as 2D's log lines, the crack a plane through the block's centroid.
        for c in &report.cracks {
            let p = |x: &[f64]| x.iter().map(|&v| fmt_e(v)).collect::<Vec<_>>().join(", ");
            self.echo(&format!(
                "BLOCK {} CRACKED AT CYCLE {} ({} {}): NEW BLOCK {} ACROSS THE PLANE THROUGH ({}) WITH NORMAL ({})",
                c.block,
                c.cycle,
                c.criterion,
                fmt_e(c.value),
                c.new_block,
                p(c.from.coords()),
                p(c.to.coords())
            ))?;
        }
        // The time step after the run, as the 1985 program printed it after each CYCLE: D3's is
        // renewed every cycle from the logical contacts there are (`Model::timestep`), and before
        // a run's first detection there are none (a deck's first CYCLE printed the step of blocks
        // without contacts, six times the one its wall of bricks then took).
        let step = format!("TIMESTEP = {}", fmt_e(self.model.timestep()));
        match result {
            Ok(()) => {}
            Err(CycleError::Setup(why)) => return Err(self.error(cmd, format!("CYCLE: cannot cycle: {why}"))),
            Err(e) => {
                if let Some(what) = self.given_overlapping(&e, start_cycle) {
                    return Err(self.error(cmd, what));
                }
                self.echo(&step)?;
                self.echo(&format!("CURRENT CYCLE COUNT = {}", self.model.cycle))?;
                return Err(RunError::Cycle { file: self.file.clone(), line: cmd.line, failure: e });
            }
        }
        self.echo(&step)?;
        self.echo(&format!("CURRENT CYCLE COUNT = {}", self.model.cycle))?;
        if stopped || self.options.interrupted() {
            self.echo(&format!("CYCLE INTERRUPTED AT CYCLE {}", self.model.cycle))?;
            return Err(RunError::Interrupted(self.model.cycle));
        }
        Ok(())
    }
}

impl Executor<'_> {
    /// Where a CYCLE stopped on an overlap past the limit and the model, rolled back, is where
    /// the CYCLE started: whether that state, its contacts detected afresh on a copy, has a
    /// contact driven through already. Then the blocks were given overlapping (BLOCK or BOX
    /// corners): an input error, said so, not a divergence to cure by a smaller FRACTION (as
    /// 2D's `overlap_before_motion`). (An overlap under the limit needs no such word: the run's
    /// energy check starts from the state with its contacts detected, their springs in it.)
    fn given_overlapping(&self, failure: &CycleError, start_cycle: u64) -> Option<String> {
        if !matches!(failure, CycleError::Overlap { .. }) || self.model.cycle != start_cycle {
            return None;
        }
        let mut probe = self.model.clone();
        super::topology::update_neighbours(&mut probe);
        super::cpu::contact_stage(&mut probe, 0.0);
        let Err(CycleError::Overlap { block1, block2, overlap, limit, at, .. }) = super::cpu::overlap_check(&probe) else { return None };
        let near = at.coords().iter().map(|&x| fmt_e(x)).collect::<Vec<_>>().join(", ");
        Some(format!(
            "CYCLE: blocks {block1} and {block2} overlap by {} near ({near}) before any motion, more than half the smaller block's radius ({}): \
             they were given overlapping (BLOCK or BOX corners); blocks may touch but not overlap",
            fmt_e(overlap),
            fmt_e(limit)
        ))
    }
}

impl Pieces for Executor<'_> {
    fn run_piece(&mut self, cycles: u64, tick: &mut dyn FnMut(u64) -> bool, report: &mut CycleReport) -> Result<(), CycleError> {
        self.backend.run_into(&mut self.model, cycles, tick, report)
    }

    fn write_frame(&mut self) {
        if let Err(e) = super::vtk::write_frame(&self.model, &self.options.out_dir.join(VTK_DIR)) {
            let _ = writeln!(std::io::stderr(), "blockdem: a VTK frame was not written ({e}); the run goes on");
        }
    }

    fn write_checkpoint(&mut self) {
        let _ = std::fs::create_dir_all(&self.options.out_dir);
        if let Err(e) = self.save_state(&self.options.out_dir.join(CHECKPOINT_FILE)) {
            let _ = writeln!(std::io::stderr(), "blockdem: the running restart file was not written ({e}); the run goes on");
        }
    }
}

/// The error text of a density whose mass or inertia overflows f64 on `block` (BLOCK, PROPERTY,
/// CHANGE).
fn density_overflow_text(what: &str, block: &Block, density: f64, material: u32) -> String {
    format!(
        "{what}: the mass of block {} (density {density:e} of material {material} × volume {:e}) or its inertia overflows f64; check DENSITY and the units of lengths",
        block.id, block.volume
    )
}

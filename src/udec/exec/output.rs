//! The commands that write: PRINT, PLOT, DUMP, VTK, SAVE, and RESTART, which reads what SAVE wrote
//! (WINDOW and VIEW, the plot's settings, are set in the dispatch, `Executor::execute`).

use std::io::Write;
use std::path::PathBuf;

use super::{Executor, RunError, DEFAULT_SAVE_FILE, VTK_DIR};
use crate::udec::deck::{Located, PlotOptions, PrintItem};
use crate::udec::output;

/// A plot's title: the deck's file name without its folders (a deck given as text has none).
fn deck_title(file: &str) -> &str {
    std::path::Path::new(file).file_name().and_then(|n| n.to_str()).unwrap_or(file)
}

impl Executor<'_> {
    /// The path of a SAVE or RESTART file: `name` (or `DEFAULT_SAVE_FILE`) in the output folder
    /// when it names no folder.
    fn resolve(&self, name: &Option<String>) -> PathBuf {
        crate::output::resolve_in(&self.options.out_dir, name.as_deref(), DEFAULT_SAVE_FILE)
    }

    /// RESTART [file]: the model and plot settings of a SAVE file, then the banner.
    pub(super) fn restart(&mut self, cmd: &Located, file: &Option<String>) -> Result<(), RunError> {
        let path = self.resolve(file);
        // Every RestartError names the file.
        let saved = output::restart::load(&path).map_err(|e| self.command_error(cmd, format!("RESTART: {e}")))?;
        // Save files of format 6 keep the domains (and the fluid) as the run left them; an older
        // file has none, and a scene that had them builds them again.
        let had_domains = self.model.domains.is_some();
        self.model = saved.model;
        if had_domains && self.model.domains.is_none() {
            crate::udec::topology::refresh_domains_with(&mut self.model, self.domain_min_area);
        }
        self.overlaps_checked = None;
        self.plot = saved.plot;
        self.plot_count = saved.plot_count;
        self.banner();
        self.echo(&format!("THIS IS A RESTART RUN (FROM {}, CYCLE {})", path.display(), self.model.cycle));
        Ok(())
    }

    /// SAVE [file]: the state, for RESTART (with fluid, the fluid and the domains too: save
    /// format 6).
    pub(super) fn save(&mut self, cmd: &Located, file: &Option<String>) -> Result<(), RunError> {
        let path = self.resolve(file);
        if let Some(dir) = path.parent() {
            let _ = std::fs::create_dir_all(dir);
        }
        output::restart::save_state(&path, &self.model, &self.plot, self.plot_count).map_err(|e| self.command_error(cmd, format!("SAVE: {e}")))?;
        self.echo(&format!("STATE SAVED TO {}", path.display()));
        Ok(())
    }

    /// DUMP: a full readable state dump into the log.
    pub(super) fn dump(&mut self, cmd: &Located) -> Result<(), RunError> {
        output::dump::dump(&self.model, &mut self.log).map_err(|e| self.command_error(cmd, format!("DUMP: {e}")))
    }

    /// VTK (extension): a frame of the blocks and contacts in the output folder's `VTK_DIR`.
    pub(super) fn vtk(&mut self, cmd: &Located) -> Result<(), RunError> {
        let dir = self.options.out_dir.join(VTK_DIR);
        let path = output::vtk::write_frame(&self.model, &dir).map_err(|e| self.command_error(cmd, format!("VTK: {e}")))?;
        self.echo(&format!("VTK FRAME WRITTEN TO {} (AND ITS CONTACTS BESIDE IT)", path.display()));
        Ok(())
    }

    /// PLOT: the next numbered plot files in the output folder, with a warning when the plot
    /// shows no block.
    pub(super) fn plot_files(&mut self, cmd: &Located, options: &PlotOptions) -> Result<(), RunError> {
        self.plot_count += 1;
        std::fs::create_dir_all(&self.options.out_dir)
            .map_err(|e| self.command_error(cmd, format!("PLOT: cannot create {}: {e}", self.options.out_dir.display())))?;
        let (files, empty) = output::plot::plot_noting_empty(&self.model, &self.plot, options, &self.options.out_dir, self.plot_count, deck_title(&self.file))
            .map_err(|e| self.command_error(cmd, format!("PLOT: {e}")))?;
        self.echo(&format!("PLOT WRITTEN TO {} AND {}", files[0].display(), files[1].display()));
        if let Some(why) = empty {
            self.echo(&format!("WARNING: PLOT shows no block: {why}"));
        }
        Ok(())
    }

    /// PRINT: the tables of `items`, in order, into the log.
    pub(super) fn print(&mut self, cmd: &Located, items: &[PrintItem]) -> Result<(), RunError> {
        for item in items {
            let r = match item {
                PrintItem::Blocks => output::print::print_blocks(&self.model, &mut self.log),
                PrintItem::Contacts => output::print::print_contacts(&self.model, &mut self.log),
                PrintItem::Corners => output::print::print_corners(&self.model, &mut self.log),
                PrintItem::List => output::print::print_block_lists(&self.model, &mut self.log),
                PrintItem::Energy => self.print_energy(),
                PrintItem::Domains => {
                    self.keep_domains();
                    output::print::print_domains(&self.model, &mut self.log)
                }
                PrintItem::DList => {
                    self.keep_domains();
                    output::print::print_domain_lists(&self.model, &mut self.log)
                }
                PrintItem::Flows => output::print::print_flows(&self.model, &mut self.log),
            };
            r.map_err(|e| self.command_error(cmd, format!("PRINT: {e}")))?;
        }
        Ok(())
    }

    /// Builds the domains when the scene first asks for them (PRINT DOMAINS or DLIST); from then
    /// on they are rebuilt after every command that changes the topology
    /// ([`Executor::refresh_domains_if_kept`]). A scene that never asks never builds them.
    fn keep_domains(&mut self) {
        if self.model.domains.is_none() {
            crate::udec::topology::refresh_domains_with(&mut self.model, self.domain_min_area);
        }
    }

    /// Rebuilds the domains of a scene that has them from the model's lists (keeping the ids of
    /// the voids found again); nothing in a scene without them.
    pub(super) fn refresh_domains_if_kept(&mut self) {
        if self.model.domains.is_some() {
            crate::udec::topology::refresh_domains_with(&mut self.model, self.domain_min_area);
        }
    }

    fn print_energy(&mut self) -> std::io::Result<()> {
        let e = self.model.energies();
        let f = output::format::fmt_e;
        writeln!(self.log)?;
        writeln!(self.log, "ENERGY")?;
        let strain = if self.model.has_sdef() { "STRAIN (CONTACTS AND SDEF BLOCKS)" } else { "STRAIN (CONTACTS)" };
        writeln!(self.log, "  KINETIC {}   {strain} {}   WORK OF GRAVITY, LOADS AND VELOCITY {}", f(e.kinetic), f(e.strain), f(e.external_work))?;
        writeln!(
            self.log,
            "  DISSIPATED: MASS DAMPING {}   CONTACT DASHPOTS {}   FRICTION {}   RELEASED (DELETED CONTACTS AND BLOCKS) {}",
            f(e.mass_damping),
            f(e.contact_damping),
            f(e.friction),
            f(e.released)
        )?;
        if self.model.fluid.is_some() {
            writeln!(self.log, "  WORK OF FLUID PRESSURES AND BUOYANCY {}", f(e.fluid_work))?;
        }
        writeln!(self.log, "  BALANCE: KINETIC + STRAIN + DISSIPATED + RELEASED - WORK = {}", f(e.ledger()))
    }
}

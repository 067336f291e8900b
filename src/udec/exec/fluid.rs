//! FLUID, PFIX and PFREE (SL-85-1 Appendix A ¶6–9 and ¶19), and the checks a scene with fluid
//! passes before CYCLE.

use super::{Executor, RunError};
use crate::udec::deck::{DomainRef, Located};
use crate::udec::model::constitutive::{Constitutive, ContactLaw};
use crate::udec::model::fluid::{domain_at, stored_volume, Fluid};

impl Executor<'_> {
    /// FLUID rhow bulkw: the scene carries fluid from here on; its domains are built (and rebuilt
    /// with every change of topology, in stage 7 too). Given again, it changes the fluid's
    /// properties and keeps the pressures and the accounts.
    pub(super) fn fluid(&mut self, density: f64, bulk: f64) {
        let first = self.model.fluid.is_none();
        let mut f = self.model.fluid.unwrap_or_default();
        f.density = density;
        f.bulk = bulk;
        self.model.fluid = Some(f);
        crate::udec::topology::refresh_domains_with(&mut self.model, self.domain_min_area);
        if first {
            // The mass balance starts here.
            if let (Some(f), Some(d)) = (self.model.fluid.as_mut(), self.model.domains.as_ref()) {
                f.stored_at_start = stored_volume(d, f.bulk);
                f.inflow = 0.0;
                f.adjusted = 0.0;
            }
        }
    }

    /// The index in the domain list of the domain `r` names, or an error naming the line.
    fn domain_named(&mut self, cmd: &Located, what: &str, r: DomainRef) -> Result<usize, RunError> {
        if self.model.fluid.is_none() {
            return Err(self.command_error(cmd, format!("{what}: no fluid in this model; give FLUID rhow bulkw before fixing domain pressures")));
        }
        let domains = self.model.domains.as_ref().expect("FLUID builds the domains");
        let found = match r {
            DomainRef::Outer => domains.list.iter().position(|d| d.kind == crate::udec::model::domain::DomainKind::Outer),
            DomainRef::Number(n) => domains.index_of(n),
            DomainRef::At(p) => domain_at(&self.model, domains, p),
        };
        found.ok_or_else(|| {
            let ids: Vec<u32> = domains.list.iter().map(|d| d.id).collect();
            let known = match (ids.first(), ids.last()) {
                (Some(a), Some(b)) if a != b => format!("the domains are {} ids from {a} to {b} (PRINT DOMAINS lists them)", ids.len()),
                (Some(a), _) => format!("the only domain is {a}, the outer one (contacts are found at the first CYCLE; CYCLE 0 detects them)"),
                _ => "there are no domains".to_string(),
            };
            let named = match r {
                DomainRef::Outer => "the outer domain".to_string(),
                DomainRef::Number(n) => format!("domain {n}"),
                DomainRef::At([x, y]) => {
                    let f = crate::output::format::fmt_short;
                    format!("domain at ({}, {}) (the point lies inside a block, away from any joint)", f(x), f(y))
                }
            };
            self.command_error(cmd, format!("{what}: there is no {named}; {known}"))
        })
    }

    /// Runs `change` on domain `d` and books the change of the fluid stored it makes (a pressure
    /// set, a domain leaving or joining the free ones) in the mass balance.
    fn change_domain(&mut self, d: usize, change: impl FnOnce(&mut crate::udec::model::domain::Domain)) {
        let Some(bulk) = self.model.fluid.map(|f| f.bulk) else { return };
        let Some(domains) = self.model.domains.as_mut() else { return };
        let before = stored_volume(domains, bulk);
        change(&mut domains.list[d]);
        let after = stored_volume(domains, bulk);
        if let Some(f) = self.model.fluid.as_mut() {
            f.adjusted += after - before;
        }
    }

    /// PFIX domain p: holds the domain's pressure at p (¶19); kept through rebuilds.
    pub(super) fn pfix(&mut self, cmd: &Located, r: DomainRef, pressure: f64) -> Result<(), RunError> {
        let d = self.domain_named(cmd, "PFIX", r)?;
        self.change_domain(d, |dom| {
            dom.pressure = pressure;
            dom.fixed = true;
        });
        Ok(())
    }

    /// PFREE domain: the domain's pressure follows its flows again, from the value it has.
    pub(super) fn pfree(&mut self, cmd: &Located, r: DomainRef) -> Result<(), RunError> {
        let d = self.domain_named(cmd, "PFREE", r)?;
        self.change_domain(d, |dom| dom.fixed = false);
        Ok(())
    }

    /// Before CYCLE in a scene with fluid: every material in use has a flow law (¶6): CPERM for
    /// its point contacts, and where its contacts may be joints (a joint constitutive number with
    /// JKN and JKS) JPERM with AZERO > 0 if it gives JPERM. Deformable blocks take the pressures
    /// too (`model::fluid::deformable_pressure_loads`, on the GPU `gpu::flow`).
    pub(super) fn check_fluid(&self, cmd: &Located) -> Result<(), RunError> {
        if self.model.fluid.is_none() {
            return Ok(());
        }
        let mut used: Vec<(u32, u32)> = self.model.blocks.iter().map(|b| (b.material, b.constitutive)).collect();
        used.extend(self.model.corners.iter().filter(|c| c.edge_material != 0).map(|c| (c.edge_material, c.edge_constitutive.max(1))));
        used.sort_unstable();
        used.dedup();
        for (m, cons) in used {
            let mat = self.model.material(m);
            let f = &mat.fluid;
            if !(f.cperm > 0.0 || f.jperm > 0.0) {
                return Err(self.command_error(
                    cmd,
                    format!(
                        "CYCLE: FLUID is given but material {m} has no flow law (¶6): give CPERM for flow across its point contacts \
                         (q = CPERM·Δp) or JPERM and AZERO for flow along its joints (q = JPERM·a³·Δp/l)"
                    ),
                ));
            }
            let joints = Constitutive::from_number(cons).is_some_and(|c| c.contact == ContactLaw::Joint) && mat.joint.kn > 0.0 && mat.joint.ks > 0.0;
            if joints && f.jperm > 0.0 && f.azero <= 0.0 {
                return Err(self.command_error(
                    cmd,
                    format!(
                        "CYCLE: material {m} gives joints a permeability JPERM but no aperture: the flow along a joint needs AZERO > 0 \
                         (a = max(ARES, AZERO − σn′/JKN))"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Book-keeping for the state a run leaves: the fluid's mass balance error now (stored −
    /// start − inflow − adjusted), in volume, and the stored volume.
    pub fn fluid_balance(&self) -> Option<(f64, f64)> {
        let f: Fluid = self.model.fluid?;
        let stored = stored_volume(self.model.domains.as_ref()?, f.bulk);
        Some((stored, f.balance_error(stored)))
    }
}

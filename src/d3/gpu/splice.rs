//! A partial detection's transfers, spliced ("Partial detections" in `d3::gpu`).
//!
//! A partial detection changes only the contacts of the blocks that moved: their pairs are
//! searched afresh and their logical contacts found afresh (stage 7 and the CPU's stage 4); every
//! other contact keeps the state the device tracks. So the detection moves only those across:
//!
//! 1. the contacts that touch a moved block (found in the adjacency the device was given, kept
//!    on the host: no pass over the list) are gathered on the device into short buffers and
//!    read back (their shear forces carry over by key, their accumulators are banked);
//! 2. the CPU runs stage 7 for the moved blocks and its stage 4 for their contacts: where no
//!    contact was made or dropped, the moved blocks' contacts renewed where they lie in the list
//!    (`topology::Renewal::in_place`), else the list merged with the fresh ones in one pass;
//! 3. the fresh contacts (those of the moved blocks, in the new list) are uploaded with a source
//!    per contact of the new list, and `splice_contacts` (shaders/d3/splice_contacts.wgsl, twin
//!    [`splice_contacts`]) makes the new contact and logical buffers: a kept contact's record and
//!    logical contacts copied from the buffers as they were, a fresh one's from the upload
//!    (the sources and keys made a stretch of kept contacts at a time, [`splice_plan`]);
//! 4. the block records are renewed on the device by `renew_blocks` (shaders/d3/renew_blocks.wgsl,
//!    twin [`renew_blocks`]) from 8 bytes a block (the adjacency range, whether it moved: its
//!    travel from zero, and the sums that count from the upload zeroed, the CPU having moved the
//!    values it read back after the batch into the bases), and the adjacency is uploaded whole
//!    where the list changed (where it kept its keys, the device's stands).
//!
//! In f64 the device's state after a splice is a whole re-upload's bit for bit (the test
//! `d3_gpu::spliced_detections_leave_the_state_a_whole_upload_leaves`), but for two things that
//! do not act: a kept contact's dead logical contacts stay in place (a whole upload drops them;
//! the kernels skip both), and the energy accumulators are banked by workgroup sums in the
//! kernel precision (a whole upload adds each contact's in f64), so the ledger's friction and
//! released terms differ by round-off. In f32 the device keeps each centroid's compensated pair
//! as it is, where a whole upload re-split it from the f64 sum read back (which does not hold a
//! low part 2⁻³⁰ below the high one to its last bit): the runs part by round-off.
//!
//! The model's contacts that no detection reads back are as the last read-back left them: a
//! contact between blocks that have stood still since is stale there until the run's end, a
//! SAVE, a crack or a failure reads every contact back (`sync`, `finish`, `recover`). So a
//! partial detection's overlap check covers the contacts it refreshed; the device's energy
//! check covers every contact each hundred cycles (`contact_energy`).

use std::rc::Rc;

use glam::DVec3;

use super::{layout, GpuBackend, State};
use crate::d3::contact::Appearing;
use crate::d3::cpu;
use crate::d3::model::{Contact, Logical, LogicalKind, Model};
use crate::d3::topology;
use crate::driver::{CycleError, CycleReport};
use crate::gpu::real::Real;
use crate::gpu::wgsl::workgroup_size;
use crate::gpu::GpuError;

/// The logical contacts' kinds as uploaded, contact by contact: contact k's are
/// `kinds[starts[k]..starts[k + 1]]`, the run its logical contacts fill in the logical buffer
/// (the read-back's keys, and where a splice puts each run).
#[derive(Clone, Debug, PartialEq)]
pub struct Keys {
    kinds: Vec<LogicalKind>,
    starts: Vec<u32>,
}

impl Default for Keys {
    fn default() -> Self {
        Keys { kinds: Vec::new(), starts: vec![0] }
    }
}

impl Keys {
    /// Keys for `contacts` contacts and `logicals` logical contacts, none pushed yet.
    pub fn with_capacity(contacts: usize, logicals: usize) -> Self {
        let mut starts = Vec::with_capacity(contacts + 1);
        starts.push(0);
        Keys { kinds: Vec::with_capacity(logicals), starts }
    }

    /// The keys of a SAVE's lists (`restart::DeviceState::keys`).
    pub fn from_lists(lists: &[Vec<LogicalKind>]) -> Self {
        let mut keys = Keys::with_capacity(lists.len(), lists.iter().map(Vec::len).sum());
        lists.iter().for_each(|run| keys.push(run.iter().copied()));
        keys
    }

    /// The lists a SAVE keeps.
    pub fn to_lists(&self) -> Vec<Vec<LogicalKind>> {
        (0..self.contacts()).map(|k| self.run(k).to_vec()).collect()
    }

    /// The next contact's run.
    pub fn push(&mut self, run: impl IntoIterator<Item = LogicalKind>) {
        self.kinds.extend(run);
        self.starts.push(self.kinds.len() as u32);
    }

    /// The runs of `old`'s contacts `from..from + count` pushed as the next contacts' (one copy
    /// of the kinds, the starts moved by as much).
    pub fn extend_runs(&mut self, old: &Keys, from: usize, count: usize) {
        let (a, b) = (old.starts[from], old.starts[from + count]);
        let shift = self.kinds.len() as u32;
        self.kinds.extend_from_slice(&old.kinds[a as usize..b as usize]);
        self.starts.extend(old.starts[from + 1..=from + count].iter().map(|&x| x - a + shift));
    }

    /// Contact `k`'s run.
    pub fn run(&self, k: usize) -> &[LogicalKind] {
        &self.kinds[self.starts[k] as usize..self.starts[k + 1] as usize]
    }

    /// Where contact `k`'s run starts in the logical buffer.
    pub fn start(&self, k: usize) -> u32 {
        self.starts[k]
    }

    /// How many contacts.
    pub fn contacts(&self) -> usize {
        self.starts.len() - 1
    }

    /// How many logical contacts (dead ones in place).
    pub fn logical_count(&self) -> usize {
        self.kinds.len()
    }
}

/// Twin of `splice_contacts` (shaders/d3/splice_contacts.wgsl): the contacts `sources` names,
/// each (its source: `layout::SPLICE_FRESH` with its index in `fresh`, else its index in `kept`;
/// the start of its run in the output's logical contacts), their records and logical contacts
/// copied, `logical_start` set, the energy accumulators zeroed; and each workgroup's sums of what
/// was zeroed, by the kernel's tree in the kernel precision.
#[allow(clippy::type_complexity)]
pub fn splice_contacts<R: Real>(
    kept: (&[layout::Contact<R>], &[layout::Logical<R>]),
    fresh: (&[layout::Contact<R>], &[layout::Logical<R>]),
    sources: &[[u32; 2]],
) -> (Vec<layout::Contact<R>>, Vec<layout::Logical<R>>, Vec<layout::Banked<R>>) {
    let record = |[source, _]: [u32; 2]| {
        let i = (source & !layout::SPLICE_FRESH) as usize;
        if source & layout::SPLICE_FRESH != 0 {
            (fresh.0[i], fresh.1)
        } else {
            (kept.0[i], kept.1)
        }
    };
    let logical_count = sources.iter().map(|&s| s[1] as usize + record(s).0.logical_count as usize).max().unwrap_or(0);
    let mut logicals = vec![layout::Logical::<R>::default(); logical_count];
    let mut contacts = Vec::with_capacity(sources.len());
    let mut zeroed = Vec::with_capacity(sources.len());
    for &s in sources {
        let (mut c, from) = record(s);
        let (start, run) = (s[1] as usize, c.logical_start as usize..(c.logical_start + c.logical_count) as usize);
        logicals[start..start + run.len()].copy_from_slice(&from[run]);
        zeroed.push([c.friction_work, c.released_work]);
        c.friction_work = R::from_f64(0.0);
        c.released_work = R::from_f64(0.0);
        c.logical_start = s[1];
        contacts.push(c);
    }
    // Each workgroup's tree, as the kernel's (an f32 sum rounded from f64 is f32's own sum).
    let size = workgroup_size() as usize;
    let add = |a: R, b: R| R::from_f64(a.to_f64() + b.to_f64());
    let banked = zeroed
        .chunks(size)
        .map(|group| {
            let mut parts = vec![[R::from_f64(0.0); 2]; size];
            parts[..group.len()].copy_from_slice(group);
            let mut s = size / 2;
            while s > 0 {
                for i in 0..s {
                    parts[i] = [add(parts[i][0], parts[i + s][0]), add(parts[i][1], parts[i + s][1])];
                }
                s /= 2;
            }
            layout::Banked { friction: parts[0][0], released: parts[0][1] }
        })
        .collect();
    (contacts, logicals, banked)
}

/// Twin of `renew_blocks` (shaders/d3/renew_blocks.wgsl): each block's record (the first
/// `renewals.len()`) given its adjacency range (`renewals[i]` = (start, length with
/// `layout::RENEW_MOVED` where it moved)), its travel from zero where it moved, and the sums that
/// count from the upload zeroed (the largest step's travel, the work, the dissipation).
pub fn renew_blocks<R: Real>(blocks: &mut [layout::Block<R>], renewals: &[[u32; 2]]) {
    let zero = R::from_f64(0.0);
    for (b, &[start, length]) in blocks.iter_mut().zip(renewals) {
        b.adjacency_start = start;
        b.adjacency_count = length & !layout::RENEW_MOVED;
        if length & layout::RENEW_MOVED != 0 {
            b.travel = zero;
        }
        b.peak_travel = zero;
        b.work = zero;
        b.damping_work = zero;
        b.dashpot_work = zero;
    }
}

/// A contact of the model as its record and run of logical contacts on the device give it: the
/// normal, and the live logical contacts under `keys` (points from `origin` in f32, where they
/// are kept from block 1's centroid); a contact with none has no category or area.
pub(super) fn contact_from_pods<R: Real>(
    c: &mut crate::d3::model::Contact,
    g: &layout::Contact<R>,
    run: &[layout::Logical<R>],
    keys: &[LogicalKind],
    origin: DVec3,
) {
    let f = |x: R| x.to_f64();
    c.normal = DVec3::new(f(g.nx), f(g.ny), f(g.nz));
    c.logical = run
        .iter()
        .zip(keys)
        .filter(|(l, _)| l.live != 0)
        .map(|(l, kind)| Logical {
            kind: *kind,
            point: if super::relative::<R>() { origin + DVec3::new(f(l.px), f(l.py), f(l.pz)) } else { DVec3::new(f(l.px), f(l.py), f(l.pz)) },
            gap: f(l.gap),
            normal_force: f(l.normal_force),
            shear_force: DVec3::new(f(l.sx), f(l.sy), f(l.sz)),
            offset: f(l.offset),
        })
        .collect();
    if c.logical.is_empty() {
        c.category = None;
        c.area = 0.0;
    }
}

/// A splice's sources and keys (`splice_contacts`): for each contact of the new list `contacts`,
/// `layout::SPLICE_FRESH` with its index among the `fresh` ones (indices in the new list,
/// ascending), else its index in the old list of `old_count` contacts, where the kept contacts
/// are the old ones but the `taken` (indices, ascending) in their order; and the start of its
/// run. A kept contact's run is its old one (`old`), a fresh one's its logical contacts'.
/// Made a stretch of kept contacts at a time (one copy of their runs). `moved` says whether a
/// contact is one of the moved blocks': each stretch's ends are checked not to be. The keys are
/// None where they are `old`'s: each fresh contact in the place of the one taken and with its
/// run's keys (a detection that made and dropped nothing and found each contact's logical
/// contacts as the device had them; no copy of the keys then).
pub fn splice_plan(
    contacts: &[Contact],
    fresh: &[usize],
    (taken, old_count): (&[usize], usize),
    old: &Keys,
    moved: impl Fn(&Contact) -> bool,
) -> Result<(Vec<[u32; 2]>, Option<Keys>), String> {
    let n = contacts.len();
    if n - fresh.len() != old_count - taken.len() {
        return Err(format!("GPU: the detection kept {} contacts of {}, the device {} of {}", n - fresh.len(), n, old_count - taken.len(), old_count));
    }
    let same_keys = n == old_count && fresh == taken && fresh.iter().all(|&k| contacts[k].logical.iter().map(|l| l.kind).eq(old.run(k).iter().copied()));
    if same_keys {
        let mut sources: Vec<[u32; 2]> = old.starts[..n].iter().enumerate().map(|(k, &start)| [k as u32, start]).collect();
        for (i, &k) in fresh.iter().enumerate() {
            sources[k][0] = layout::SPLICE_FRESH | i as u32;
        }
        return Ok((sources, None));
    }
    let fresh_logicals: usize = fresh.iter().map(|&k| contacts[k].logical.len()).sum();
    let mut keys = Keys::with_capacity(n, old.logical_count() + fresh_logicals);
    let mut sources = Vec::with_capacity(n);
    let (mut fresh, mut taken) = (fresh.iter().copied().peekable(), taken.iter().copied().peekable());
    // The next contact of the new list, and of the old.
    let (mut p, mut a) = (0usize, 0usize);
    let mut fresh_count = 0u32;
    while p < n {
        if fresh.next_if_eq(&p).is_some() {
            sources.push([layout::SPLICE_FRESH | fresh_count, keys.logical_count() as u32]);
            keys.push(contacts[p].logical.iter().map(|l| l.kind));
            fresh_count += 1;
            p += 1;
            continue;
        }
        while taken.next_if_eq(&a).is_some() {
            a += 1;
        }
        // A stretch of kept contacts: up to the next fresh one in the new list, the next taken
        // one in the old.
        let count = (fresh.peek().copied().unwrap_or(n) - p).min(taken.peek().copied().unwrap_or(old_count) - a);
        if count == 0 || moved(&contacts[p]) || moved(&contacts[p + count - 1]) {
            return Err(format!("GPU: contact {} of the detection is not the device's next kept contact", contacts[p].id));
        }
        keys.extend_runs(old, a, count);
        sources.extend((0..count).map(|i| [(a + i) as u32, keys.starts[p + i]]));
        p += count;
        a += count;
    }
    Ok((sources, Some(keys)))
}

/// The sums of the workgroups' banks, in order, in f64: (friction, released).
fn bank_sum<R: Real>(banked: &[layout::Banked<R>]) -> (f64, f64) {
    banked.iter().fold((0.0, 0.0), |(f, r), b| (f + b.friction.to_f64(), r + b.released.to_f64()))
}

impl GpuBackend {
    /// A partial detection whose transfers are the changed contacts (the module doc): the moved
    /// blocks' contacts read back, stage 7 and the CPU's stage 4 for them, the fresh contacts
    /// spliced into the device's buffers, the block records renewed there, the adjacency
    /// uploaded.
    pub(super) fn detect_spliced<R: Real>(&mut self, model: &mut Model, report: &mut CycleReport) -> Result<(), CycleError> {
        let device = super::device_error;
        let Some(s) = self.state.as_ref() else { return Ok(()) };
        let tol = s.tol;
        let (moved, limit) = super::moved_blocks(model, tol);
        if s.keys.contacts() != model.contacts.len() {
            return Err(CycleError::Setup(format!("GPU: {} contacts on the device, {} in the model", s.keys.contacts(), model.contacts.len())));
        }
        // The moved blocks' contacts, from the adjacency the device holds (its list is the
        // model's): no pass over the list.
        let touched = s.adjacency_host.contacts_of(&moved);
        let (gathered, read) = self.read_touched::<R>(model, &touched).map_err(device)?;
        let old_count = model.contacts.len();
        let before = (model.dissipated.friction, model.dissipated.released);
        let renewal = topology::update_neighbours_kept(model, &moved, &touched, &mut self.kept_grid, (tol, limit));
        report.contacts_created += renewal.created;
        report.contacts_dropped += renewal.dropped;
        report.topology_updates += 1;
        // The contacts renewed: those taken where the list kept its keys, else the moved blocks'
        // in the new list.
        let selected = if renewal.in_place() { touched.clone() } else { topology::contacts_touching(model, |k| moved[k]) };
        cpu::contact_stage_of(model, tol, 0.0, Appearing::Carried, &selected);
        // What the stage booked (logical contacts that went while loaded), on the model's totals.
        let stage = (model.dissipated.friction - before.0, model.dissipated.released - before.1);
        self.host.refreshed += selected.len() as u64;
        self.host.listed += model.contacts.len() as u64;
        self.host.kept_lists += renewal.in_place() as u64;
        cpu::overlap_check_of(model, &selected)?;

        // The new list's sources and keys: a kept contact's run as the device holds it, a fresh
        // one's as the stage found it. The list is in key order, as the old one was, so the
        // kept contacts come in their old order.
        let Some(s) = self.state.as_ref() else { return Ok(()) };
        let (sources, keys) =
            splice_plan(&model.contacts, &selected, (&touched, old_count), &s.keys, |c| moved[c.blocks[0] as usize] || moved[c.blocks[1] as usize])
                .map_err(CycleError::Setup)?;
        let cap = crate::gpu::device::binding_cap(&self.dev);
        let check = |label, item, count| crate::gpu::device::check_fits(label, item, count, cap, R::PRECISION).map_err(device);
        check("contacts", std::mem::size_of::<layout::Contact<R>>(), model.contacts.len())?;
        let keys = keys.map_or_else(|| Rc::clone(&s.keys), Rc::new);
        check("logical contacts", std::mem::size_of::<layout::Logical<R>>(), keys.logical_count())?;
        check("adjacency", 4, 4 * model.contacts.len())?;
        let (fresh_contacts, fresh_logicals, _) = super::contact_pods::<R>(model, selected.iter().map(|&k| &model.contacts[k]));
        // The adjacency: as the device holds it where the list kept its keys, else made anew.
        let adjacency = (!renewal.in_place()).then(|| super::adjacency_pods(model));
        let starts = &adjacency.as_ref().unwrap_or(&s.adjacency_host).starts;
        let renewals: Vec<[u32; 2]> =
            moved.iter().enumerate().map(|(k, &m)| [starts[k], (starts[k + 1] - starts[k]) | if m { layout::RENEW_MOVED } else { 0 }]).collect();
        let (banked, moved_bytes) = self.splice_into_state::<R>((&fresh_contacts, &fresh_logicals), &sources, keys, &renewals, adjacency).map_err(device)?;
        self.host.detection_bytes += read + moved_bytes;

        // The bases: the blocks' terms the model's (read back after the batch, their sums on the
        // device zeroed by `renew_blocks`); the contacts',
        // the bases before plus every accumulator the detection zeroed (those read back, those
        // spliced) and what its stage booked, as a whole upload's.
        let banked = bank_sum(&banked);
        let Some(s) = self.state.as_mut() else { return Ok(()) };
        model.dissipated.friction = s.bases.friction + gathered.0 + banked.0 + stage.0;
        model.dissipated.released = s.bases.released + gathered.1 + banked.1 + stage.1;
        s.bases = super::bases(model);
        self.write_params(model);
        Ok(())
    }

    /// The contacts `at` (indices in the old list, ascending) gathered on the device by
    /// `splice_contacts` and read back into the model; returns their accumulators' sums
    /// (friction, released) and the bytes moved.
    fn read_touched<R: Real>(&self, model: &mut Model, at: &[usize]) -> Result<((f64, f64), u64), GpuError> {
        let Some(s) = self.state.as_ref() else { return Ok(((0.0, 0.0), 0)) };
        let keys = Rc::clone(&s.keys);
        let mut sources = Vec::with_capacity(at.len());
        let mut logical_count = 0u32;
        for &k in at {
            sources.push([k as u32, logical_count]);
            logical_count += keys.run(k).len() as u32;
        }
        if at.is_empty() {
            return Ok(((0.0, 0.0), 0));
        }
        let sizes = [at.len() * std::mem::size_of::<layout::Contact<R>>(), logical_count as usize * std::mem::size_of::<layout::Logical<R>>()];
        let out = [self.output_buffer("d3 gathered contacts", sizes[0] as u64), self.output_buffer("d3 gathered logicals", sizes[1] as u64)];
        let banked = self.splice::<R>((&s.contacts, &s.logicals), None, &sources, (&out[0], &out[1]))?;
        let (contacts, logicals) = self.read_records::<R>((&out[0], at.len()), (&out[1], logical_count as usize))?;
        let origins: Vec<DVec3> = at.iter().map(|&k| super::point_origin::<R>(model, &model.contacts[k])).collect();
        for ((&k, g), origin) in at.iter().zip(&contacts).zip(origins) {
            let run = &logicals[g.logical_start as usize..(g.logical_start + g.logical_count) as usize];
            contact_from_pods(&mut model.contacts[k], g, run, keys.run(k), origin);
        }
        let bytes = (sources.len() * 8 + sizes[0] + sizes[1] + banked.len() * std::mem::size_of::<layout::Banked<R>>()) as u64;
        Ok((bank_sum(&banked), bytes))
    }

    /// The state's contact and logical buffers made anew by `splice_contacts` from themselves and
    /// the `fresh` contacts as `sources` says (under `keys`), the blocks renewed by
    /// `renew_blocks` from `renewals` and the adjacency uploaded where it changed (Some), the
    /// bind group renewed; returns the banks and the bytes moved.
    fn splice_into_state<R: Real>(
        &mut self,
        fresh: (&[layout::Contact<R>], &[layout::Logical<R>]),
        sources: &[[u32; 2]],
        keys: Rc<Keys>,
        renewals: &[[u32; 2]],
        adjacency: Option<super::Adjacency>,
    ) -> Result<(Vec<layout::Banked<R>>, u64), GpuError> {
        let storage_usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let sizes =
            [(sources.len() * std::mem::size_of::<layout::Contact<R>>()) as u64, (keys.logical_count() * std::mem::size_of::<layout::Logical<R>>()) as u64];
        // The output: the buffers the last splice left, where they hold it (the state's two
        // buffers and these take turns), else new ones with room to grow.
        let out = match self.spare_contacts.take() {
            Some((c, l)) if c.size() >= sizes[0] && l.size() >= sizes[1] => (c, l),
            _ => {
                let room = |size: u64| (size + size / 4).min(crate::gpu::device::binding_cap(&self.dev).max(size));
                (self.output_buffer("d3 contacts", room(sizes[0])), self.output_buffer("d3 logicals", room(sizes[1])))
            }
        };
        let fresh_buffers = (
            self.buffer("d3 fresh contacts", bytemuck::cast_slice(fresh.0), wgpu::BufferUsages::STORAGE),
            self.buffer("d3 fresh logicals", bytemuck::cast_slice(fresh.1), wgpu::BufferUsages::STORAGE),
        );
        let Some(s) = self.state.as_ref() else { return Ok((Vec::new(), 0)) };
        let banked = self.splice::<R>((&s.contacts, &s.logicals), Some((&fresh_buffers.0, &fresh_buffers.1)), sources, (&out.0, &out.1))?;
        self.renew(&s.params, &s.blocks, renewals);
        let adjacency_bytes = adjacency.as_ref().map_or(0, |a| std::mem::size_of_val(&a.words[..]));
        let adjacency_buffer = adjacency.as_ref().map(|a| self.buffer("d3 adjacency", bytemuck::cast_slice(&a.words), storage_usage));
        let bind = self.bind(
            s.variant,
            &[&s.params, &s.blocks, &s.vertices, &s.planes, &s.edges, &out.0, &out.1, adjacency_buffer.as_ref().unwrap_or(&s.adjacency)],
            s.sdef.as_ref(),
        );
        let s: &mut State = self.state.as_mut().expect("state");
        let old_contacts = std::mem::replace(&mut s.contacts, out.0);
        let old_logicals = std::mem::replace(&mut s.logicals, out.1);
        if let (Some(buffer), Some(host)) = (adjacency_buffer, adjacency) {
            s.adjacency = buffer;
            s.adjacency_host = host;
        }
        s.bind = bind;
        s.keys = keys;
        self.spare_contacts = Some((old_contacts, old_logicals));
        let bytes = std::mem::size_of_val(fresh.0)
            + std::mem::size_of_val(fresh.1)
            + std::mem::size_of_val(sources)
            + std::mem::size_of_val(renewals)
            + adjacency_bytes
            + banked.len() * std::mem::size_of::<layout::Banked<R>>();
        Ok((banked, bytes as u64))
    }

    /// `renew_blocks` on the device over the first `renewals.len()` records of `blocks` (the
    /// params' block count).
    fn renew(&self, params: &wgpu::Buffer, blocks: &wgpu::Buffer, renewals: &[[u32; 2]]) {
        if renewals.is_empty() {
            return;
        }
        let renewals = self.buffer("d3 renewals", bytemuck::cast_slice(renewals), wgpu::BufferUsages::STORAGE);
        let entries = [
            wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: blocks.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 9, resource: renewals.as_entire_binding() },
        ];
        let groups = (renewals.size() as u32 / 8).div_ceil(workgroup_size());
        self.dispatch_own("renew_blocks", &self.renew_kernel, &entries, groups);
    }

    /// `renew_blocks` on the device on records given here (for the test that holds it against its
    /// twin, [`renew_blocks`]): the records renewed. Err where `R` is not the device's precision.
    pub fn renew_blocks_on_device<R: Real>(&self, blocks: &[layout::Block<R>], renewals: &[[u32; 2]]) -> Result<Vec<layout::Block<R>>, GpuError> {
        if R::PRECISION != self.dev.precision {
            return Err(GpuError::Setup(format!("records in {:?} for kernels in {:?}", R::PRECISION, self.dev.precision)));
        }
        let params = layout::Params::<R> { blocks: renewals.len() as u32, ..super::params::<R>(&Model::default(), 1e-6, 0.0) };
        let params = self.buffer("d3 params", bytemuck::bytes_of(&params), wgpu::BufferUsages::UNIFORM);
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let buffer = self.buffer("d3 blocks", bytemuck::cast_slice(blocks), usage);
        self.renew(&params, &buffer, renewals);
        self.dev.read_pod(&buffer, blocks.len())
    }

    /// A storage buffer of `bytes` the kernels write and the host reads back (at least 512
    /// bytes, as `buffer` makes an empty list: a binding may not be shorter than its struct).
    fn output_buffer(&self, label: &str, bytes: u64) -> wgpu::Buffer {
        self.dev.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(512).next_multiple_of(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// `splice_contacts` on the device: `out` made from `kept` and `fresh` (the kept buffers
    /// where None: a gather) as `sources` says; returns the workgroups' banks.
    fn splice<R: Real>(
        &self,
        kept: (&wgpu::Buffer, &wgpu::Buffer),
        fresh: Option<(&wgpu::Buffer, &wgpu::Buffer)>,
        sources: &[[u32; 2]],
        out: (&wgpu::Buffer, &wgpu::Buffer),
    ) -> Result<Vec<layout::Banked<R>>, GpuError> {
        if sources.is_empty() {
            return Ok(Vec::new());
        }
        let fresh = fresh.unwrap_or(kept);
        let groups = (sources.len() as u32).div_ceil(workgroup_size());
        let bank_bytes = groups as u64 * std::mem::size_of::<layout::Banked<R>>() as u64;
        let bank = self.output_buffer("d3 splice banks", bank_bytes);
        let header = layout::Splice { contacts: sources.len() as u32, ..Default::default() };
        let header = self.buffer("d3 splice", bytemuck::bytes_of(&header), wgpu::BufferUsages::UNIFORM);
        let sources = self.buffer("d3 splice sources", bytemuck::cast_slice(sources), wgpu::BufferUsages::STORAGE);
        let entries = [
            wgpu::BindGroupEntry { binding: 5, resource: out.0.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 6, resource: out.1.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 9, resource: header.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 10, resource: kept.0.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 11, resource: kept.1.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 12, resource: fresh.0.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 13, resource: fresh.1.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 14, resource: sources.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 15, resource: bank.as_entire_binding() },
        ];
        self.dispatch_own("splice_contacts", &self.splice_kernel, &entries, groups);
        self.dev.read_pod(&bank, groups as usize)
    }

    /// `splice_contacts` on the device on records given here (for the test that holds it against
    /// its twin, [`splice_contacts`]): the output's contacts, logical contacts and banks. Err
    /// where `R` is not the device's precision.
    #[allow(clippy::type_complexity)]
    pub fn splice_contacts_on_device<R: Real>(
        &self,
        kept: (&[layout::Contact<R>], &[layout::Logical<R>]),
        fresh: (&[layout::Contact<R>], &[layout::Logical<R>]),
        sources: &[[u32; 2]],
    ) -> Result<(Vec<layout::Contact<R>>, Vec<layout::Logical<R>>, Vec<layout::Banked<R>>), GpuError> {
        if R::PRECISION != self.dev.precision {
            return Err(GpuError::Setup(format!("records in {:?} for kernels in {:?}", R::PRECISION, self.dev.precision)));
        }
        let usage = wgpu::BufferUsages::STORAGE;
        let upload = |label, bytes: &[u8]| self.buffer(label, bytes, usage);
        let kept_buffers = (upload("d3 kept contacts", bytemuck::cast_slice(kept.0)), upload("d3 kept logicals", bytemuck::cast_slice(kept.1)));
        let fresh_buffers = (upload("d3 fresh contacts", bytemuck::cast_slice(fresh.0)), upload("d3 fresh logicals", bytemuck::cast_slice(fresh.1)));
        // The output's logical contacts end where its last run does.
        let count = |&[source, start]: &[u32; 2]| {
            let i = (source & !layout::SPLICE_FRESH) as usize;
            start as usize + if source & layout::SPLICE_FRESH != 0 { fresh.0[i].logical_count } else { kept.0[i].logical_count } as usize
        };
        let logical_count = sources.iter().map(count).max().unwrap_or(0);
        let out = (
            self.output_buffer("d3 contacts", (sources.len() * std::mem::size_of::<layout::Contact<R>>()) as u64),
            self.output_buffer("d3 logicals", (logical_count * std::mem::size_of::<layout::Logical<R>>()) as u64),
        );
        let banked = self.splice::<R>((&kept_buffers.0, &kept_buffers.1), Some((&fresh_buffers.0, &fresh_buffers.1)), sources, (&out.0, &out.1))?;
        let (contacts, logicals) = self.read_records::<R>((&out.0, sources.len()), (&out.1, logical_count))?;
        Ok((contacts, logicals, banked))
    }
}

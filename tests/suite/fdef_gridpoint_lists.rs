//! The zoned blocks' grid-point contact lists (`gpu::fdef::GridPointContacts`, issue 29): each
//! boundary grid point gathers from its own list of its block's contacts rather than walking
//! the block's whole list. The lists are checked against the CPU twin of the force shares
//! (`cpu::zones::force_shares`) on zoned scenes, and a GPU run gathering from them against one
//! walking the block lists, bit for bit.

use crate::common;

use blockdem::udec::contact::gather::AdjacencyEntry;
use blockdem::udec::gpu::fdef::{feature_edge, gridpoint_starts, GridPointContacts, LIST_REACH, WALK_BLOCK_LISTS, WIDE_BOUNDARY};
use blockdem::udec::gpu::layout::NO_INDEX;
use blockdem::udec::model::{BlockKind, Model};
use blockdem::udec::topology::adjacency::Adjacency;
use common::Target;

/// Sample 3 (a heavy rigid block on a zoned one: rigid corners on the zoned block's edges, its
/// grid points on the base), shortened.
fn sample3(cycles: u32) -> String {
    common::sample("udec3_deformable_block.dat").replace("WIND 0 8 0 10\nPLOT\nPRINT BLOCKS\n", "").replace("CYCLE 1000", &format!("CYCLE {cycles}"))
}

/// Two zoned blocks stacked on a fixed rigid base: contacts between zoned blocks on both sides,
/// and boundaries of many grid points.
fn zoned_stack(cycles: u32) -> String {
    format!(
        "START\nPROP MAT=1 DENS=2000 K=1E8 G=6E7 KN=1E9 KS=1E9 FRIC=0.5\nROUND 0.05\nBLOCK (0,0) (0,3) (3,3) (3,0)\nSPLIT 0,1 3,1\nSPLIT 0,2 3,2\n\
         SPLIT 1.3,2 1.3,3\nCHANGE 0 3 1 3 FDEF\nGENERATE 0 3 1 3 AUTO 0.3\nFIX 0 3 0 1\nGRAV 0 -10\nDAMP 0.1 5 MASS\nCYCLE {cycles}\nSTOP\n"
    )
}

/// A rigid block sliding at 20 m/s over a zoned slab on a fixed base, frictionless: the slab's
/// boundary edges (≤ 0.01 m) are well under the update tolerance (¶26: ROUND/4 = 0.025 m), so the
/// slider's corners cross more than `LIST_REACH` of them between two contact updates and
/// `check_fdef_lists` sends the slab's grid points back to walking its whole list (the lists'
/// fallback) until the lists are built again.
fn slide_over_zones(cycles: u32) -> String {
    format!(
        "START\nPROP MAT=1 DENS=2000 K=1E6 G=6E5 KN=1E7 KS=1E7 FRIC=0\nROUND 0.1\nBLOCK (0,0) (0,0.4) (1.2,0.4) (1.2,0)\n\
         SPLIT 0,0.1 1.2,0.1\nSPLIT 0,0.2 1.2,0.2\nSPLIT 0.3,0.2 0.3,0.4\nSPLIT 0.6,0.2 0.6,0.4\nDELETE 0 0.3 0.2 0.4\n\
         DELETE 0.6 1.2 0.2 0.4\nCHANGE 0 1.2 0.1 0.2 FDEF\nGENERATE 0 1.2 0.1 0.2 AUTO 0.01\nFIX 0 1.2 0 0.1\nGRAV 0 -10\n\
         VELOCITY 0.3 0.6 0.2 0.4 20 0\nCYCLE {cycles}\nSTOP\n"
    )
}

fn cpu_run(deck: &str) -> Model {
    blockdem::scenes::run_deck_on(deck, Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap()
}

/// The lists of `m`'s zoned blocks from word 0 (offsets, entries, each contact's feature edge).
fn lists_of(m: &Model) -> (Vec<u32>, Vec<u32>, Adjacency) {
    let adjacency = Adjacency::build(m.blocks.len(), &m.contacts);
    let starts = gridpoint_starts(m);
    let n_gp: usize = (0..m.blocks.len()).filter(|&b| starts[b] != NO_INDEX).map(|b| m.fdef[b].gridpoints.len()).sum();
    let words = GridPointContacts::of(m, &adjacency.offsets, &adjacency.entries, &starts, n_gp, 0).words;
    (words, starts, adjacency)
}

/// Every boundary grid point's list is the subsequence of its block's list (in its order) that
/// holds every contact the CPU's force shares give it a part of: block 1's corner on its grid
/// point, and on block 2 the grid points of every feature within `LIST_REACH` edges of the
/// contact's feature (the contact stage moves it one edge a cycle at most), taken at the
/// feature's middle (both shares non-zero). Interior grid points have no list, each contact's
/// feature edge follows the lists, and the lists are shorter than the walks they replace.
fn lists_hold_every_contact_that_acts(m: &Model) {
    let (words, starts, adjacency) = lists_of(m);
    let n_gp: usize = (0..m.blocks.len()).filter(|&b| starts[b] != NO_INDEX).map(|b| m.fdef[b].gridpoints.len()).sum();
    let list = |g: usize| &words[words[g] as usize..words[g + 1] as usize];
    let (mut listed, mut walked, mut checked) = (0usize, 0usize, 0usize);
    for b in (0..m.blocks.len()).filter(|&b| starts[b] != NO_INDEX) {
        let blk = &m.blocks[b];
        let f = &m.fdef[b];
        let n = f.boundary;
        let cs = blk.corner_start;
        let corners = &m.corners[cs as usize..(cs + blk.corner_count) as usize];
        let entries: Vec<u32> = adjacency.entries(b).iter().map(|&e| bytemuck::cast(e)).collect();
        let g0 = starts[b] as usize;
        for k in 0..f.gridpoints.len() {
            let l = list(g0 + k);
            if k as u32 >= n {
                assert!(l.is_empty(), "block {b}: interior grid point {k} has a list");
                continue;
            }
            // A subsequence of the block's list, in its order.
            let mut at = 0usize;
            for w in l {
                let p = entries[at..].iter().position(|e| e == w).unwrap_or_else(|| panic!("block {b}, grid point {k}: entry {w} out of the block's order"));
                at += p + 1;
            }
            listed += l.len();
            walked += entries.len();
        }
        for &w in &entries {
            let e: AdjacencyEntry = bytemuck::cast(w);
            let c = &m.contacts[e.contact() as usize];
            let mut acts = Vec::new();
            if e.side() == 0 {
                acts.push((c.corner - cs) as usize);
            } else {
                let j0 = feature_edge(c.feature, n);
                for j in (0..n).filter(|&j| (j + n - j0) % n <= LIST_REACH || (j0 + n - j) % n <= LIST_REACH) {
                    let a = corners[j as usize].position;
                    let (d, len) = (corners[j as usize].edge_dir, corners[j as usize].edge_length);
                    let mid = [a[0] + 0.5 * len * d[0], a[1] + 0.5 * len * d[1]];
                    for feature in [2 * j, 2 * j + 1] {
                        let shares = blockdem::udec::cpu::zones::force_shares([c.corner, feature], 1, cs, corners, mid);
                        acts.extend(shares.iter().filter(|(_, w)| *w != 0.0).map(|(g, _)| *g));
                    }
                }
            }
            for g in acts {
                assert!(list(g0 + g).contains(&w), "block {b}: contact {} (side {}) acts on grid point {g}, not in its list", e.contact(), e.side());
                checked += 1;
            }
        }
    }
    assert_eq!(words[n_gp] as usize + m.contacts.len(), words.len());
    let wide: Vec<u32> = (0..m.blocks.len()).filter(|&b| starts[b] != NO_INDEX && m.fdef[b].boundary > WIDE_BOUNDARY).map(|b| b as u32).collect();
    assert_eq!(words[n_gp + 1] as usize, wide.len());
    assert_eq!(&words[n_gp + 2..n_gp + 2 + wide.len()], &wide[..], "the wide blocks");
    assert_eq!(words[0] as usize, n_gp + 2 + wide.len(), "the entries after the wide blocks");
    for (k, c) in m.contacts.iter().enumerate() {
        let b2 = c.block2 as usize;
        let want = if starts[b2] == NO_INDEX { 0 } else { feature_edge(c.feature, m.fdef[b2].boundary) };
        assert_eq!(words[words[n_gp] as usize + k], want, "contact {k}'s feature edge");
    }
    assert!(checked > 0, "no contact on a zoned block");
    assert!(listed < walked, "the lists ({listed} entries) are no shorter than the walks ({walked})");
}

/// The sliding scene does reach the lists' fallback: run on the CPU a cycle at a time, some
/// contact's feature on the slab lies `LIST_REACH` edges or more from where it was at the last
/// contact update (where the lists were built), which is where `check_fdef_lists` clears the
/// slab's `listed` flags; the GPU runs of `lists_gather_as_the_walk` take that path.
#[test]
fn a_sliding_corner_outruns_the_lists_between_updates() {
    use blockdem::udec::backend::Backend as _;
    let mut m = cpu_run(&slide_over_zones(1));
    let slab = (0..m.blocks.len()).find(|&b| m.fdef_of(b).is_some_and(|f| !f.zones.is_empty())).expect("the zoned slab");
    let n = m.fdef[slab].boundary;
    assert!(n > 2 * LIST_REACH + 2, "the slab's boundary ({n} grid points) is long enough to have lists");
    // Each contact's feature edge on the slab, by contact id.
    let homes = |m: &Model| -> std::collections::HashMap<u32, u32> {
        m.contacts.iter().filter(|c| c.block2 as usize == slab).map(|c| (c.id, feature_edge(c.feature, n))).collect()
    };
    let mut built = homes(&m);
    let mut cpu = blockdem::udec::cpu::CpuBackend::new();
    let (mut farthest, mut updates) = (0u32, 0u32);
    for _ in 0..599 {
        let report = cpu.run(&mut m, 1, &mut |_| true).expect("the slide runs");
        if report.topology_updates > 0 {
            updates += 1;
            built = homes(&m);
            continue;
        }
        for (id, j) in homes(&m) {
            if let Some(&j0) = built.get(&id) {
                let d = j.abs_diff(j0);
                farthest = farthest.max(d.min(n - d));
            }
        }
    }
    assert!(!built.is_empty(), "the slider's corners touch the slab");
    assert!(updates >= 2, "contact updates while sliding: {updates}");
    eprintln!("{updates} contact updates, a feature {farthest} edges from its lists at most");
    assert!(farthest >= LIST_REACH, "a feature moved {farthest} edges between updates, under the lists' reach {LIST_REACH}");
}

/// The lists' reach and the wide blocks' bound are the kernels' (zones.wgsl,
/// geometry_update.wgsl).
#[test]
fn the_kernels_take_the_same_reach_and_bound() {
    let src = |file| blockdem::udec::gpu::shaders::source(file, blockdem::udec::gpu::Precision::F32).unwrap();
    assert!(src("zones").contains(&format!("const LIST_REACH: u32 = {LIST_REACH}u;")));
    assert!(src("law_of_motion").contains(&format!("const WIDE_BOUNDARY: u32 = {WIDE_BOUNDARY}u;")));
}

#[test]
fn sample_3_lists_hold_every_contact_that_acts() {
    let m = cpu_run(&sample3(300));
    assert!(m.blocks.iter().any(|b| b.kind == BlockKind::FullyDeformable));
    lists_hold_every_contact_that_acts(&m);
}

#[test]
fn zoned_stack_lists_hold_every_contact_that_acts() {
    let m = cpu_run(&zoned_stack(200));
    let zoned = (0..m.blocks.len()).filter(|&b| m.fdef_of(b).is_some_and(|f| !f.zones.is_empty())).count();
    assert_eq!(zoned, 3);
    assert!(m.contacts.iter().any(|c| m.fdef_of(c.block1 as usize).is_some() && m.fdef_of(c.block2 as usize).is_some()), "contacts between zoned blocks");
    lists_hold_every_contact_that_acts(&m);
}

/// The switch of the walk is process-wide: the GPU runs take turns.
static TURNS: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// A GPU run whose grid points gather from their own lists against one walking their blocks'
/// whole lists (`WALK_BLOCK_LISTS`): the same zones, grid points, blocks and contacts bit for bit.
fn lists_gather_as_the_walk(t: &Target) {
    let _turn = TURNS.lock().unwrap_or_else(|e| e.into_inner());
    for (deck, cycles) in [(sample3(300), 300), (zoned_stack(300), 300), (slide_over_zones(600), 600)] {
        WALK_BLOCK_LISTS.store(true, std::sync::atomic::Ordering::Relaxed);
        let walked = std::panic::catch_unwind(|| t.run(&deck));
        WALK_BLOCK_LISTS.store(false, std::sync::atomic::Ordering::Relaxed);
        let walked = walked.unwrap_or_else(|_| panic!("{}: the walk's run failed", t.name()));
        let listed = t.run(&deck);
        assert_eq!(listed.cycle, cycles);
        assert_eq!(listed.fdef, walked.fdef, "{}: zones and grid points", t.name());
        assert_eq!(listed.blocks, walked.blocks, "{}: blocks", t.name());
        assert_eq!(listed.contacts, walked.contacts, "{}: contacts", t.name());
    }
}

mod vulkan_f32 {
    #[test]
    fn lists_gather_as_the_walk() {
        if let Some(t) = crate::common::Target::gpu("vulkan", blockdem::udec::gpu::Precision::F32) {
            super::lists_gather_as_the_walk(&t)
        }
    }
}

mod vulkan_f64 {
    #[test]
    fn lists_gather_as_the_walk() {
        if let Some(t) = crate::common::Target::gpu("vulkan", blockdem::udec::gpu::Precision::F64) {
            super::lists_gather_as_the_walk(&t)
        }
    }
}

mod gl_f32 {
    #[test]
    fn lists_gather_as_the_walk() {
        if let Some(t) = crate::common::Target::gpu("gl", blockdem::udec::gpu::Precision::F32) {
            super::lists_gather_as_the_walk(&t)
        }
    }
}

//! PRINT tables in the layouts of the 1985 listings (print-formats.md, "UDEC PRINT tables").
//!
//! Each table starts with a blank line and its title, then one or two heading lines, then one
//! row per item. Columns are fixed-width and right-aligned; numbers are written by [`fmt_e`] so a
//! table reads like a UDEC listing and parses back with `str::parse::<f64>()`. No line of a table
//! exceeds 132 columns, the width of a line printer.
//!
//! Block, contact and domain numbers are the stable ids (`Block::id`, `Contact::id`, `Domain::id`), never vector
//! indices: in 1985 they were memory addresses, here they do not change when other blocks are
//! deleted. Corner numbers are the global corner index + 1.

use std::fmt::{self, Write as _};
use std::io::{self, Write};

use super::format::{fmt_e, push_col_e, NUMBER_WIDTH};
use crate::udec::deck::PrintItem;
use crate::udec::model::domain::{Domain, DomainKind, DomainLink, Domains, MIN_AREA_FRACTION};
use crate::udec::model::{Block, BlockKind, Contact, ContactKind, Model};

/// One heading group: a title over one or more sub-columns of equal width. A single-column
/// title is right-aligned like the numbers beneath it; a title over several columns is centred
/// over them, as "CENTROID COORDS." sits over X and Y.
struct Group {
    title: &'static str,
    subs: &'static [&'static str],
    width: usize,
}

const fn single(title: &'static str, width: usize) -> Group {
    Group { title, subs: &[""], width }
}

const fn numbers(title: &'static str, subs: &'static [&'static str]) -> Group {
    Group { title, subs, width: NUMBER_WIDTH }
}

/// Writes the blank line, the title and the two heading lines of a table.
fn write_headings(out: &mut dyn Write, title: &str, groups: &[Group]) -> io::Result<()> {
    let mut line1 = String::new();
    let mut line2 = String::new();
    for g in groups {
        let span = g.width * g.subs.len();
        if g.subs.len() == 1 {
            line1.push_str(&format!("{:>span$}", g.title));
        } else {
            // Centre the title, leaving the leading column separator space out of the count.
            line1.push(' ');
            line1.push_str(&format!("{:^w$}", g.title, w = span - 1));
        }
        for s in g.subs {
            line2.push_str(&format!("{:>w$}", s, w = g.width));
        }
    }
    writeln!(out)?;
    writeln!(out, "{title}")?;
    writeln!(out)?;
    writeln!(out, "{}", line1.trim_end())?;
    let line2 = line2.trim_end();
    if !line2.is_empty() {
        writeln!(out, "{line2}")?;
    }
    Ok(())
}

/// The id of the block at `index`, or `?` when there is none (a corrupt model prints what it
/// can); formatted in place, honouring the column's width.
fn block_id(model: &Model, index: u32) -> BlockId {
    BlockId(model.blocks.get(index as usize).map(|b| b.id))
}

struct BlockId(Option<u32>);

impl fmt::Display for BlockId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(id) => fmt::Display::fmt(&id, f),
            None => f.pad("?"),
        }
    }
}

/// The bracketed type line printed under a block, `(RIGID)`, `(SDEF)` or `(FDEF)`.
fn type_label(kind: BlockKind) -> &'static str {
    match kind {
        BlockKind::Rigid => "(RIGID)",
        BlockKind::SimplyDeformable => "(SDEF)",
        BlockKind::FullyDeformable => "(FDEF)",
    }
}

const BLOCK_GROUPS: [Group; 8] = [
    single("BLOCK", 8),
    single("MAT", 5),
    single("CONST", 6),
    numbers("CENTROID COORDS.", &["X", "Y"]),
    numbers("MASS", &[""]),
    numbers("POL. MOM.", &[""]),
    numbers("X,Y,THETA VELOCITIES", &["X", "Y", "THETA"]),
    numbers("X,Y,THETA FORCES", &["X", "Y", "THETA"]),
];

/// PRINT BLOCKS: one row per block (centroid, mass, polar moment, velocities, forces), and under
/// it the block's type in brackets, followed by `FIXED` for a fixed block. Under a
/// simply-deformable block, the three tensors of its extension array (print-formats.md), each as
/// 11 12 21 22: `ED` the strain rate, `SI` the internal stress, `SA` the applied stress times the
/// block's area.
/// Under a zoned fully-deformable block, its zone table (ZONE, GRID-POINTS, SIGMA-11, SIGMA-12,
/// SIGMA-22, MASS) and grid-point table (GRID-POINT, CORNER-LINK, X, Y, X,Y VELOCITIES, X,Y
/// FORCES, MASS), numbered from 1 within the block.
pub fn print_blocks(model: &Model, out: &mut dyn Write) -> io::Result<()> {
    write_headings(out, "BLOCK DATA", &BLOCK_GROUPS)?;
    let mut line = String::new();
    for (k, b) in model.blocks.iter().enumerate() {
        let numbers = [b.centroid[0], b.centroid[1], b.mass, b.inertia, b.velocity[0], b.velocity[1], b.angular_velocity, b.force[0], b.force[1], b.moment];
        line.clear();
        let _ = write!(line, "{:>8}{:>5}{:>6}", b.id, b.material, b.constitutive);
        numbers.iter().for_each(|&x| push_col_e(&mut line, x));
        writeln!(out, "{line}")?;
        let fixed = if b.fixed { " FIXED" } else { "" };
        writeln!(out, "{:>8}{fixed}", type_label(b.kind))?;
        if let Some(s) = model.sdef_of(k) {
            let (e, t, a) = (s.strain_rate, s.stress, s.applied);
            for (label, row) in
                [("ED11 ED12 ED21 ED22", [e[0], e[1], e[1], e[2]]), ("SI11 SI12 SI21 SI22", [t[0], t[1], t[1], t[2]]), ("SA11 SA12 SA21 SA22", a)]
            {
                line.clear();
                let _ = write!(line, "{:>27}", label);
                row.iter().for_each(|&x| push_col_e(&mut line, x));
                writeln!(out, "{line}")?;
            }
        }
        if let Some(f) = model.fdef_of(k).filter(|f| !f.zones.is_empty()) {
            print_zones(f, out)?;
        }
    }
    Ok(())
}

/// The zone and grid-point tables of one fully-deformable block (print-formats.md).
fn print_zones(f: &crate::udec::model::fdef::Fdef, out: &mut dyn Write) -> io::Result<()> {
    let mut line = String::new();
    writeln!(out)?;
    writeln!(out, "{:>8}{:>18}{:>11}{:>11}{:>11}{:>11}", "ZONE", "GRID-POINTS", "SIGMA-11", "SIGMA-12", "SIGMA-22", "MASS")?;
    for (z, zone) in f.zones.iter().enumerate() {
        line.clear();
        let [a, b, c] = zone.gridpoints.map(|g| g + 1);
        let _ = write!(line, "{:>8}{a:>6}{b:>6}{c:>6}", z + 1);
        [zone.stress[0], zone.stress[1], zone.stress[2], zone.mass].iter().for_each(|&x| push_col_e(&mut line, x));
        writeln!(out, "{line}")?;
    }
    writeln!(out)?;
    writeln!(out, "{:>10}{:>12}{:>11}{:>11}{:>22}{:>22}{:>11}", "GRID-POINT", "CORNER-LINK", "X", "Y", "X,Y VELOCITIES", "X,Y FORCES", "MASS")?;
    for (k, g) in f.gridpoints.iter().enumerate() {
        line.clear();
        let link = if k < f.boundary as usize { k + 1 } else { 0 };
        let _ = write!(line, "{:>10}{link:>12}", k + 1);
        [g.position[0], g.position[1], g.velocity[0], g.velocity[1], g.force[0], g.force[1], g.mass].iter().for_each(|&x| push_col_e(&mut line, x));
        writeln!(out, "{line}")?;
    }
    writeln!(out)?;
    Ok(())
}

const CONTACT_GROUPS: [Group; 9] = [
    single("CONTACT", 8),
    single("BLOCK1", 7),
    single("BLOCK2", 7),
    single("MAT", 5),
    single("CONST", 6),
    numbers("X,Y COORDS.", &["X", "Y"]),
    numbers("FORCE", &["NORMAL", "SHEAR"]),
    numbers("DISPLACEMENT", &["NORMAL", "SHEAR"]),
    Group { title: "  KIND", subs: &[""], width: 0 },
];

/// A contact's kind as the linked lists name it, seen from the block that owns the corner.
fn kind_label(kind: ContactKind) -> &'static str {
    match kind {
        ContactKind::CornerEdge => "CORNER/EDGE",
        ContactKind::CornerCorner => "CORNER/CORNER",
    }
}

/// Appends an unsigned number right-aligned in `width`, or blanks for 0: a contact whose joint
/// material or constitutive number was never given shows no number (Appendix A, SPLIT).
fn push_blank_if_zero(line: &mut String, n: u32, width: usize) {
    if n == 0 {
        let _ = write!(line, "{:width$}", "");
    } else {
        let _ = write!(line, "{n:>width$}");
    }
}

/// PRINT CONTACTS: one row per contact with the two block ids (block 1 owns the corner), the
/// contact point, normal force (compression positive), shear force, normal displacement (the
/// gap; overlap negative, as UDEC printed it), accumulated shear displacement and the kind; a
/// joint (Appendix A ¶5) is marked `JOINT L=` with the length of joint it carries (half the
/// common length of the faces in opposition) after the kind.
pub fn print_contacts(model: &Model, out: &mut dyn Write) -> io::Result<()> {
    write_headings(out, "CONTACT DATA", &CONTACT_GROUPS)?;
    let mut line = String::new();
    for c in &model.contacts {
        line.clear();
        let _ = write!(line, "{:>8}{:>7}{:>7}", c.id, block_id(model, c.block1), block_id(model, c.block2));
        push_blank_if_zero(&mut line, c.material, 5);
        push_blank_if_zero(&mut line, c.constitutive, 6);
        for x in [c.point[0], c.point[1], c.normal_force, c.shear_force, c.gap, c.shear_displacement] {
            push_col_e(&mut line, x);
        }
        line.push_str("  ");
        line.push_str(kind_label(c.kind));
        if c.joint_length > 0.0 {
            // After the 1985 row, as its notes are: a joint (¶5) and the length it carries.
            let _ = write!(line, " JOINT L={}", fmt_e(c.joint_length));
        }
        if let Some(note) = other_view_note(model, c) {
            line.push_str(&note);
        }
        writeln!(out, "{line}")?;
    }
    Ok(())
}

/// For the view of a corner–corner touch that does not carry its force (`Model::counts_force`:
/// each touch of two rounded corners is seen from both blocks, and only one view counts, so
/// its force is not summed twice), a note naming the contact that does: the other row of the
/// pair reads zero force and an overlap, which looked like a contact gone wrong.
fn other_view_note(model: &Model, c: &crate::udec::model::Contact) -> Option<String> {
    let (n, nc) = (model.blocks.len(), model.corners.len());
    if c.block1 as usize >= n || c.block2 as usize >= n || c.corner as usize >= nc || model.counts_force(c) {
        return None;
    }
    // The other view: from block 2, at block 2's corner this view's feature names, facing this
    // contact's corner.
    let start1 = model.blocks[c.block1 as usize].corner_start;
    let start2 = model.blocks[c.block2 as usize].corner_start;
    let partner = model.contacts.iter().find(|d| {
        d.block1 == c.block2
            && d.block2 == c.block1
            && d.corner == start2 + c.feature / 2
            && d.feature / 2 == c.corner.wrapping_sub(start1)
            && (d.corner as usize) < nc
            && model.counts_force(d)
    });
    Some(match partner {
        Some(d) => format!(" (OTHER VIEW: FORCE IN CONTACT {})", d.id),
        None => " (OTHER VIEW: FORCE COUNTED ONCE)".to_string(),
    })
}

/// Coordinate pairs per line of the corner table: 12 + 5 × 22 = 122 columns.
const PAIRS_PER_LINE: usize = 5;

/// PRINT CORNERS: for each block, `BLOCK n` and then its corners' x y pairs counter-clockwise,
/// continued on indented lines after five pairs.
pub fn print_corners(model: &Model, out: &mut dyn Write) -> io::Result<()> {
    writeln!(out)?;
    writeln!(out, "CORNER COORDINATES (IN X,Y ORDER)")?;
    writeln!(out)?;
    for (b, block) in model.blocks.iter().enumerate() {
        let corners = corners_of(model, b);
        let mut prefix = format!("BLOCK {:>6}", block.id);
        if corners.is_empty() {
            writeln!(out, "{prefix}")?;
        }
        for chunk in corners.chunks(PAIRS_PER_LINE) {
            let mut line = std::mem::replace(&mut prefix, " ".repeat(12));
            for c in chunk {
                push_col_e(&mut line, c.position[0]);
                push_col_e(&mut line, c.position[1]);
            }
            writeln!(out, "{line}")?;
        }
    }
    Ok(())
}

/// Block `b`'s corners, or none when its range lies outside `Model::corners` (a corrupt model
/// prints what it can instead of panicking).
fn corners_of(model: &Model, b: usize) -> &[crate::udec::model::Corner] {
    let blk: &Block = &model.blocks[b];
    let start = blk.corner_start as usize;
    let end = start.saturating_add(blk.corner_count as usize);
    model.corners.get(start..end).unwrap_or(&[])
}

/// One entry of a block's linked list: a contact and how this block sees it.
struct ListedContact<'a> {
    contact: &'a Contact,
    label: &'static str,
    /// Position along the edge, for ordering several contacts on one edge.
    along: f64,
}

/// PRINT LIST: for each block, going counter-clockwise around it, each corner
/// (`CORNER n, BLOCK id`) and after it the contacts at that corner and then those on the edge to
/// the next corner, in order along the edge.
///
/// A contact at a corner is one where this block owns the corner (`CORNER/EDGE`,
/// `CORNER/CORNER`) or where another block's corner touches this corner's rounding arc
/// (`CORNER/CORNER`). A contact on the edge is another block's corner touching this block's
/// straight edge, printed `EDGE/CORNER` because this block is block 2.
pub fn print_block_lists(model: &Model, out: &mut dyn Write) -> io::Result<()> {
    writeln!(out)?;
    writeln!(out, "BLOCK LINKED LISTS")?;
    // Each block's contacts in the list's order, found by one sort rather than a scan of every
    // contact for each block (which made the table quadratic: 316 s for a 10⁵-block wall).
    let mut by_block: Vec<(u32, u32)> = Vec::with_capacity(2 * model.contacts.len());
    for (i, c) in model.contacts.iter().enumerate() {
        by_block.push((c.block1, i as u32));
        if c.block2 != c.block1 {
            by_block.push((c.block2, i as u32));
        }
    }
    by_block.sort_unstable();
    for (b, block) in model.blocks.iter().enumerate() {
        let first = by_block.partition_point(|&(k, _)| (k as usize) < b);
        let end = by_block.partition_point(|&(k, _)| (k as usize) <= b);
        let corners = corners_of(model, b);
        let n = corners.len();
        // at_corner[k] and on_edge[k] for local corner k; contacts that name a corner or feature
        // outside the block go to `unplaced`, printed at the end rather than lost.
        let mut at_corner: Vec<Vec<ListedContact>> = (0..n).map(|_| Vec::new()).collect();
        let mut on_edge: Vec<Vec<ListedContact>> = (0..n).map(|_| Vec::new()).collect();
        let mut unplaced = Vec::new();
        for &(_, i) in &by_block[first..end] {
            let c = &model.contacts[i as usize];
            if c.block1 as usize == b {
                let entry = ListedContact { contact: c, label: kind_label(c.kind), along: 0.0 };
                let k = (c.corner as usize).wrapping_sub(block.corner_start as usize);
                match at_corner.get_mut(k) {
                    Some(list) => list.push(entry),
                    None => unplaced.push(entry),
                }
            } else if c.block2 as usize == b {
                let label = match c.kind {
                    ContactKind::CornerEdge => "EDGE/CORNER",
                    ContactKind::CornerCorner => "CORNER/CORNER",
                };
                let k = (c.feature / 2) as usize;
                if k >= n {
                    unplaced.push(ListedContact { contact: c, label, along: 0.0 });
                } else if c.feature % 2 == 0 {
                    at_corner[k].push(ListedContact { contact: c, label, along: 0.0 });
                } else {
                    let [p, q] = [corners[k].position, corners[(k + 1) % n].position];
                    let along = (c.point[0] - p[0]) * (q[0] - p[0]) + (c.point[1] - p[1]) * (q[1] - p[1]);
                    on_edge[k].push(ListedContact { contact: c, label, along });
                }
            }
        }
        writeln!(out)?;
        writeln!(out, "BLOCK {} {}", block.id, type_label(block.kind))?;
        for k in 0..n {
            // R-LINK: the next corner of the block's circular corner list (counter-clockwise),
            // as the 1985 list printed it.
            writeln!(out, "   CORNER {}, BLOCK {}, R-LINK {}", block.corner_start as usize + k + 1, block.id, block.corner_start as usize + (k + 1) % n + 1)?;
            at_corner[k].sort_by_key(|e| e.contact.id);
            on_edge[k].sort_by(|a, b| a.along.total_cmp(&b.along).then(a.contact.id.cmp(&b.contact.id)));
            for e in at_corner[k].iter().chain(&on_edge[k]) {
                write_list_contact(model, e, out)?;
            }
        }
        for e in &unplaced {
            write_list_contact(model, e, out)?;
        }
    }
    Ok(())
}

fn write_list_contact(model: &Model, e: &ListedContact, out: &mut dyn Write) -> io::Result<()> {
    let c = e.contact;
    writeln!(out, "      CONTACT {}, BLOCK1 {}, BLOCK2 {} {}", c.id, block_id(model, c.block1), block_id(model, c.block2), e.label)
}

/// PRINT ENERGY (an extension): kinetic energy of the blocks, ½ m |v|² + ½ I ω², and the work
/// done by gravity and loads since START.
pub fn print_energy(model: &Model, out: &mut dyn Write) -> io::Result<()> {
    let kinetic: f64 = model.blocks.iter().map(|b| b.kinetic_energy()).sum();
    writeln!(out)?;
    writeln!(out, "ENERGY")?;
    writeln!(out)?;
    writeln!(out, "   KINETIC ENERGY   = {}", fmt_e(kinetic))?;
    writeln!(out, "   EXTERNAL WORK    = {}", fmt_e(model.external_work))?;
    Ok(())
}

/// The note after a domain's row and beside its name in the linked lists.
fn domain_label(d: &Domain) -> String {
    let mut label = match d.kind {
        DomainKind::Outer => "(OUTER BOUNDARY)".to_string(),
        DomainKind::Joint => format!("JOINT L={}", fmt_e(d.length)),
        DomainKind::Regular => String::new(),
    };
    if d.fixed {
        label.push_str(if label.is_empty() { "FIXED" } else { " FIXED" });
    }
    label
}

/// Writes the title of a domain table and `(NONE IN THIS MODEL)` when the model has no domains
/// built (the executor builds them before it prints them); returns them otherwise.
fn domains_or_none<'a>(model: &'a Model, out: &mut dyn Write, title: &str) -> io::Result<Option<&'a Domains>> {
    if model.domains.is_none() {
        writeln!(out)?;
        writeln!(out, "{title}")?;
        writeln!(out, "   (NONE IN THIS MODEL)")?;
    }
    Ok(model.domains.as_ref())
}

const DOMAIN_GROUPS: [Group; 4] =
    [single("DOMAIN", 8), numbers("PORE", &["PRESSURE"]), numbers("VOLUME", &[""]), Group { title: "  MAXIMUM", subs: &["DISPLACEMENT"], width: 14 }];

/// PRINT DOMAINS: one row per domain (Appendix A ¶6–7): its id, pore pressure, volume (the area
/// the fluid calculation uses: the void's, a joint's a·l, never below the minimum; 0 for the
/// unbounded outer domain) and the largest displacement of a block around it since its last
/// contact update, then `(OUTER BOUNDARY)` for the outer domain, `JOINT L=` and the joint's
/// length for the void of an edge-to-edge contact, and `FIXED` for a pressure PFIX holds.
pub fn print_domains(model: &Model, out: &mut dyn Write) -> io::Result<()> {
    let Some(domains) = domains_or_none(model, out, "DOMAIN DATA")? else {
        return Ok(());
    };
    write_headings(out, "DOMAIN DATA", &DOMAIN_GROUPS)?;
    let mut line = String::new();
    for d in &domains.list {
        line.clear();
        let _ = write!(line, "{:>8}", d.id);
        push_col_e(&mut line, d.pressure);
        push_col_e(&mut line, d.area);
        line.push_str("   ");
        push_col_e(&mut line, d.max_displacement);
        let label = domain_label(d);
        if !label.is_empty() {
            line.push_str("  ");
            line.push_str(&label);
        }
        writeln!(out, "{line}")?;
    }
    let why = match domains.given_min_area {
        Some(_) => "SET DAMIN".to_string(),
        None => format!("{} OF THE AVERAGE BLOCK AREA", fmt_e(MIN_AREA_FRACTION)),
    };
    writeln!(out, "   MINIMUM DOMAIN AREA {} ({why})", fmt_e(domains.min_area))
}

/// PRINT DLIST: for each domain, going round its void, each contact it crosses from one block to
/// the next (`CONTACT n, BLOCK1 id, BLOCK2 id` and its kind, as PRINT CONTACTS names them) and
/// the corners it passes between them (`CORNER n, BLOCK id, R-LINK n`, numbered as PRINT LIST
/// numbers them). The outer domain goes round the outside of the assembly; a group of blocks
/// floating in a void, or outside, follows the domain's own circuit.
pub fn print_domain_lists(model: &Model, out: &mut dyn Write) -> io::Result<()> {
    let Some(domains) = domains_or_none(model, out, "DOMAIN LINKED LISTS")? else {
        return Ok(());
    };
    writeln!(out)?;
    writeln!(out, "DOMAIN LINKED LISTS")?;
    for d in &domains.list {
        writeln!(out)?;
        let label = domain_label(d);
        if label.is_empty() {
            writeln!(out, "DOMAIN {}", d.id)?;
        } else {
            writeln!(out, "DOMAIN {} {label}", d.id)?;
        }
        for link in domains.links_of(d) {
            match *link {
                DomainLink::Contact { index, id } => {
                    // The contact at its index when the domains were built, or found by its id.
                    let c = model.contacts.get(index as usize).filter(|c| c.id == id).or_else(|| model.contacts.iter().find(|c| c.id == id));
                    match c {
                        Some(c) => writeln!(
                            out,
                            "   CONTACT {}, BLOCK1 {}, BLOCK2 {} {}",
                            c.id,
                            block_id(model, c.block1),
                            block_id(model, c.block2),
                            kind_label(c.kind)
                        )?,
                        None => writeln!(out, "   CONTACT {id} (GONE)")?,
                    }
                }
                DomainLink::Corner { corner } => {
                    let owner = model.corners.get(corner as usize).map(|c| c.block);
                    let (block, rlink) = match owner.and_then(|b| model.blocks.get(b as usize)) {
                        Some(blk) => {
                            let k = corner.wrapping_sub(blk.corner_start);
                            (BlockId(Some(blk.id)), blk.corner_start as usize + (k as usize + 1) % (blk.corner_count.max(1) as usize) + 1)
                        }
                        None => (BlockId(None), corner as usize + 1),
                    };
                    writeln!(out, "   CORNER {}, BLOCK {block}, R-LINK {rlink}", corner as usize + 1)?
                }
            }
        }
    }
    Ok(())
}

const FLOW_GROUPS: [Group; 7] = [
    single("CONTACT", 8),
    numbers("X,Y COORDS.", &["X", "Y"]),
    numbers("FLOW", &[""]),
    numbers("LENGTH", &[""]),
    numbers("APERTURE", &[""]),
    single("DOM1", 8),
    single("DOM2", 8),
];

/// PRINT FLOWS (Appendix A ¶8): for each contact that separates two domains, its point, the flow
/// from its first domain (DOM1) to its second (DOM2) in the last cycle (volume per unit time per
/// unit thickness), and for a joint its length (the contact's share l_c, the l of the flow law)
/// and aperture; `(NONE IN THIS MODEL)` in a scene without fluid.
pub fn print_flows(model: &Model, out: &mut dyn Write) -> io::Result<()> {
    let title = "FLOW ACROSS CONTACTS OR JOINTS";
    let Some(domains) = model.domains.as_ref().filter(|d| model.fluid.is_some() && !d.flows.is_empty()) else {
        writeln!(out)?;
        writeln!(out, "{title}")?;
        return writeln!(out, "   (NONE IN THIS MODEL)");
    };
    write_headings(out, title, &FLOW_GROUPS)?;
    let mut line = String::new();
    for (k, c) in model.contacts.iter().enumerate() {
        let (Some(&[d0, d1]), Some(f)) = (domains.sides.get(k), domains.flows.get(k)) else { continue };
        if d0 == crate::udec::model::domain::NO_DOMAIN {
            continue;
        }
        line.clear();
        let _ = write!(line, "{:>8}", c.id);
        for x in [c.point[0], c.point[1], f.flow, f.length, f.aperture] {
            push_col_e(&mut line, x);
        }
        let _ = write!(line, "{:>8}{:>8}", domains.list[d0 as usize].id, domains.list[d1 as usize].id);
        writeln!(out, "{line}")?;
    }
    Ok(())
}

/// Prints one PRINT keyword's table.
pub fn print_item(model: &Model, item: PrintItem, out: &mut dyn Write) -> io::Result<()> {
    match item {
        PrintItem::Blocks => print_blocks(model, out),
        PrintItem::Contacts => print_contacts(model, out),
        PrintItem::Corners => print_corners(model, out),
        PrintItem::List => print_block_lists(model, out),
        PrintItem::Energy => print_energy(model, out),
        PrintItem::Domains => print_domains(model, out),
        PrintItem::DList => print_domain_lists(model, out),
        PrintItem::Flows => print_flows(model, out),
    }
}

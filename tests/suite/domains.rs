//! Domains (issue 30 item 1; SL-85-1 Appendix A ¶6–9): the voids between blocks traced from the
//! contact lists, as PRINT DOMAINS, PRINT DLIST and the state JSON show them, through contact
//! creation and deletion, SPLIT, DELETE and cracking; sample 4 runs to its end. The domains are
//! the CPU topology's on every backend: one scene checks them after cycling on each.

use crate::common;

use blockdem::udec::exec::RunError;
use blockdem::udec::model::domain::{DomainKind, DomainLink, Domains, NO_DOMAIN};
use blockdem::udec::model::geometry::signed_area;
use blockdem::udec::model::Model;
use blockdem::udec::output::state_json;
use common::{every_backend, run_logged, run_ok, sample, Target};

const HEAD: &str = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.05\n";

/// Four blocks around a 1 × 1 hole, each in face contact with the next along 1 m.
const PINWHEEL: &str = "BLOCK 0,0 2,0 2,1 0,1\nBLOCK 2,0 3,0 3,2 2,2\nBLOCK 1,2 3,2 3,3 1,3\nBLOCK 0,1 1,1 1,3 0,3\n";

/// One row of a DOMAIN DATA table.
#[derive(Debug, PartialEq)]
struct Row {
    id: u32,
    pressure: f64,
    volume: f64,
    displacement: f64,
    note: String,
}

/// The rows of every DOMAIN DATA table in a log, table by table.
fn domain_tables(log: &str) -> Vec<Vec<Row>> {
    let mut tables = Vec::new();
    let mut lines = log.lines();
    while let Some(line) = lines.next() {
        if line != "DOMAIN DATA" {
            continue;
        }
        // A blank line and the two heading lines.
        let (_, h1, h2) = (lines.next(), lines.next().unwrap(), lines.next().unwrap());
        assert!(h1.contains("DOMAIN") && h1.contains("PORE") && h1.contains("VOLUME") && h1.contains("MAXIMUM"), "{h1}");
        assert!(h2.contains("PRESSURE") && h2.contains("DISPLACEMENT"), "{h2}");
        let mut rows = Vec::new();
        for row in lines.by_ref() {
            if row.starts_with("   MINIMUM DOMAIN AREA ") && row.ends_with(')') {
                break;
            }
            let f: Vec<&str> = row.split_whitespace().collect();
            rows.push(Row {
                id: f[0].parse().unwrap(),
                pressure: f[1].parse().unwrap(),
                volume: f[2].parse().unwrap(),
                displacement: f[3].parse().unwrap(),
                note: f[4..].join(" "),
            });
        }
        tables.push(rows);
    }
    tables
}

/// The lines of the section of `log` from the line `title` to the next line that is none of
/// its rows (`keep` says which are).
fn section<'a>(log: &'a str, title: &str, keep: impl Fn(&str) -> bool) -> Vec<&'a str> {
    let mut lines = log.lines().skip_while(|l| *l != title).skip(1);
    let mut out = Vec::new();
    for l in lines.by_ref() {
        if l.is_empty() || keep(l) {
            out.push(l);
        } else {
            break;
        }
    }
    out
}

/// The contact rows of the last CONTACT DATA table: id → (block 1, block 2).
fn contact_table(log: &str) -> std::collections::HashMap<u32, (String, String)> {
    let start = log.rfind("CONTACT DATA").expect("a contact table");
    log[start..]
        .lines()
        .skip(4)
        .take_while(|l| !l.is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            (f[0].parse().unwrap(), (f[1].to_string(), f[2].to_string()))
        })
        .collect()
}

/// The invariants of a built set: each contact that links domains is crossed twice in all, by
/// the domains its sides name; exactly one outer domain; ids ascending.
fn assert_consistent(model: &Model, d: &Domains) {
    let mut crossings = vec![Vec::new(); model.contacts.len()];
    for (k, dom) in d.list.iter().enumerate() {
        for l in d.links_of(dom) {
            if let DomainLink::Contact { index, id } = *l {
                assert_eq!(model.contacts[index as usize].id, id, "a domain names a contact that is not there");
                crossings[index as usize].push(k as u32);
            }
        }
    }
    assert_eq!(d.sides.len(), model.contacts.len());
    let mut linking = 0;
    for (i, side) in d.sides.iter().enumerate() {
        let mut listed = crossings[i].clone();
        listed.sort_unstable();
        if side[0] == NO_DOMAIN {
            assert!(listed.is_empty());
            continue;
        }
        linking += 1;
        let mut expected = side.to_vec();
        expected.sort_unstable();
        assert_eq!(listed, expected, "contact {}", model.contacts[i].id);
    }
    assert!(model.contacts.is_empty() || linking > 0);
    assert_eq!(d.list.iter().filter(|x| x.kind == DomainKind::Outer).count(), 1);
    assert!(d.list.windows(2).all(|w| w[0].id < w[1].id));
    assert!(d.list.iter().all(|x| x.kind == DomainKind::Outer || x.area >= d.min_area), "an area below the minimum");
    // Each piece of block boundary bounds exactly one domain: the void areas (the outer
    // domain's minus the outline's) add up to minus the blocks' area.
    let blocks: f64 = (0..model.blocks.len()).map(|b| signed_area(&model.corner_positions(b))).sum();
    let voids: f64 = d.list.iter().map(|x| x.void_area).sum();
    assert!((blocks + voids).abs() <= 1e-9 * blocks.abs().max(1.0), "blocks {blocks}, voids {voids}");
}

#[test]
fn a_closed_void_between_four_blocks_prints_as_one_domain_of_its_area() {
    let (model, log) = run_ok(&format!("{HEAD}{PINWHEEL}CYCLE 1\nPRINT CONTACTS DOMAINS DLIST\nSTOP\n"));
    let tables = domain_tables(&log);
    assert_eq!(tables.len(), 1);
    let rows = &tables[0];
    // The outer domain (id 1), the hole, and the four joints between the blocks.
    assert_eq!(rows.len(), 6, "{rows:?}");
    assert_eq!((rows[0].id, rows[0].volume, rows[0].note.as_str()), (1, 0.0, "(OUTER BOUNDARY)"));
    let voids: Vec<&Row> = rows.iter().filter(|r| r.note.is_empty()).collect();
    assert_eq!(voids.len(), 1);
    assert!((voids[0].volume - 1.0).abs() < 1e-3, "the hole is 1 × 1: {}", voids[0].volume);
    let min_area = 1e-3 * model.blocks.iter().map(|b| b.area).sum::<f64>() / 4.0;
    let joints: Vec<&Row> = rows.iter().filter(|r| r.note.starts_with("JOINT L=")).collect();
    assert_eq!(joints.len(), 4);
    for j in &joints {
        assert_eq!(j.note, "JOINT L=1.000E+00");
        assert!((j.volume - min_area).abs() < 1e-3 * min_area, "a joint's area is the minimum until fluid: {}", j.volume);
    }
    assert!(rows.iter().all(|r| r.pressure == 0.0 && r.displacement >= 0.0));
    // PRINT DLIST: each domain's header, then the contacts (named as PRINT CONTACTS names them)
    // and corners around it.
    let contacts = contact_table(&log);
    let dlist = section(&log, "DOMAIN LINKED LISTS", |l| l.starts_with("DOMAIN ") || l.starts_with("   CONTACT ") || l.starts_with("   CORNER "));
    let headers: Vec<&str> = dlist.iter().copied().filter(|l| l.starts_with("DOMAIN ")).collect();
    assert_eq!(headers.len(), 6);
    assert_eq!(headers[0], "DOMAIN 1 (OUTER BOUNDARY)");
    for l in dlist.iter().filter(|l| l.starts_with("   CONTACT ")) {
        // "   CONTACT 7, BLOCK1 2, BLOCK2 3 CORNER/EDGE"
        let f: Vec<&str> = l.split([' ', ',']).filter(|s| !s.is_empty()).collect();
        let id: u32 = f[1].parse().unwrap();
        assert_eq!(contacts.get(&id), Some(&(f[3].to_string(), f[5].to_string())), "{l}");
    }
    // The hole's circuit crosses four contacts, one from each block.
    let hole = headers.iter().position(|h| *h == format!("DOMAIN {}", voids[0].id)).unwrap();
    let d = model.domains.as_ref().expect("built on request");
    assert_consistent(&model, d);
    let regular = d.list.iter().find(|x| x.kind == DomainKind::Regular).unwrap();
    assert_eq!(regular.id, voids[0].id);
    assert_eq!(d.links_of(regular).iter().filter(|l| matches!(l, DomainLink::Contact { .. })).count(), 4);
    assert!(hole > 0);
}

#[test]
fn the_outer_domain_holds_lone_blocks_and_a_deck_with_no_blocks_prints_it() {
    // No blocks at all: the outer domain alone, no panic.
    let (model, log) = run_ok("START\nPRINT DOMAINS DLIST\nSTOP\n");
    let rows = &domain_tables(&log)[0];
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0].note, "(OUTER BOUNDARY)");
    assert!(log.contains("\nDOMAIN 1 (OUTER BOUNDARY)\n"), "{log}");
    assert_eq!(model.domains.as_ref().map(|d| d.list.len()), Some(1));
    // Two blocks that touch nothing: both on the outer domain's list, corner by corner.
    let (model, log) = run_ok(&format!("{HEAD}BLOCK 0,0 1,0 1,1 0,1\nBLOCK 3,0 4,0 4,1 3,1\nCYCLE 1\nPRINT DLIST\nSTOP\n"));
    let dlist = section(&log, "DOMAIN LINKED LISTS", |l| l.starts_with("DOMAIN ") || l.starts_with("   C"));
    let corners: Vec<&&str> = dlist.iter().filter(|l| l.starts_with("   CORNER ")).collect();
    assert_eq!(corners.len(), 8, "{dlist:?}");
    assert_eq!(corners[0].to_string(), "   CORNER 1, BLOCK 1, R-LINK 2");
    assert_eq!(corners[3].to_string(), "   CORNER 4, BLOCK 1, R-LINK 1");
    assert!(model.contacts.is_empty());
    // A block floating in a cavity belongs to the cavity's domain, whose area it takes.
    let ring = "BLOCK 0,0 3,0 3,1 0,1\nBLOCK 3,0 4,0 4,3 3,3\nBLOCK 1,3 4,3 4,4 1,4\nBLOCK 0,1 1,1 1,4 0,4\nBLOCK 1.75,1.75 2.25,1.75 2.25,2.25 1.75,2.25\n";
    let (model, log) = run_ok(&format!("{HEAD}{ring}CYCLE 1\nPRINT DOMAINS\nSTOP\n"));
    let rows = &domain_tables(&log)[0];
    let cavity: Vec<&Row> = rows.iter().filter(|r| r.note.is_empty()).collect();
    assert_eq!(cavity.len(), 1);
    assert!((cavity[0].volume - 3.75).abs() < 1e-3, "2 × 2 less the 0.5 × 0.5 block: {}", cavity[0].volume);
    assert_consistent(&model, model.domains.as_ref().unwrap());
}

#[test]
fn two_blocks_in_face_contact_have_a_joint_domain_between_them() {
    // A 1 m block resting on a fixed base, joint law (CONS=2 with JKN, JKS: ¶5).
    let deck = format!(
        "{HEAD}PROP MAT=1 JKN=1E10 JKS=1E10 JF=0.5\nBLOCK CONS=2 0,0 3,0 3,1 0,1\nBLOCK CONS=2 1,1 2,1 2,2 1,2\nFIX 0 3 0 1\nGRAV 0 -10\nDAMP 0.8 10 MASS\nCYCLE 200\nPRINT CONTACTS DOMAINS\nSTOP\n"
    );
    let (model, log) = run_ok(&deck);
    assert!(model.contacts.iter().any(|c| c.joint_length > 0.0), "the contacts follow the joint law");
    let d = model.domains.as_ref().unwrap();
    assert_consistent(&model, d);
    assert_eq!(d.list.iter().map(|x| x.kind).collect::<Vec<_>>(), [DomainKind::Outer, DomainKind::Joint]);
    let joint = &d.list[1];
    assert!((joint.length - 1.0).abs() < 1e-3, "the common length of the faces: {}", joint.length);
    assert_eq!(joint.area, d.min_area);
    assert!((d.min_area - 1e-3 * 2.0).abs() < 1e-12, "a thousandth of the average block area (3 and 1 m²)");
    // Each of its two contacts leads from the outer domain into the joint.
    let linking: Vec<[u32; 2]> = d.sides.iter().copied().filter(|s| s[0] != NO_DOMAIN).collect();
    assert_eq!(linking.len(), 2);
    for s in linking {
        let mut s = s.to_vec();
        s.sort_unstable();
        assert_eq!(s, [0, 1]);
    }
    let rows = &domain_tables(&log)[0];
    assert_eq!(rows[1].note, "JOINT L=1.000E+00");
}

#[test]
fn domains_follow_split_delete_and_contacts_that_open_keeping_their_ids() {
    // A 2 × 2 block split in four: four joints and the small void where the four corners meet.
    let deck = format!(
        "{HEAD}BLOCK 0,0 2,0 2,2 0,2\nSPLIT 1,-1 1,3\nSPLIT -1,1 3,1\nCYCLE 1\nPRINT DOMAINS\nDELETE 0 1 0 1\nCYCLE 1\nPRINT DOMAINS\nVELOCITY 0 2 1 2 0 5\nCYCLE 100\nPRINT CONTACTS DOMAINS\nSTOP\n"
    );
    let (model, log) = run_ok(&deck);
    let tables = domain_tables(&log);
    assert_eq!(tables.len(), 3);
    let joints = |t: &[Row]| t.iter().filter(|r| r.note.starts_with("JOINT")).map(|r| r.id).collect::<Vec<_>>();
    let (split, deleted, opened) = (&tables[0], &tables[1], &tables[2]);
    assert_eq!(joints(split).len(), 4, "{split:?}");
    assert!(split.iter().filter(|r| r.note.starts_with("JOINT")).all(|r| r.note == "JOINT L=1.000E+00"), "{split:?}");
    // The void where the four rounded corners meet is a domain of the minimum area.
    assert_eq!(split.iter().filter(|r| r.note.is_empty()).count(), 1, "{split:?}");
    // DELETE of the lower left block takes its two joints; the other two keep their ids.
    assert_eq!(joints(deleted).len(), 2, "{deleted:?}");
    assert!(joints(deleted).iter().all(|id| joints(split).contains(id)));
    // The two upper blocks fly off together: the joints between them and the lower block open
    // and go; the one between the two upper blocks stays, with its id; no id is reused.
    assert_eq!(opened.len(), 2, "{opened:?}");
    assert_eq!(opened[0].note, "(OUTER BOUNDARY)");
    assert!(joints(deleted).contains(&opened[1].id));
    assert!(opened[0].displacement > 0.0, "the blocks moved since their last update");
    let d = model.domains.as_ref().unwrap();
    assert_consistent(&model, d);
    assert!(d.next_id as usize > split.len(), "ids are never reused");
    // And the model's domains are those printed last.
    assert_eq!(d.list.iter().map(|x| x.id).collect::<Vec<_>>(), opened.iter().map(|r| r.id).collect::<Vec<_>>());
}

#[test]
fn domains_stay_right_through_cracking() {
    // Sample 1 cracks blocks under point loads (¶15); its domains after the run, asked for at
    // the end, and again in a run that printed them before it cycled (rebuilt after each CYCLE).
    let deck = sample("udec1_point_load_cracking.dat");
    let first_cycle = deck.find("\nCYC").expect("sample 1 cycles");
    let (before, _) = run_ok(&format!("{}\nSTOP\n", &deck[..first_cycle]));
    let at_end = deck.replacen("\nSTOP", "\nPRINT DOMAINS\nSTOP", 1);
    let (model, log) = run_ok(&at_end);
    assert!(model.blocks.len() > before.blocks.len(), "sample 1 cracked its blocks ({} then {})", before.blocks.len(), model.blocks.len());
    let d = model.domains.as_ref().unwrap();
    assert_consistent(&model, d);
    assert!(d.list.len() > 1 && !domain_tables(&log).is_empty());
    let early = format!("{}\nPRINT DOMAINS{}", &at_end[..first_cycle], &at_end[first_cycle..]);
    let (again, _) = run_ok(&early);
    let kept = again.domains.as_ref().unwrap();
    assert_consistent(&again, kept);
    // The same voids, whatever ids they got on the way.
    let shape = |d: &Domains| {
        let mut v: Vec<(&str, u64)> = d.list.iter().map(|x| (x.kind.name(), (x.area * 1e9).round() as u64)).collect();
        v.sort_unstable();
        v
    };
    assert_eq!(shape(kept), shape(d));
    // Domains only observe: the motion is the same bit for bit.
    assert!(again == model, "printing domains changed the run");
}

#[test]
fn sample_4_runs_to_its_end_with_its_domain_lists() {
    let deck = sample("udec4_projectile_beam.dat");
    let (model, log) = run_ok(&deck);
    assert!(log.contains(")P B C COR DL L") && log.contains(")STOP"), "{log}");
    assert_eq!(model.cycle, 2000);
    let contacts = contact_table(&log);
    assert!(!contacts.is_empty());
    let dlist = section(&log, "DOMAIN LINKED LISTS", |l| l.starts_with("DOMAIN ") || l.starts_with("   CONTACT ") || l.starts_with("   CORNER "));
    assert_eq!(dlist.iter().filter(|l| l.ends_with("(OUTER BOUNDARY)")).count(), 1);
    let mut crossed = std::collections::HashMap::new();
    for l in dlist.iter().filter(|l| l.starts_with("   CONTACT ")) {
        let f: Vec<&str> = l.split([' ', ',']).filter(|s| !s.is_empty()).collect();
        let id: u32 = f[1].parse().unwrap();
        assert_eq!(contacts.get(&id), Some(&(f[3].to_string(), f[5].to_string())), "{l}: not as PRINT CONTACTS has it");
        *crossed.entry(id).or_insert(0) += 1;
    }
    // Each contact that links domains is crossed twice (once from each side).
    assert!(crossed.values().all(|&n| n == 2), "{crossed:?}");
    // The corners of DL are PRINT LIST's, numbered alike.
    let blist: std::collections::HashSet<&str> =
        section(&log, "BLOCK LINKED LISTS", |l| l.starts_with("BLOCK ") || l.starts_with("   CORNER ") || l.starts_with("      CONTACT "))
            .into_iter()
            .collect();
    for l in dlist.iter().filter(|l| l.starts_with("   CORNER ")) {
        assert!(blist.contains(l), "{l} is not in PRINT LIST");
    }
    assert_consistent(&model, model.domains.as_ref().unwrap());
}

#[test]
fn a_scene_that_never_asks_has_no_domains_and_one_that_does_moves_the_same() {
    let body = format!(
        "{HEAD}PROP MAT=1 JKN=1E10 JKS=1E10\nBLOCK 0,0 3,0 3,1 0,1\nBLOCK 1,1 2,1 2,2 1,2\nBLOCK 1.2,2.05 1.8,2.05 1.8,2.6 1.2,2.6\nFIX 0 3 0 1\nGRAV 0 -10\n"
    );
    let (plain, _) = run_ok(&format!("{body}CYCLE 300\nCYCLE 300\nSTOP\n"));
    assert!(plain.domains.is_none());
    let json = state_json::state_json(&plain);
    assert!(json.get("domains").is_none(), "no domains key in a scene without domains");
    let (observed, log) = run_ok(&format!("{body}PRINT DOMAINS\nCYCLE 300\nPRINT DLIST\nCYCLE 300\nSTOP\n"));
    assert!(log.contains("DOMAIN LINKED LISTS"));
    // Bit for bit: blocks, corners, contacts and every setting (the domains take no part).
    assert!(observed == plain, "domains changed the motion");
    assert_eq!(observed.blocks[2].centroid.map(f64::to_bits), plain.blocks[2].centroid.map(f64::to_bits));
    // The state JSON's domains: the keys issue 30 fixes.
    let json = state_json::state_json(&observed);
    let domains = json["domains"].as_array().expect("a domains list");
    assert_eq!(domains.len(), observed.domains.as_ref().unwrap().list.len());
    assert!(domains.len() >= 3, "the outer domain and the two joints: {domains:?}");
    for d in domains {
        for key in ["id", "pressure", "area", "fixed", "outer"] {
            assert!(d.get(key).is_some(), "{key} missing in {d}");
        }
        assert_eq!(d["pressure"], 0.0);
        assert_eq!(d["fixed"], false);
    }
    assert_eq!(domains.iter().filter(|d| d["outer"] == true).count(), 1);
    assert!(domains.iter().all(|d| d["outer"] == true || d["area"].as_f64().unwrap() > 0.0));
}

#[test]
fn printing_the_domains_twice_gives_the_same_table() {
    let (_, log) = run_ok(&format!("{HEAD}{PINWHEEL}CYCLE 5\nPRINT DOMAINS\nPRINT DOMAINS\nSTOP\n"));
    let t = domain_tables(&log);
    assert_eq!(t.len(), 2);
    assert_eq!(t[0], t[1]);
}

/// A random pile: a fixed base and up to 12 blocks of random sizes, dropped from a grid of cells
/// (so that none overlaps) under a strong gravity, some of them split by random lines, some given
/// a spin; it falls and settles for 200 to 2000 cycles, then its domains are built. Whatever the contacts (corner to corner,
/// T-junctions, open ones, bridges), the set is consistent and the areas add up.
fn random_pile(cells: &[(u8, f64, f64, f64, f64)], splits: &[(f64, f64, f64, f64)], cycles: u32) -> String {
    let mut deck = format!("{HEAD}PROP MAT=1 JKN=1E9 JKS=1E9\nBLOCK 0,0 4,0 4,0.5 0,0.5\n");
    for (k, &(fill, w, h, dx, dy)) in cells.iter().enumerate() {
        if fill == 0 {
            continue;
        }
        let (cx, cy) = ((k % 4) as f64, 0.6 + (k / 4) as f64);
        let (x0, y0) = (cx + dx * (1.0 - w), cy + 0.05 * dy);
        let cons = if fill == 2 { " CONS=2" } else { "" };
        deck.push_str(&format!("BLOCK{cons} {x0:.4},{y0:.4} {:.4},{y0:.4} {:.4},{:.4} {x0:.4},{:.4}\n", x0 + w, x0 + w, y0 + h, y0 + h));
    }
    for &(x1, y1, x2, y2) in splits {
        deck.push_str(&format!("SPLIT {x1:.3},{y1:.3} {x2:.3},{y2:.3}\n"));
    }
    deck.push_str(&format!("FIX 0 4 0 0.5\nGRAV 0 -100\nDAMP 0.5 8 MASS\nVELOCITY 0 4 3 4 0 0 1\nCYCLE {cycles}\nPRINT DOMAINS DLIST\nSTOP\n"));
    deck
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config { cases: 64, ..Default::default() })]
    #[test]
    fn domains_of_random_piles_are_consistent_and_their_areas_add_up(
        cells in proptest::collection::vec((0u8..3, 0.4f64..0.95, 0.3f64..0.95, 0.0f64..1.0, 0.0f64..1.0), 12),
        splits in proptest::collection::vec((-0.5f64..4.5, 0.0f64..4.0, -0.5f64..4.5, 0.0f64..4.0), 0..3),
        cycles in 200u32..2000,
    ) {
        let deck = random_pile(&cells, &splits, cycles);
        let (r, log) = run_logged(&deck);
        // A random SPLIT may be refused (along an edge, say): that is the executor's to say.
        let model = match r {
            Ok(m) => m,
            Err(RunError::Command { .. }) => return Ok(()),
            Err(e) => panic!("{e}\n{deck}\n{log}"),
        };
        let d = model.domains.as_ref().expect("asked for");
        assert_consistent(&model, d);
        proptest::prop_assert_eq!(domain_tables(&log)[0].len(), d.list.len());
    }
}

#[test]
fn set_damin_gives_the_minimum_area_and_bad_values_name_their_line() {
    // The pinwheel's joints take the minimum; its 1 m² hole keeps its area above it and is
    // raised to it below.
    for (a, hole) in [(0.25, 1.0), (2.0, 2.0)] {
        let (model, log) = run_ok(&format!("{HEAD}{PINWHEEL}SET DAMIN {a}\nCYCLE 1\nPRINT DOMAINS\nSTOP\n"));
        let rows = &domain_tables(&log)[0];
        assert!(log.contains(&format!("   MINIMUM DOMAIN AREA {} (SET DAMIN)", blockdem::output::format::fmt_e(a))), "{log}");
        assert!(rows.iter().filter(|r| r.note.starts_with("JOINT")).all(|r| r.volume == a), "{rows:?}");
        let void = rows.iter().find(|r| r.note.is_empty()).unwrap();
        assert!((void.volume - hole).abs() < 1e-9, "{a}: {}", void.volume);
        let d = model.domains.as_ref().unwrap();
        assert_eq!((d.min_area, d.given_min_area), (a, Some(a)));
        assert_consistent(&model, d);
    }
    // Given after the domains exist, it applies at once; the rebuilds keep it.
    let (model, log) = run_ok(&format!("{HEAD}{PINWHEEL}CYCLE 1\nPRINT DOMAINS\nSET DAMIN 0.5\nCYCLE 1\nSTOP\n"));
    assert!(log.contains("(1.000E-03 OF THE AVERAGE BLOCK AREA)"), "{log}");
    assert_eq!(model.domains.as_ref().unwrap().min_area, 0.5);
    for (bad, needle) in [
        ("SET DAMIN 0", "must be positive"),
        ("SET DAMIN -1", "must be positive"),
        ("SET DAMIN", "minimum domain area"),
        ("SET DAMIN X", "minimum domain area"),
    ] {
        let e = blockdem::udec::deck::parse_deck(&format!("START\n{bad}\n"), "d").unwrap_err();
        assert!(e.to_string().starts_with("d:2:") && e.to_string().contains(needle), "{bad}: {e}");
    }
}

every_backend!(domains_are_built_from_the_model_every_backend_leaves);

/// A ring of blocks around a hole, one of them fixed, a small block falling into the hole: after
/// cycling on `t`, the domains built from the model it leaves are those the CPU's gives (the
/// same kinds, the hole's area to f32's round-off), and consistent.
fn domains_are_built_from_the_model_every_backend_leaves(t: &Target) {
    let deck = format!("{HEAD}{PINWHEEL}BLOCK 1.2,1.2 1.5,1.2 1.5,1.5 1.2,1.5\nFIX -1 4 -1 0.9\nGRAV 0 -10\nPRINT DOMAINS\nCYCLE 300\nPRINT DOMAINS\nSTOP\n");
    let here = t.run(&deck);
    let cpu = Target::Cpu.run(&deck);
    let (d, reference) = (here.domains.as_ref().unwrap(), cpu.domains.as_ref().unwrap());
    assert_consistent(&here, d);
    let kinds = |d: &Domains| d.list.iter().map(|x| x.kind.name()).collect::<Vec<_>>();
    assert_eq!(kinds(d), kinds(reference), "{}", t.name());
    let hole = |d: &Domains| d.list.iter().find(|x| x.kind == DomainKind::Regular).map(|x| x.area).unwrap();
    let tol = if t.is_f32() { 1e-4 } else { 1e-9 };
    assert!((hole(d) - hole(reference)).abs() < tol, "{}: {} against {}", t.name(), hole(d), hole(reference));
    // The block fell in: the hole is less than 1 m² by its area, and it touches the ring.
    assert!(hole(d) < 0.95, "{}", hole(d));
}

#[test]
fn a_restart_builds_the_domains_again() {
    // SAVE files do not keep the domains; a scene that had them builds them again at RESTART,
    // the same voids with the same numbers (nothing changed in between).
    let dir = std::env::temp_dir().join(format!("blockdem-domains-restart-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("d.sav");
    let deck = format!("{HEAD}{PINWHEEL}CYCLE 5\nPRINT DOMAINS\nSAVE {f}\nRESTART {f}\nPRINT DOMAINS\nSTOP\n", f = file.display());
    let (model, log) = run_ok(&deck);
    let t = domain_tables(&log);
    assert_eq!(t.len(), 2);
    assert_eq!(t[0], t[1]);
    assert!(log.contains("THIS IS A RESTART RUN"));
    assert_consistent(&model, model.domains.as_ref().unwrap());
    let _ = std::fs::remove_dir_all(&dir);
}

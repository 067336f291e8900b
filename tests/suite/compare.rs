//! `blockdem::compare` on outcomes made here: the same run compares as equal, a moved block is
//! named with its difference, and runs that end on other blocks are not compared block by block.

use blockdem::compare::{compare, table, Outcome};

fn outcome(deck: &str) -> Outcome {
    let model = blockdem::scenes::run_deck_on(deck, Box::new(blockdem::udec::cpu::CpuBackend::new())).unwrap();
    Outcome { backend: "cpu (f64)".into(), wall_s: 1.0, model, error: None }
}

const DECK: &str = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.1\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1 1,2 2,2 2,1\nBLOCK 2.5,1 2.5,2 3.5,2 3.5,1\n\
                    FIX 0 4 0 0.9\nGRAV 0 -10\nVELOCITY 1 2 1 2 0.5 0\nCYCLE 200\n";

#[test]
fn the_same_run_compares_equal_and_a_moved_block_is_named() {
    let a = outcome(DECK);
    let mut b = a.clone();
    b.wall_s = 3.0;
    let c = compare(&a, &b);
    assert!(c.same_blocks && c.position.value == 0.0 && c.velocity.value == 0.0 && c.energy.iter().all(|e| e.1 == 0.0), "{c:?}");
    assert_eq!(c.time_ratio, 3.0);
    // Block 3 moved by 1 mm: 1e-2 of ROUND, named.
    b.model.blocks[2].centroid[1] += 1e-3;
    let c = compare(&a, &b);
    assert_eq!(c.position.block, 3);
    assert!((c.position.value - 1e-3).abs() < 1e-12 && (c.position.relative - 1e-2).abs() < 1e-9, "{:?}", c.position);
    assert!(table(&a, &b, &c).contains("position             1.000e-3 m"), "{}", table(&a, &b, &c));
}

#[test]
fn runs_ending_on_other_blocks_are_not_compared_block_by_block() {
    let a = outcome(DECK);
    let b = outcome(&DECK.replace("CYCLE 200", "DELETE 2.4 3.6 1 2\nCYCLE 200"));
    let c = compare(&a, &b);
    assert!(!c.same_blocks && c.position.value.is_nan(), "{c:?}");
    assert_eq!(c.blocks, [3, 2]);
    assert!(table(&a, &b, &c).contains("the runs end on different blocks (3 and 2"), "{}", table(&a, &b, &c));
}

/// Issue 27 item 9: the rows of the largest differences line up — each row's block id and
/// relative figure start in the same column as the header's (the rotation row was shifted).
#[test]
fn the_rows_of_largest_differences_line_up() {
    let a = outcome(DECK);
    let mut b = a.clone();
    b.model.blocks[2].centroid[1] += 1e-3;
    b.model.blocks[1].rotation += 1e-4;
    b.model.blocks[2].velocity[0] += 1e-2;
    let text = table(&a, &b, &compare(&a, &b));
    let lines: Vec<&str> = text.lines().skip_while(|l| !l.starts_with("largest difference")).take(4).collect();
    let column = |l: &str, from: usize| l.char_indices().skip(from).find(|(_, c)| *c != ' ').map(|(i, _)| i);
    let header = lines[0];
    let (relative, block) = (header.find("relative").unwrap(), header.find("block").unwrap());
    for row in &lines[1..] {
        assert_eq!(column(row, relative), Some(relative), "{text}");
        assert_eq!(row.rfind(' ').map(|i| i + 1), Some(block), "{text}");
    }
}

/// With simply-deformable blocks the internal stresses are compared too (issue 28 item 7): the
/// largest component difference, relative to the largest stress of the reference, and its block.
#[test]
fn sdef_stresses_are_compared() {
    let deck = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 K=1E8 G=6E7 F=0.5\nROUND 0.05\nGRAV 0 -10\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1 1,2 2,2 2,1\n\
                FIX 0 4 0 0.9\nCHANGE 0 4 1 2 SDEF\nCYCLE 300\n";
    let a = outcome(deck);
    assert!(compare(&a, &a).stress.is_some_and(|l| l.value == 0.0), "{:?}", compare(&a, &a).stress);
    let mut b = a.clone();
    let top = a.model.sdef[1].stress.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(top > 0.0);
    b.model.sdef[1].stress[2] += 0.5 * top;
    let c = compare(&a, &b);
    let l = c.stress.expect("a stress row");
    assert_eq!(l.block, 2);
    assert!((l.relative - 0.5).abs() < 1e-12, "{l:?}");
    assert!(table(&a, &b, &c).contains("stress (SDEF)"), "{}", table(&a, &b, &c));
    // A rigid scene has no stress row.
    assert!(compare(&outcome(DECK), &outcome(DECK)).stress.is_none());
}

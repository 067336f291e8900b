//! The report's sample decks, determinism, and SAVE/RESTART.

use blockdem::cpu::CpuBackend;
use blockdem::model::Model;
use blockdem::scenes::{run_deck_logged, run_deck_on};

fn sample(name: &str) -> String {
    let path = format!("{}/examples/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// A `Write` that appends to a shared buffer, to read the run log back.
#[derive(Clone, Default)]
struct SharedLog(std::rc::Rc<std::cell::RefCell<Vec<u8>>>);

impl std::io::Write for SharedLog {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.borrow_mut().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn sample_1_cracks_once_and_the_piece_comes_to_rest_on_the_base() {
    let log = SharedLog::default();
    let deck = sample("udec1_point_load_cracking.dat");
    let m = run_deck_logged(&deck, Box::new(CpuBackend::new()), Box::new(log.clone())).expect("sample 1 runs");
    let text = String::from_utf8(log.0.borrow().clone()).unwrap();
    // The run log as UDEC printed it.
    assert!(text.contains("THIS IS A START RUN"));
    assert!(text.contains("STIFFNESS-DAMPING TERM SET TO ZERO"));
    assert!(text.contains("INITIAL TIMESTEP = 1.000E-02"), "m_min = 2.5e5 kg, k = 1e8: 0.1·2·√(2.5e-3) = 1e-2");
    assert!(text.contains("CURRENT CYCLE COUNT = 600"));
    assert_eq!(text.matches("CRACKED AT CYCLE").count(), 1, "exactly one point-load crack:\n{text}");
    // Five blocks were carved; the crack makes six.
    assert_eq!(m.blocks.len(), 6);
    // The cracked piece is the one whose centroid lies right of the support (x > 25) at mid
    // height originally; it must now rest on the fixed base, whose top is y = 5.
    let base = &m.blocks[m.blocks.iter().position(|b| b.fixed).unwrap()];
    let base_top = top_of(&m, base.id);
    let piece = m.blocks.iter().filter(|b| !b.fixed).min_by(|a, b| a.centroid[1].partial_cmp(&b.centroid[1]).unwrap()).unwrap();
    let idx = m.block_index(piece.id).unwrap();
    let lowest = m.block_corners(idx).iter().map(|c| c.position[1]).fold(f64::INFINITY, f64::min);
    assert!(piece.centroid[0] > 25.0, "the lowest free block is the cracked-off piece, right of the support: {:?}", piece.centroid);
    // On the base: its lowest corner within the contact overlap (a few cm) of the base's top.
    assert!((lowest - base_top).abs() < 0.1, "lowest corner at y = {lowest}, base top at {base_top}");
    // At rest: speed below 1 cm/s.
    let speed = piece.velocity[0].hypot(piece.velocity[1]);
    assert!(speed < 0.01, "piece still moving at {speed} m/s");
}

/// Highest corner of the block with this id.
fn top_of(m: &Model, id: u32) -> f64 {
    let i = m.block_index(id).unwrap();
    m.block_corners(i).iter().map(|c| c.position[1]).fold(f64::NEG_INFINITY, f64::max)
}

#[test]
fn the_same_deck_twice_gives_bit_identical_state() {
    let deck = sample("udec1_point_load_cracking.dat");
    let a = run_deck_on(&deck, Box::new(CpuBackend::new())).unwrap();
    let b = run_deck_on(&deck, Box::new(CpuBackend::new())).unwrap();
    assert_eq!(a, b);
}

#[test]
fn save_then_restart_continues_identically() {
    let dir = std::env::temp_dir().join(format!("blockdem-restart-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let save = dir.join("half.sav");
    let base = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.1\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1.5 1,2.5 2,2.5 2,1.5\n\
         FIX 0 4 0 0.9\nGRAV 0 -10\nVELOCITY 1 2 1.5 2.5 0.5 0 0.3\n";
    let straight = run_deck_on(&format!("{base}CYCLE 400\nCYCLE 400\n"), Box::new(CpuBackend::new())).unwrap();
    run_deck_on(&format!("{base}CYCLE 400\nSAVE {}\n", save.display()), Box::new(CpuBackend::new())).unwrap();
    let resumed = run_deck_on(&format!("RESTART {}\nCYCLE 400\n", save.display()), Box::new(CpuBackend::new())).unwrap();
    assert_eq!(straight, resumed);
    let _ = std::fs::remove_dir_all(&dir);
}

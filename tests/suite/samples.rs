//! The report's sample decks, determinism, and SAVE/RESTART, on every backend (tests/suite/common).

use crate::common;

use blockdem::scenes::{run_deck_logged, run_deck_on};
use common::{every_backend, SharedLog, Target};

every_backend!(
    sample_1_cracks_once_and_the_piece_comes_to_rest_on_the_base,
    the_same_deck_twice_gives_bit_identical_state,
    save_then_restart_continues_identically,
);

fn sample(name: &str) -> String {
    let path = format!("{}/examples/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn sample_1_cracks_once_and_the_piece_comes_to_rest_on_the_base(t: &Target) {
    let log = SharedLog::default();
    let deck = sample("udec1_point_load_cracking.dat");
    let m = run_deck_logged(&deck, t.backend(), Box::new(log.clone())).expect("sample 1 runs");
    let text = String::from_utf8(log.0.borrow().clone()).unwrap();
    // The run log as UDEC printed it.
    assert!(text.contains("THIS IS A START RUN"));
    assert!(text.contains("STIFFNESS-DAMPING TERM SET TO ZERO"));
    assert!(text.contains("INITIAL TIMESTEP = 1.000E-02"), "m_min = 2.5e5 kg, k = 1e8: 0.1·2·√(2.5e-3) = 1e-2");
    assert!(text.contains("CURRENT CYCLE COUNT = 600"));
    assert_eq!(text.matches("CRACKED AT CYCLE").count(), 1, "exactly one point-load crack:\n{text}");
    // Four blocks are carved (base, support, beam, top block); the crack makes five.
    assert_eq!(m.blocks.len(), 5);
    // The cracked piece is the free block furthest right (right of the support, x > 25); it must now
    // rest on the fixed base: a compressive contact between the two.
    let base = m.blocks.iter().position(|b| b.fixed).unwrap() as u32;
    let piece = m.blocks.iter().filter(|b| !b.fixed).max_by(|a, b| a.centroid[0].partial_cmp(&b.centroid[0]).unwrap()).unwrap();
    let idx = m.block_index(piece.id).unwrap() as u32;
    assert!(piece.centroid[0] > 25.0, "the cracked-off piece lies right of the support: {:?}", piece.centroid);
    let on_base: f64 =
        m.contacts.iter().filter(|c| (c.block1 == idx && c.block2 == base) || (c.block1 == base && c.block2 == idx)).map(|c| c.normal_force).sum();
    // It fell from the beam's level (its bottom at y = 10) onto the base (top at y = 5) and
    // carries part of its own weight (2.5e5 kg · 10 m/s²) there.
    assert!(on_base > 0.1 * 2.5e6, "piece presses on the base with {on_base} N");
    // At rest: speed below 1 cm/s.
    let speed = piece.velocity[0].hypot(piece.velocity[1]);
    assert!(speed < 0.01, "piece still moving at {speed} m/s");
    // The energy books balance through the crack: the contacts re-made on the pieces start with
    // the forces their overlaps hold (`topology::cracking::apply_crack`), so the crack releases
    // only what really goes. Measured 1.3e-4 of the largest term on every backend (0.36 kJ of
    // 1.6 MJ before the crack); when the re-made contacts started unloaded the ledger jumped by
    // 2.8e5 J at the crack (2.7% of the largest term at cycle 600, 16% just after it).
    let e = m.energies();
    let balance = e.ledger().abs() / e.scale();
    assert!(balance < 2e-3, "ledger {balance:.2e} of the largest term on {}: {e:?}", t.name());
}

/// Two runs of one deck give bit-identical state: forces are gathered in a fixed order, never
/// summed with float atomics, on every backend.
fn the_same_deck_twice_gives_bit_identical_state(t: &Target) {
    let deck = sample("udec1_point_load_cracking.dat");
    let a = run_deck_on(&deck, t.backend()).unwrap();
    let b = run_deck_on(&deck, t.backend()).unwrap();
    assert_eq!(a, b);
    // Bit for bit: `==` on f64 calls 0.0 and −0.0 equal and NaN unequal to itself; the serialized
    // state (every f64 as its 8 IEEE bytes, as SAVE writes it) does not.
    assert_eq!(bits(&a), bits(&b), "the serialized states differ on {}", t.name());
}

/// The model as SAVE serializes it: every f64 as its IEEE bytes.
fn bits(m: &blockdem::udec::model::Model) -> Vec<u8> {
    postcard::to_stdvec(m).expect("serializes")
}

fn save_then_restart_continues_identically(t: &Target) {
    let tag: String = t.name().chars().filter(|c| c.is_ascii_alphanumeric()).collect();
    let dir = std::env::temp_dir().join(format!("blockdem-restart-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let save = dir.join("half.sav");
    let base = "START\nPROP MAT=1 D=2000 KN=1E8 KS=1E8 F=0.5\nROUND 0.1\nBLOCK 0,0 0,1 4,1 4,0\nBLOCK 1,1.5 1,2.5 2,2.5 2,1.5\n\
         FIX 0 4 0 0.9\nGRAV 0 -10\nVELOCITY 1 2 1.5 2.5 0.5 0 0.3\n";
    let straight = run_deck_on(&format!("{base}CYCLE 400\nCYCLE 400\n"), t.backend()).unwrap();
    run_deck_on(&format!("{base}CYCLE 400\nSAVE {}\n", save.display()), t.backend()).unwrap();
    let mut resumed = run_deck_on(&format!("RESTART {}\nCYCLE 400\n", save.display()), t.backend()).unwrap();
    if !matches!(t, Target::Cpu) {
        // The straight run's second CYCLE goes on from the device's state (nothing changed the
        // model in between); the restarted one uploads the saved state, and with it re-bases
        // the energy ledger's accumulators (the device sums from zero onto the model's f64
        // value). Those sums may then differ in their last bits (the rounding of two groupings:
        // 1e-12 in f64; in f32 the device's sums are f32, 2e-7 measured, 1e-6 allowed);
        // everything else is the same bit for bit.
        let tol = if t.is_f32() { 1e-6 } else { 1e-12 };
        let close = |a: f64, b: f64, what: &str| assert!((a - b).abs() <= tol * a.abs().max(b.abs()), "{what}: {a:e} vs {b:e} on {}", t.name());
        close(straight.external_work, resumed.external_work, "external work");
        resumed.external_work = straight.external_work;
        for (s, r) in straight.blocks.iter().zip(resumed.blocks.iter_mut()) {
            close(s.damping_work, r.damping_work, "mass damping work");
            r.damping_work = s.damping_work;
        }
        for (s, r) in straight.contacts.iter().zip(resumed.contacts.iter_mut()) {
            close(s.slip_work, r.slip_work, "slip work");
            close(s.dashpot_work, r.dashpot_work, "dashpot work");
            (r.slip_work, r.dashpot_work) = (s.slip_work, s.dashpot_work);
        }
    }
    assert_eq!(straight, resumed);
    assert_eq!(bits(&straight), bits(&resumed), "bit for bit on {}", t.name());
    let _ = std::fs::remove_dir_all(&dir);
}

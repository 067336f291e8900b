//! Joints (SL-85-1 Appendix A ¶5, issue 28 item 3): an edge-to-edge contact between planar block
//! faces in opposition, with a joint constitutive number (2, 4, 5), follows a stress-based law
//! (JKN, JKS, JCOH, JFRIC over its length); it reverts to the point-contact law when the faces
//! stop being in opposition and where JKN·l_j < KN. Scenes on every backend (tests/suite/common), the
//! topology and the inputs on the CPU.

use crate::common;

use blockdem::scenes::{run_deck_logged, run_deck_on};
use blockdem::udec::cpu::CpuBackend;
use blockdem::udec::model::constitutive::ContactLaw;
use blockdem::udec::model::{Contact, Model};
use common::{every_backend, SharedLog, Target};

every_backend!(
    stacked_blocks_of_a_joint_number_meet_in_a_joint,
    a_joint_in_direct_shear_follows_jks_up_to_its_peak,
    a_joint_reverts_to_a_point_contact_when_its_block_tips,
    the_shear_history_carries_over_when_the_law_changes,
);

fn run(t: &Target, deck: &str) -> Model {
    t.run(deck)
}

/// The force-carrying contacts between blocks with ids a and b.
fn between(m: &Model, a: u32, b: u32) -> Vec<Contact> {
    let (ia, ib) = (m.block_index(a).unwrap() as u32, m.block_index(b).unwrap() as u32);
    m.contacts.iter().filter(|c| (c.block1 == ia && c.block2 == ib) || (c.block1 == ib && c.block2 == ia)).filter(|c| m.counts_force(c)).copied().collect()
}

/// A 1 m block (constitutive `cons`) resting on a fixed 4 m base (the same number), under
/// gravity, critically damped on its joint (ω = √(JKN·L/m) = 2236 rad/s, 356 Hz); `props` the
/// material's joint keys.
fn stack(cons: u32, props: &str, top: &str) -> String {
    format!(
        "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=0.5 {props}\nROUND 0.05\nBLOCK CONS={cons} 0,-1 0,0 4,0 4,-1\nBLOCK CONS={cons} {top}\n\
         FIX 0 4 -1 -0.1\nGRAV 0 -10\nDAMP 2 356 MASS\nCYCLE 200\n"
    )
}

const JOINT_PROPS: &str = "JKN=1E10 JKS=1E10 JCOH=0 JFRIC=0.5";

fn stacked_blocks_of_a_joint_number_meet_in_a_joint(t: &Target) {
    // CONS=2: the block's bottom face on the base's top face, a joint of length 1: its two
    // corner contacts each carry 0.5 (¶5 and UDEC: half the common length each).
    let m = run(t, &stack(2, JOINT_PROPS, "1,0 1,1 2,1 2,0"));
    let joint = between(&m, 1, 2);
    assert_eq!(joint.len(), 2, "two corner contacts on {}", t.name());
    for c in &joint {
        assert_eq!(c.law(), ContactLaw::Joint, "contact {} on {}", c.id, t.name());
        assert!((c.joint_length - 0.5).abs() < 1e-12, "length {} on {}", c.joint_length, t.name());
    }
    // Statics: the joint carries the weight, 2000 kg × 10 m/s² (1%: settling under damping).
    let fn_: f64 = joint.iter().map(|c| c.normal_force).sum();
    assert!((fn_ - 2e4).abs() < 200.0, "{fn_} N on {}", t.name());
    // Its normal stiffness is JKN·l_c: the overlap is the weight over JKN·L (f32: 1e-3).
    let overlap = -joint.iter().map(|c| c.gap).sum::<f64>() / 2.0;
    let expected = 2e4 / (1e10 * 1.0);
    assert!((overlap - expected).abs() < expected * if t.is_f32() { 2e-2 } else { 1e-2 }, "overlap {overlap} vs {expected} on {}", t.name());

    // Offset by half its width: the faces share 0.5.
    let m = run(t, &stack(2, JOINT_PROPS, "3.5,0 3.5,1 4.5,1 4.5,0"));
    let joint = between(&m, 1, 2);
    assert!(!joint.is_empty() && joint.iter().all(|c| c.law() == ContactLaw::Joint && (c.joint_length - 0.25).abs() < 1e-9), "{joint:?}");

    // CONS=1: point contacts, whatever the faces.
    let m = run(t, &stack(1, JOINT_PROPS, "1,0 1,1 2,1 2,0"));
    assert!(between(&m, 1, 2).iter().all(|c| c.law() == ContactLaw::Point && c.joint_length == 0.0));
}

#[test]
fn corner_to_corner_touches_and_soft_joints_are_point_contacts() {
    // Two blocks that touch only at their corners: faces in line but not overlapping.
    let deck = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 JKN=1E10 JKS=1E10\nROUND 0.05\nBLOCK CONS=2 0,-1 0,0 4,0 4,-1\n\
                BLOCK CONS=2 4,0 4,1 5,1 5,0\nFIX -1 6 -2 2\nCYCLE 1\n";
    let m = run_deck_on(deck, Box::new(CpuBackend::new())).unwrap();
    let touch: Vec<_> = m.contacts.iter().collect();
    assert!(!touch.is_empty(), "the corners touch");
    assert!(touch.iter().all(|c| c.law() == ContactLaw::Point), "{touch:?}");

    // ¶5: the point law where sn_j·l_j < sn: JKN 5e8 × 1 m < KN 1e9.
    let m = run_deck_on(&stack(2, "JKN=5E8 JKS=5E8", "1,0 1,1 2,1 2,0"), Box::new(CpuBackend::new())).unwrap();
    let contacts = between(&m, 1, 2);
    assert_eq!(contacts.len(), 2);
    assert!(contacts.iter().all(|c| c.law() == ContactLaw::Point), "{contacts:?}");
    // The same faces with JKN 2e9 × 1 m ≥ KN: a joint.
    let m = run_deck_on(&stack(2, "JKN=2E9 JKS=5E8", "1,0 1,1 2,1 2,0"), Box::new(CpuBackend::new())).unwrap();
    assert!(between(&m, 1, 2).iter().all(|c| c.law() == ContactLaw::Joint));
}

fn a_joint_in_direct_shear_follows_jks_up_to_its_peak(t: &Target) {
    // `verify::cases::joint_shear_deck`: a 2 × 0.2 m block on a fixed base, σn = P/L = 1e5 Pa,
    // JKS = 1e9 Pa/m, JCOH = 5e4 Pa, JFRIC = 0.5: τp = JCOH + σn·JFRIC = 1e5 Pa. Closed form:
    // the joint's shear displacement u = τ/JKS below τp (statics, to the settling's 1e-4 and the
    // kernels' round-off), and sliding above it.
    let (l, jks) = (2.0, 1e9);
    for ratio in [0.5, 0.9, 1.1] {
        let (deck, peak) = blockdem::verify::cases::joint_shear_deck(ratio, "FRAC 0.1\n");
        let m = run(t, &deck);
        let joint = between(&m, 1, 2);
        assert_eq!(joint.len(), 2, "{ratio}: {joint:?}");
        assert!(joint.iter().all(|c| c.law() == ContactLaw::Joint && (c.joint_length - 1.0).abs() < 1e-12));
        let u = joint.iter().map(|c| c.shear_displacement.abs()).sum::<f64>() / 2.0;
        let tau = ratio * peak / l;
        if ratio < 1.0 {
            let e = (u - tau / jks).abs() / (tau / jks);
            assert!(e < 5e-3, "{ratio}τp: u = {u:e} vs τ/JKS = {:e} on {}", tau / jks, t.name());
            // The shear stress the joint carries is the load's: Σ|Fs| / L = τ.
            let fs: f64 = joint.iter().map(|c| c.shear_force.abs()).sum();
            assert!((fs / l - tau).abs() < 5e-3 * tau, "τ = {} vs {tau} on {}", fs / l, t.name());
        } else {
            assert!(u > 10.0 * peak / l / jks, "{ratio}τp: u = {u:e}, still stuck on {}", t.name());
        }
    }
}

fn a_joint_reverts_to_a_point_contact_when_its_block_tips(t: &Target) {
    // A 0.5 × 2 m block on a joint, tipped over by a side load (moment 1e4 N·m against its
    // weight's 5e3 about the corner; friction 1 keeps it from sliding): once it has turned past
    // a degree the faces are no longer in opposition, and the corner it turns on is a point
    // contact. The update that re-examines it comes with the motion (its corners move past the
    // update tolerance long before a degree).
    let setup = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 F=1 JKN=1E10 JKS=1E10 JFRIC=1\nROUND 0.05\nBLOCK CONS=2 0,-1 0,0 4,0 4,-1\n\
                 BLOCK CONS=2 1,0 1,2 1.5,2 1.5,0\nFIX 0 4 -1 -0.1\nGRAV 0 -10\n";
    let m = run(t, &format!("{setup}CYCLE 1\n"));
    assert!(between(&m, 1, 2).iter().all(|c| c.law() == ContactLaw::Joint), "a joint at rest");
    let m = run(t, &format!("{setup}CYCLE 1\nLOAD 0 4 0 2 1E4 0\nCYCLE 5000\n"));
    let turn = m.blocks[m.block_index(2).unwrap()].rotation;
    assert!(turn.abs() > 2f64.to_radians(), "it tipped ({turn} rad) on {}", t.name());
    let contacts = between(&m, 1, 2);
    assert!(!contacts.is_empty(), "it still stands on its corner");
    assert!(contacts.iter().all(|c| c.law() == ContactLaw::Point && c.joint_length == 0.0), "{contacts:?} on {}", t.name());
}

fn the_shear_history_carries_over_when_the_law_changes(t: &Target) {
    // The direct shear at half the peak, then JKN lowered so that JKN·l_j < KN (¶5): the next
    // CYCLE's detection makes the joint two point contacts. Their shear force and displacement
    // stay (eq. 17 is incremental): the load stays balanced and the block does not move on; a
    // history reset would let it slide on by F/(2·KS) = 1.25e-4 m.
    let (deck, _) = blockdem::verify::cases::joint_shear_deck(0.5, "FRAC 0.1\n");
    let before = run(t, &deck);
    let u0: Vec<f64> = between(&before, 1, 2).iter().map(|c| c.shear_displacement).collect();
    let after = run(t, &format!("{deck}PROP MAT=1 JKN=1E8 F=2\nCYCLE 400\n"));
    let contacts = between(&after, 1, 2);
    assert!(contacts.iter().all(|c| c.law() == ContactLaw::Point), "{contacts:?}");
    let u1: Vec<f64> = contacts.iter().map(|c| c.shear_displacement).collect();
    assert_eq!(u0.len(), u1.len());
    for (a, b) in u0.iter().zip(&u1) {
        // 2% of the elastic displacement (5e-5 m): the normal springs change stiffness (KN for
        // JKN·l_c) and the block settles to its new overlap, tilting a little.
        assert!((a - b).abs() < 1e-6, "shear displacement {a:e} → {b:e} on {}", t.name());
    }
    let fs: f64 = contacts.iter().map(|c| c.shear_force.abs()).sum();
    assert!((fs - 1e5).abs() < 1e3, "the shear load stays carried: {fs} N on {}", t.name());
}

#[test]
fn a_joint_is_marked_in_print_contacts_the_state_json_and_vtk() {
    let log = SharedLog::default();
    let deck = format!("{}PRINT CONTACTS\n", stack(2, JOINT_PROPS, "1,0 1,1 2,1 2,0"));
    let m = run_deck_logged(&deck, Box::new(CpuBackend::new()), Box::new(log.clone())).unwrap();
    let text = String::from_utf8(log.0.borrow().clone()).unwrap();
    let rows: Vec<&str> = text.lines().filter(|l| l.contains("CORNER/EDGE")).collect();
    assert_eq!(rows.len(), 2, "{text}");
    assert!(rows.iter().all(|r| r.ends_with(" JOINT L= 5.000E-01") || r.contains(" JOINT L=")), "{rows:?}");
    let json = blockdem::udec::output::state_json(&m);
    let contacts = json["contacts"].as_array().unwrap();
    assert!(contacts.iter().all(|c| c["law"] == "joint" && c["length"].as_f64() == Some(0.5)), "{contacts:?}");
    let vtk = blockdem::udec::output::vtk::contacts_vtk(&m);
    let text = format!("{vtk:?}");
    assert!(text.contains("\"joint\"") && text.contains("\"joint_length\""));
    // A point contact: "law": "point" and no length.
    let m = run_deck_on(&stack(1, JOINT_PROPS, "1,0 1,1 2,1 2,0"), Box::new(CpuBackend::new())).unwrap();
    let json = blockdem::udec::output::state_json(&m);
    assert!(json["contacts"].as_array().unwrap().iter().all(|c| c["law"] == "point" && c.get("length").is_none()));
}

#[test]
fn joint_stiffnesses_are_checked_at_cycle() {
    let run = |props: &str| {
        let log = SharedLog::default();
        let r = run_deck_logged(&stack(2, props, "1,0 1,1 2,1 2,0"), Box::new(CpuBackend::new()), Box::new(log.clone()));
        let text = String::from_utf8(log.0.borrow().clone()).unwrap();
        (r.map(|_| ()).map_err(|e| e.to_string()), text)
    };
    // JKN without JKS: an error at CYCLE naming the material, the block and what is missing.
    let (r, _) = run("JKN=1E10");
    let e = r.unwrap_err();
    assert!(e.contains("material 1") && e.contains("JKS") && e.contains("CYCLE") && e.starts_with("<scene>:9:"), "{e}");
    // Neither: the joints run as point contacts, said once (sample 4 gives CONS=4 and no JKN).
    let (r, log) = run("");
    assert!(r.is_ok(), "{r:?}");
    assert_eq!(log.matches("NOTE: material 1").count(), 1, "{log}");
    assert!(log.contains("point-contact law"), "{log}");
    // Neither JKN nor KN: "JKN missing", naming the material.
    let deck = "START\nPROP MAT=1 D=2000\nBLOCK CONS=2 0,0 0,1 1,1 1,0\nCYCLE 1\n";
    let e = run_deck_on(deck, Box::new(CpuBackend::new())).unwrap_err().to_string();
    assert!(e.contains("JKN missing") && e.contains("material 1") && e.starts_with("<scene>:4:"), "{e}");
}

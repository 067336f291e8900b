//! What `blockdem bench` asks of D3's GPU cycle beyond running it (issue 31, Speed: contact-
//! cycles/s and the roofline ratio): each kernel's time per cycle (`gpu::profile::time_passes`,
//! pass timestamps where the adapter has them) and the bytes each kernel must move per cycle, the
//! byte model the roofline divides by the streaming kernel's bandwidth (`gpu::stream`), as the 2D
//! engine's `udec::gpu::profile`.
//!
//! The byte model is each kernel's compulsory traffic, from the Pod structs' sizes (`layout`) and
//! the counts of the scene: every struct a kernel reads counts once a cycle (as if fetched once
//! and then cached; the contacts and logical contacts gather reads from both of their blocks
//! count once), whole (a GPU fetches 32-byte sectors and the kernels read fields all over these
//! 20–400-byte records), and the fields it stores every cycle once:
//!
//! - `gather`: each block record, its adjacency list (two words a contact), each contact and
//!   logical contact; stores the force and moment sums and the dashpots' work (7 reals a block;
//!   a simply-deformable block's applied stress, 9 more);
//! - `law_of_motion`: each block record and vertex (and strain record); stores the motion (20
//!   reals: velocity, angular momentum and velocity, orientation, centroid, travel, peak travel,
//!   work, damping; 3 more in f32, the centroid's low parts), each vertex placed (3 reals) and a
//!   strain record's strain, rate and stress (18 reals);
//! - `track_contact`: each contact, its two bodies' names (two words), every body record, vertex,
//!   face plane and edge word, each logical contact; stores the contact's normal and friction
//!   work (4 reals) and each logical contact's point, gap, normal and shear force (8 reals);
//! - `end_cycle` (a scene with Griffith's candidates): the halting record and the screen's flag.
//!
//! The CPU backend's cycle works on the same data in f64 (and finds the logical contacts afresh
//! every cycle, from the same vertices, planes and edges): its roofline divides the f64 model by
//! the host's copy bandwidth (`bench::d3`).

use crate::gpu::profile::{time_passes, DeviceProfile, Pass, StageBytes};
use crate::gpu::real::Real;
use crate::gpu::{GpuError, Precision};

use super::super::model::Model;
use super::{buffer_items, grids, layout, GpuBackend};

/// The compulsory traffic of each of the cycle's kernels for `model` in precision `R` (module
/// doc).
pub fn bytes_per_cycle<R: Real>(model: &Model) -> Vec<StageBytes> {
    let items = buffer_items::<R>(model);
    let count = |what: &str| items.iter().find(|(label, _, _)| *label == what).map_or(0, |&(_, _, n)| n as u64);
    let bytes = |what: &str| items.iter().find(|(label, _, _)| *label == what).map_or(0, |&(_, item, n)| (item * n) as u64);
    let r = std::mem::size_of::<R>() as u64;
    let block = std::mem::size_of::<layout::Block<R>>() as u64;
    let params = std::mem::size_of::<layout::Params<R>>() as u64;
    let nb = model.blocks.len() as u64;
    let (nk, nl) = (count("contacts"), count("logical contacts"));
    let sdef_blocks = model.blocks.iter().filter(|b| b.is_sdef()).count() as u64;
    let strain = bytes("simply-deformable blocks");
    // The motion's fields a step stores (module doc): f32 keeps the centroid as a pair.
    let motion = if R::PRECISION == Precision::F32 { 23 } else { 20 };
    let mut stages = vec![
        StageBytes {
            stage: "gather",
            read: block * nb + 4 * 2 * nk + bytes("contacts") + bytes("logical contacts") + params,
            written: 7 * r * nb + 9 * r * sdef_blocks,
        },
        StageBytes {
            stage: "law_of_motion",
            read: block * nb + bytes("vertices") + strain + params,
            written: motion * r * nb + 3 * r * count("vertices") + 18 * r * sdef_blocks,
        },
        StageBytes {
            stage: "track_contact",
            read: bytes("contacts")
                + 4 * 2 * nk
                + bytes("blocks")
                + bytes("vertices")
                + bytes("face planes")
                + bytes("edges")
                + bytes("logical contacts")
                + params,
            written: 4 * r * nk + 8 * r * nl,
        },
    ];
    if halting(model) {
        let halt = std::mem::size_of::<layout::Halt>() as u64;
        stages.push(StageBytes { stage: "end_cycle", read: halt + 4 + params, written: halt });
    }
    stages
}

/// Whether `model`'s batches end each cycle with `end_cycle` (Griffith's cracking candidates).
fn halting(model: &Model) -> bool {
    model.blocks.iter().any(|b| b.is_sdef())
}

impl GpuBackend {
    /// The bytes each kernel must move per cycle for `model`, in this backend's precision.
    pub fn bytes_per_cycle(&self, model: &Model) -> Vec<StageBytes> {
        match self.precision() {
            Precision::F32 => bytes_per_cycle::<f32>(model),
            Precision::F64 => bytes_per_cycle::<f64>(model),
        }
    }

    /// Each kernel's device time per cycle over `cycles` cycles, on the state the last run left
    /// on the device for `model` (the model it read back). The cycles move that state on, so the
    /// next run starts afresh from its model (a detection and an upload).
    pub fn profile_kernels(&mut self, model: &Model, cycles: u32) -> Result<DeviceProfile, GpuError> {
        self.resumable = false;
        let Some(s) = self.state.as_ref() else {
            return Err(GpuError::Setup("profile_kernels needs a run first (no state on the device)".into()));
        };
        let kernels = self.scene_kernels();
        let (blocks, contacts) = grids(model);
        let mut passes: Vec<Pass> = ["gather", "law_of_motion", "track_contact"]
            .into_iter()
            .zip(&kernels.pipelines)
            .zip([blocks, blocks, contacts])
            .map(|((label, pipeline), grid)| Pass { label, pipeline, bind_group: &s.bind, grid })
            .collect();
        if let (Some((_, end_bind)), Some((_, end_cycle))) = (&s.halt, &kernels.end_cycle) {
            passes.push(Pass { label: "end_cycle", pipeline: end_cycle, bind_group: end_bind, grid: (1, 1) });
        }
        // Dispatched directly (not from the halting record): a screen that fires halts nothing.
        time_passes(&self.dev, &passes, cycles, &|_| {}, &|| {})
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model_of(deck: &str) -> Model {
        let commands = super::super::super::deck::parse_deck(deck, "<test>").unwrap();
        let mut exec = super::super::super::exec::Executor::new(Box::new(std::io::sink()), "<test>");
        exec.run(&commands).unwrap_or_else(|e| panic!("{e}"));
        std::mem::take(&mut exec.model)
    }

    /// The byte model counts what the scene holds: two stacks apart move twice one stack's bytes
    /// in every kernel (less the params, read once), f64 more than f32, and a simply-deformable
    /// scene adds its strain records and `end_cycle`.
    #[test]
    fn the_byte_model_grows_with_the_scene() {
        let stack = |x: f64| format!("BOX {x} {} -1 2 -1 0\nBOX {} {} 0 1 0 1\nBOX {} {} 0 1 1 2\n", x + 3.0, x + 1.0, x + 2.0, x + 1.0, x + 2.0);
        let head = "START\nPROP MAT=1 D=2000 KN=1E9 KS=1E9 K=1E9 G=1E9\n";
        let tail = "FIX -9 99 -9 9 -0.6 -0.4\nGRAV 0 0 -10\nCYCLE 0\n";
        let one = model_of(&format!("{head}{}{tail}", stack(0.0)));
        let two = model_of(&format!("{head}{}{}{tail}", stack(0.0), stack(10.0)));
        let params = std::mem::size_of::<layout::Params<f32>>() as u64;
        let (b1, b2) = (bytes_per_cycle::<f32>(&one), bytes_per_cycle::<f32>(&two));
        assert_eq!(b1.iter().map(|b| b.stage).collect::<Vec<_>>(), ["gather", "law_of_motion", "track_contact"]);
        for (a, b) in b1.iter().zip(&b2) {
            assert_eq!((b.read - params, b.written), (2 * (a.read - params), 2 * a.written), "{}", a.stage);
        }
        let total = |v: &[StageBytes]| v.iter().map(|b| b.read + b.written).sum::<u64>();
        assert!(total(&bytes_per_cycle::<f64>(&one)) > total(&b1));
        let sdef = model_of(&format!("{head}{}CHANGE -9 99 -9 9 0 9 SDEF\n{tail}", stack(0.0)));
        let bs = bytes_per_cycle::<f32>(&sdef);
        assert_eq!(bs.last().map(|b| b.stage), Some("end_cycle"));
        assert!(bs[1].read > b1[1].read && bs[1].written > b1[1].written);
    }
}

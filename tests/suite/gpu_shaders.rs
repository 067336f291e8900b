//! Shaders are checked without a GPU (STYLE.md item 9): every kernel file in every precision
//! parses and validates with naga, and every GPU struct's size and field offsets, read through
//! naga's type layouter, equal its Rust twin in src/udec/gpu/layout.rs.

use blockdem::udec::gpu::layout::{self, Real, StructLayout};
use blockdem::udec::gpu::shaders;
use blockdem::udec::gpu::Precision;

#[test]
fn every_kernel_parses_and_validates_in_every_precision() {
    for precision in [Precision::F32, Precision::F64] {
        for name in shaders::kernel_names() {
            let src = shaders::source(name, precision).unwrap();
            let (module, _) = shaders::validate(&src, precision).unwrap_or_else(|e| panic!("{name}.wgsl ({precision}):\n{e}"));
            assert!(module.entry_points.iter().any(|e| e.name == name), "{name}.wgsl has an entry point named after it");
        }
    }
}

#[test]
fn f64_kernels_need_the_f64_capability() {
    // The f64 variant really is f64: without the FLOAT64 capability naga rejects it.
    let src = shaders::source("law_of_motion", Precision::F64).unwrap();
    let module = naga::front::wgsl::parse_str(&src).unwrap();
    let strict = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty()).validate(&module);
    assert!(strict.is_err());
}

fn naga_layout(module: &naga::Module, name: &str) -> StructLayout {
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let (handle, ty) = module.types.iter().find(|(_, t)| t.name.as_deref() == Some(name)).unwrap_or_else(|| panic!("no WGSL struct {name}"));
    let naga::TypeInner::Struct { members, span } = &ty.inner else { panic!("{name} is not a struct") };
    let size = layouter[handle].size;
    assert_eq!(size, *span);
    StructLayout {
        name: layout::layouts::<f32>().into_iter().find(|l| l.name == name).unwrap().name,
        size: size as usize,
        fields: members.iter().map(|m| (leak(m.name.clone().unwrap()), m.offset as usize)).collect(),
    }
}

fn leak(s: String) -> &'static str {
    Box::leak(s.into_boxed_str())
}

fn check_layouts<R: Real>(precision: Precision) {
    let src = shaders::source("contact_forces", precision).unwrap();
    let (module, _) = shaders::validate(&src, precision).unwrap();
    for rust in layout::layouts::<R>() {
        let wgsl = naga_layout(&module, rust.name);
        assert_eq!(wgsl, rust, "{} in {precision}: WGSL (left) against Rust (right)", rust.name);
    }
}

#[test]
fn every_gpu_struct_matches_its_rust_twin_in_f32() {
    check_layouts::<f32>(Precision::F32);
}

#[test]
fn every_gpu_struct_matches_its_rust_twin_in_f64() {
    check_layouts::<f64>(Precision::F64);
}

/// The state's slots in Rust (`gpu::kernels::StateSlot`) are common.wgsl's declarations: name,
/// group 0, binding, and uniform / read-only storage / read-write storage.
#[test]
fn the_state_slots_are_common_wgsls_bindings() {
    use blockdem::udec::gpu::kernels::{SlotKind, StateSlot};
    let src = shaders::source("contact_forces", Precision::F32).unwrap();
    let (module, _) = shaders::validate(&src, Precision::F32).unwrap();
    let declared: Vec<_> = module.global_variables.iter().filter(|(_, v)| v.binding.is_some()).map(|(_, v)| v).collect();
    assert_eq!(declared.len(), StateSlot::ALL.len(), "common.wgsl declares one binding per slot");
    for slot in StateSlot::ALL {
        let var = declared.iter().find(|v| v.name.as_deref() == Some(slot.wgsl_name())).unwrap_or_else(|| panic!("no {} in common.wgsl", slot.wgsl_name()));
        let b = var.binding.as_ref().unwrap();
        assert_eq!((b.group, b.binding), (0, slot.binding()), "{slot:?}");
        let kind = match var.space {
            naga::AddressSpace::Uniform => SlotKind::Uniform,
            naga::AddressSpace::Storage { access } if !access.contains(naga::StorageAccess::STORE) => SlotKind::StorageRead,
            naga::AddressSpace::Storage { .. } => SlotKind::StorageReadWrite,
            other => panic!("{slot:?} in {other:?}"),
        };
        assert_eq!(kind, slot.kind(), "{slot:?}");
    }
}

/// Each cycle kernel binds only the state slots its entry point uses (found by naga, the
/// functions it calls included), so the per-stage storage-buffer limit (8, DESIGN.md §3) counts
/// one kernel's buffers: here each kernel's set, in every precision.
#[test]
fn each_cycle_kernel_binds_only_what_it_uses() {
    use blockdem::udec::gpu::kernels::{used_slots, SlotKind, StateSlot::*};
    for precision in [Precision::F32, Precision::F64] {
        let slots = |file: &str, entry: &str| {
            let src = shaders::source(file, precision).unwrap();
            let (module, info) = shaders::validate(&src, precision).unwrap();
            used_slots(&module, &info, entry).unwrap()
        };
        // The block pass sums the contact forces over the adjacency (gather.wgsl's force_sum,
        // called from law_of_motion), moves the block, places its corners and flags errors.
        assert_eq!(slots("law_of_motion", "law_of_motion"), [Params, Blocks, Corners, AdjOffsets, AdjEntries, Flags, ContactForces]);
        // The contact stage: no adjacency, no energy sums.
        let contact = slots("contact_forces", "contact_forces");
        assert!(!contact.contains(&AdjOffsets) && !contact.contains(&AdjEntries) && !contact.contains(&EnergySums), "{contact:?}");
        assert!(contact.contains(&Contacts) && contact.contains(&ContactForces) && contact.contains(&Materials), "{contact:?}");
        assert_eq!(slots("gather", "gather"), [Params, Blocks, AdjOffsets, AdjEntries, ContactForces]);
        // Only the SDEF entry points bind the SDEF slots (a rigid scene binds nothing of them).
        assert_eq!(slots("law_of_motion", "law_of_motion_sdef"), [Params, Blocks, Corners, AdjOffsets, AdjEntries, Flags, ContactForces, Sdefs, ContactLevers]);
        for (file, entry) in [("contact_forces", "contact_forces"), ("gather", "gather"), ("gather", "gather_heavy"), ("energy_sums", "energy_sums")] {
            let s = slots(file, entry);
            assert!(!s.contains(&Sdefs) && !s.contains(&ContactLevers), "{entry} binds an SDEF slot: {s:?}");
        }
        // Only the FDEF entry points bind the FDEF slots (a rigid or SDEF scene binds nothing of
        // them).
        let fdef_slots = [GridPoints, Zones, FdefBlocks, GridPointZones, ContactShares];
        for (file, entry) in [
            ("law_of_motion", "law_of_motion"),
            ("law_of_motion", "law_of_motion_sdef"),
            ("contact_forces", "contact_forces"),
            ("contact_forces", "contact_forces_sdef"),
            ("contact_forces", "contact_points"),
            ("gather", "gather"),
            ("gather", "gather_sdef"),
            ("gather", "gather_heavy"),
            ("energy_sums", "energy_sums"),
            ("energy_sums", "energy_sums_sdef"),
        ] {
            let s = slots(file, entry);
            assert!(!s.iter().any(|x| fdef_slots.contains(x)), "{entry} binds an FDEF slot: {s:?}");
        }
        assert_eq!(
            slots("law_of_motion", "law_of_motion_fdef"),
            [Params, Blocks, Corners, AdjOffsets, AdjEntries, Flags, ContactForces, GridPoints, FdefBlocks]
        );
        assert_eq!(slots("zones", "gather_gridpoints"), [Params, AdjOffsets, AdjEntries, ContactForces, GridPoints, Zones, GridPointZones, ContactShares]);
        assert_eq!(slots("zones", "step_gridpoints"), [Params, Flags, GridPoints]);
        // A large zoned block's corners (a workgroup each) and the check of the grid points'
        // contact lists against the contacts' features.
        assert_eq!(slots("law_of_motion", "place_fdef_corners"), [Params, Blocks, Corners, Flags, GridPoints, FdefBlocks, GridPointZones]);
        assert_eq!(slots("zones", "check_fdef_lists"), [Params, Contacts, GridPoints, FdefBlocks, GridPointZones]);
        assert_eq!(slots("zones", "zones"), [Params, Flags, GridPoints, Zones, FdefBlocks]);
        assert!(slots("contact_forces", "contact_forces_fdef").contains(&ContactShares));
        assert_eq!(slots("gather", "gather_fdef"), [Params, Blocks, AdjOffsets, AdjEntries, ContactForces]);
        assert!(slots("energy_sums", "energy_sums_fdef").contains(&Zones));
        assert!(slots("contact_forces", "contact_forces_sdef").contains(&ContactLevers));
        assert!(slots("energy_sums", "energy_sums_sdef").contains(&Sdefs));
        // Only the fluid's entry points bind the fluid's slots (a dry scene binds nothing of
        // them), each at most 8 storage buffers.
        let fluid_slots = [FluidParams, FluidMaterials, Domains, DomainFlows, DomainLinks, ContactSides, ContactFlows, FluidLoads, DomainTerms, TermItems];
        for (file, entry) in [
            ("law_of_motion", "law_of_motion"),
            ("law_of_motion", "law_of_motion_sdef"),
            ("law_of_motion", "law_of_motion_fdef"),
            ("contact_forces", "contact_forces"),
            ("contact_forces", "contact_points"),
            ("gather", "gather"),
            ("gather", "gather_heavy"),
            ("energy_sums", "energy_sums"),
            ("zones", "gather_gridpoints"),
        ] {
            let s = slots(file, entry);
            assert!(!s.iter().any(|x| fluid_slots.contains(x)), "{entry} binds a fluid slot: {s:?}");
        }
        assert_eq!(
            slots("law_of_motion", "law_of_motion_fluid"),
            [Params, Blocks, Corners, AdjOffsets, AdjEntries, Flags, ContactForces, ContactFlows, FluidLoads]
        );
        assert_eq!(slots("gather", "gather_fluid"), [Params, Blocks, AdjOffsets, AdjEntries, ContactForces, ContactFlows, FluidLoads]);
        assert_eq!(slots("energy_sums", "energy_sums_fluid"), [Params, EnergySums, FluidLoads]);
        assert_eq!(slots("flow", "flow"), [Params, Blocks, Corners, Contacts, Materials, Flags, FluidMaterials, Domains, ContactSides, ContactFlows]);
        // A long domain's sums from the terms `domain_terms` computed (`gpu::flow::LONG_WALK`).
        assert_eq!(
            slots("flow", "domain_terms"),
            [Params, Blocks, Corners, Contacts, FluidParams, DomainFlows, DomainLinks, ContactFlows, DomainTerms, TermItems]
        );
        assert_eq!(
            slots("flow", "domain_pressures"),
            [Params, Blocks, Corners, Contacts, FluidParams, Domains, DomainFlows, DomainLinks, ContactFlows, DomainTerms]
        );
        // The pressure loads are summed in the block pass (`force_sum_fluid`): flow.wgsl has no
        // pass over the blocks, and the block pass reads the pressures from the contacts' flow
        // slots, within the 8 storage buffers.
        let (flow, _) = shaders::validate(&shaders::source("flow", precision).unwrap(), precision).unwrap();
        assert_eq!(
            flow.entry_points.iter().map(|e| e.name.as_str()).collect::<Vec<_>>(),
            ["flow", "domain_terms", "corner_moves_sdef", "corner_moves_fdef", "deformed_terms", "domain_pressures", "pressure_pieces"]
        );
        // The pressures' push on deformable blocks: only the kernels of fluid with deformable
        // blocks bind its slots (a dry scene, and a scene with fluid and rigid blocks only, bind
        // nothing of them), each within the 8 storage buffers.
        let wet_slots = [FluidPieces, BlockPieces, BlockFluid, GridPointFluid, CornerMoves];
        for (file, entry) in [
            ("law_of_motion", "law_of_motion"),
            ("law_of_motion", "law_of_motion_sdef"),
            ("law_of_motion", "law_of_motion_fdef"),
            ("law_of_motion", "law_of_motion_fluid"),
            ("contact_forces", "contact_forces"),
            ("contact_forces", "contact_forces_sdef"),
            ("contact_forces", "contact_forces_fdef"),
            ("gather", "gather"),
            ("gather", "gather_sdef"),
            ("gather", "gather_fdef"),
            ("gather", "gather_fluid"),
            ("gather", "gather_heavy"),
            ("zones", "gather_gridpoints"),
            ("zones", "step_gridpoints"),
            ("flow", "flow"),
            ("flow", "domain_pressures"),
            ("energy_sums", "energy_sums_fluid"),
        ] {
            let s = slots(file, entry);
            assert!(!s.iter().any(|x| wet_slots.contains(x)), "{entry} binds a slot of fluid with deformable blocks: {s:?}");
        }
        assert_eq!(slots("flow", "pressure_pieces"), [Blocks, Corners, Contacts, FluidParams, Domains, DomainLinks, ContactFlows, FluidPieces]);
        assert_eq!(
            slots("gather", "fluid_block_loads"),
            [Params, Blocks, AdjOffsets, AdjEntries, ContactFlows, FluidLoads, FluidPieces, BlockPieces, BlockFluid]
        );
        assert_eq!(slots("gather", "gather_sdef_fluid"), [Params, Blocks, Sdefs, BlockFluid]);
        assert_eq!(slots("gather", "gather_fdef_fluid"), [Params, Blocks, BlockFluid]);
        assert_eq!(slots("law_of_motion", "law_of_motion_sdef_fluid"), [Params, Blocks, Corners, Flags, Sdefs, FluidLoads, BlockFluid]);
        assert_eq!(
            slots("law_of_motion", "law_of_motion_fdef_fluid"),
            [Params, Blocks, Corners, Flags, GridPoints, FdefBlocks, FluidLoads, BlockFluid, GridPointFluid]
        );
        assert_eq!(slots("zones", "gridpoint_fluid_loads"), [Params, Blocks, GridPoints, FdefBlocks, FluidLoads, FluidPieces, BlockPieces, GridPointFluid]);
        assert_eq!(
            slots("zones", "gather_gridpoints_fluid"),
            [Params, AdjOffsets, AdjEntries, ContactForces, GridPoints, Zones, GridPointZones, ContactShares, GridPointFluid]
        );
        assert_eq!(slots("zones", "step_gridpoints_fluid"), [Params, Flags, GridPoints, GridPointFluid]);
        // The f32 voids of deformable blocks followed by their boundary's motion: each corner's
        // move, then each edge's term of the change, within the 8 storage buffers.
        assert_eq!(slots("flow", "corner_moves_sdef"), [Params, Blocks, Corners, Sdefs, CornerMoves]);
        assert_eq!(slots("flow", "corner_moves_fdef"), [Params, Blocks, Corners, GridPoints, FdefBlocks, CornerMoves]);
        assert_eq!(slots("flow", "deformed_terms"), [Blocks, Corners, Contacts, FluidParams, DomainLinks, ContactFlows, DomainTerms, TermItems, CornerMoves]);
        for (file, entry) in [
            ("flow", "corner_moves_sdef"),
            ("flow", "corner_moves_fdef"),
            ("flow", "deformed_terms"),
            ("flow", "pressure_pieces"),
            ("gather", "fluid_block_loads"),
            ("gather", "gather_sdef_fluid"),
            ("gather", "gather_fdef_fluid"),
            ("law_of_motion", "law_of_motion_sdef_fluid"),
            ("law_of_motion", "law_of_motion_fdef_fluid"),
            ("zones", "gridpoint_fluid_loads"),
            ("zones", "gather_gridpoints_fluid"),
            ("zones", "step_gridpoints_fluid"),
        ] {
            let s = slots(file, entry);
            assert!(s.iter().filter(|x| x.kind() != SlotKind::Uniform).count() <= 8, "{entry}: {s:?}");
        }
        for (file, entry) in
            [("flow", "flow"), ("flow", "domain_terms"), ("flow", "domain_pressures"), ("law_of_motion", "law_of_motion_fluid"), ("gather", "gather_fluid")]
        {
            let s = slots(file, entry);
            assert!(s.iter().filter(|x| x.kind() != SlotKind::Uniform).count() <= 8, "{entry}: {s:?}");
        }
        let energy = slots("energy_sums", "energy_sums");
        assert!(energy.contains(&EnergySums) && !energy.contains(&AdjEntries), "{energy:?}");
        for (file, entry) in [
            ("law_of_motion", "law_of_motion"),
            ("contact_forces", "contact_forces"),
            ("contact_forces", "contact_points"),
            ("gather", "gather"),
            ("gather", "gather_heavy"),
            ("energy_sums", "energy_sums"),
            ("law_of_motion", "law_of_motion_sdef"),
            ("contact_forces", "contact_forces_sdef"),
            ("gather", "gather_sdef"),
            ("energy_sums", "energy_sums_sdef"),
            ("zones", "gather_gridpoints"),
            ("zones", "step_gridpoints"),
            ("zones", "zones"),
            ("law_of_motion", "law_of_motion_fdef"),
            ("contact_forces", "contact_forces_fdef"),
            ("gather", "gather_fdef"),
            ("energy_sums", "energy_sums_fdef"),
        ] {
            let s = slots(file, entry);
            let storage = s.iter().filter(|x| x.kind() != SlotKind::Uniform).count();
            assert!(storage <= 8, "{entry} ({precision}) binds {storage} storage buffers: {s:?}");
            assert!(s.len() < blockdem::udec::gpu::kernels::StateSlot::ALL.len(), "{entry} binds every slot: {s:?}");
        }
    }
}

/// D3's kernels (`shaders/d3/`) parse and validate in both precisions, each with its entry point.
#[test]
fn every_d3_kernel_parses_and_validates_in_every_precision() {
    use blockdem::d3::gpu::shaders as d3;
    for precision in [Precision::F32, Precision::F64] {
        for (name, _) in d3::KERNELS {
            let src = d3::source(name, precision).unwrap();
            let (module, _) = shaders::validate(&src, precision).unwrap_or_else(|e| panic!("d3/{name}.wgsl ({precision}):\n{e}"));
            assert!(module.entry_points.iter().any(|e| e.name == *name), "d3/{name}.wgsl has an entry point named after it");
        }
    }
}

fn check_d3_layouts<R: Real>(precision: Precision) {
    use blockdem::d3::gpu::{layout as d3_layout, shaders as d3};
    check_layouts_in(&d3::source("track_contact", precision).unwrap(), precision, d3_layout::layouts::<R>());
}

/// Each of `layouts` (Rust's) against the WGSL struct of its name in `src`: size and offsets.
fn check_layouts_in(src: &str, precision: Precision, layouts: Vec<StructLayout>) {
    let (module, _) = shaders::validate(src, precision).unwrap();
    for rust in layouts {
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        let (handle, ty) = module.types.iter().find(|(_, t)| t.name.as_deref() == Some(rust.name)).unwrap_or_else(|| panic!("no WGSL struct {}", rust.name));
        let naga::TypeInner::Struct { members, span } = &ty.inner else { panic!("{} is not a struct", rust.name) };
        assert_eq!(layouter[handle].size, *span);
        let wgsl = StructLayout {
            name: rust.name,
            size: *span as usize,
            fields: members.iter().map(|m| (leak(m.name.clone().unwrap()), m.offset as usize)).collect(),
        };
        assert_eq!(wgsl, rust, "D3's {} in {precision}: WGSL (left) against Rust (right)", rust.name);
    }
}

/// Every D3 GPU struct (`d3::gpu::layout`) has its WGSL twin's size and field offsets.
#[test]
fn every_d3_gpu_struct_matches_its_rust_twin_in_f32() {
    check_d3_layouts::<f32>(Precision::F32);
}

#[test]
fn every_d3_gpu_struct_matches_its_rust_twin_in_f64() {
    check_d3_layouts::<f64>(Precision::F64);
}

/// D3's kernels with the strain stage of simply-deformable blocks (`shaders/d3/sdef.wgsl`) parse
/// and validate in both precisions, and bind the strain buffer where the rigid ones do not.
#[test]
fn every_d3_kernel_with_the_strain_stage_parses_and_validates() {
    use blockdem::d3::gpu::shaders as d3;
    for precision in [Precision::F32, Precision::F64] {
        for (name, _) in d3::KERNELS {
            let src = d3::source_for(name, precision, true).unwrap();
            shaders::validate(&src, precision).unwrap_or_else(|e| panic!("d3/{name}.wgsl with SDEF ({precision}):\n{e}"));
            assert!(src.contains("@binding(8)") && !d3::source(name, precision).unwrap().contains("@binding(8)"));
        }
    }
}

fn check_d3_sdef_layout<R: Real>(precision: Precision) {
    use blockdem::d3::gpu::{layout as d3_layout, shaders as d3};
    check_layouts_in(&d3::source_for("law_of_motion", precision, true).unwrap(), precision, d3_layout::sdef_layouts::<R>());
}

/// The strain buffer's struct (`d3::gpu::layout::SdefBlock`) has its WGSL twin's size and offsets.
#[test]
fn the_d3_strain_struct_matches_its_rust_twin() {
    check_d3_sdef_layout::<f32>(Precision::F32);
    check_d3_sdef_layout::<f64>(Precision::F64);
}

/// D3's `end_cycle` (shaders/d3/end_cycle.wgsl, the cycle's last kernel in a scene with
/// Griffith's cracking candidates) parses and validates in both precisions with its entry point,
/// its halting record has the Rust twin's layout (`d3::gpu::layout::Halt`), and it binds the
/// params, the strain buffer (the screen's flag) and its record alone.
#[test]
fn the_d3_end_cycle_kernel_and_its_halting_record_match_their_twins() {
    use blockdem::d3::gpu::{layout as d3_layout, shaders as d3};
    for precision in [Precision::F32, Precision::F64] {
        let src = d3::end_cycle_source(precision);
        let (module, _) = shaders::validate(&src, precision).unwrap_or_else(|e| panic!("d3/end_cycle.wgsl ({precision}):\n{e}"));
        assert!(module.entry_points.iter().any(|e| e.name == "end_cycle"));
        check_layouts_in(&src, precision, d3_layout::halt_layouts());
        assert!(src.contains("@binding(9) var<storage, read_write> halt: Halt"));
    }
}

/// D3's `contact_energy` (shaders/d3/contact_energy.wgsl, the energy check's contact sums)
/// parses and validates in both precisions with its entry point, its record has the Rust twin's
/// layout (`d3::gpu::layout::ContactEnergy`), its items per invocation are the Rust side's, and
/// it writes its own binding 9; so does `critical_rows` (shaders/d3/critical_rows.wgsl, the time
/// step's rows on the device) with its record `StepGive` at binding 9, and `splice_contacts`
/// (shaders/d3/splice_contacts.wgsl, a partial detection's splice) with its `Banked` and
/// `Splice`, and the fresh sources' bit of the Rust side; `renew_blocks` (its moved blocks' bit).
#[test]
fn the_d3_contact_energy_kernel_and_its_record_match_their_twins() {
    use blockdem::d3::gpu::{layout as d3_layout, shaders as d3};
    /// A kernel of its own (`name`, its source `src`) validates with its entry point, its records
    /// have their Rust twins' layouts, and its source declares `binding`.
    fn check(name: &str, src: String, precision: Precision, layouts: Vec<StructLayout>, binding: &str) {
        let (module, _) = shaders::validate(&src, precision).unwrap_or_else(|e| panic!("d3/{name}.wgsl ({precision}):\n{e}"));
        assert!(module.entry_points.iter().any(|e| e.name == name));
        check_layouts_in(&src, precision, layouts);
        assert!(src.contains(binding), "{name}: {binding}");
    }
    fn both<R: Real>(precision: Precision) {
        let energy = d3::contact_energy_source(precision);
        assert!(energy.contains(&format!("const ENERGY_ITEMS: u32 = {}u;", d3_layout::ENERGY_ITEMS)));
        check("contact_energy", energy, precision, d3_layout::energy_layouts::<R>(), "@binding(9) var<storage, read_write> energy_out: array<ContactEnergy>");
        check(
            "critical_rows",
            d3::critical_rows_source(precision),
            precision,
            d3_layout::step_layouts::<R>(),
            "@binding(9) var<storage, read_write> gives: array<StepGive>",
        );
        let splice = d3::splice_contacts_source(precision);
        assert!(splice.contains(&format!("const SPLICE_FRESH: u32 = {:#x}u;", d3_layout::SPLICE_FRESH)));
        check("splice_contacts", splice, precision, d3_layout::splice_layouts::<R>(), "@binding(15) var<storage, read_write> banked: array<Banked>");
        let renew = d3::renew_blocks_source(precision);
        assert!(renew.contains(&format!("const RENEW_MOVED: u32 = {:#x}u;", d3_layout::RENEW_MOVED)));
        check("renew_blocks", renew, precision, d3_layout::layouts::<R>(), "@binding(9) var<storage, read> renewals: array<vec2<u32>>");
    }
    both::<f32>(Precision::F32);
    both::<f64>(Precision::F64);
}

/// D3's kernels with the boundary conditions (BOUNDARY, `d3::gpu::shaders::source_with`) parse
/// and validate in both precisions, with and without the strain stage, and bind no buffer more
/// than the kernels without them (the loaded faces are records in the plane buffer): at most
/// eight storage buffers.
#[test]
fn every_d3_kernel_with_the_boundary_conditions_parses_and_validates() {
    use blockdem::d3::gpu::shaders as d3;
    for precision in [Precision::F32, Precision::F64] {
        for sdef in [false, true] {
            for (name, _) in d3::KERNELS {
                let src = d3::source_with(name, precision, sdef, true).unwrap();
                assert!(src.contains("const BOUNDARY: bool = true;"));
                shaders::validate(&src, precision).unwrap_or_else(|e| panic!("d3/{name}.wgsl with BOUNDARY, SDEF {sdef} ({precision}):\n{e}"));
                let storage = src.matches("var<storage").count();
                assert_eq!(storage, d3::source_for(name, precision, sdef).unwrap().matches("var<storage").count());
                assert!(storage <= 8, "d3/{name}.wgsl binds {storage} storage buffers");
            }
        }
    }
}

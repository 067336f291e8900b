// Stage 7's adjacency lists on the device (twins in `gpu::splice`): a contact update that made or
// dropped contacts changes the lists of the blocks it touched, renumbers every other entry (the
// contacts after a change move in the list) and moves the offsets after each changed list. The
// CPU has made that edit to its own lists (`Adjacency::apply`) and sends it in proportion to the
// changes, instead of the lists whole (4 bytes an entry).
//
// `splice_adjacency`: the new entries as runs (`EntriesEdit::runs`), each (first new position,
// source) with the source an old position or, with FROM_LISTS set, a position in `lists` (the
// touched blocks' new lists); the runs end with (new length, 0). An old entry (contact·2 + side)
// takes its contact's new index: the contact plus the insertions at or before it less the
// removals before it, tabulated in `renumber` as (first old index, that shift), ascending.
//
// `shift_offsets`: each block's offset, in place, moved by the change in length of the touched
// lists before it; `touched` holds (block, the change up to and including its list), ascending,
// and ends with (the number of offsets, 0). The blocks `gather_heavy` sums, listed after the
// offsets, are the CPU's to write.

const FROM_LISTS: u32 = 0x80000000u;

@group(0) @binding(0) var<storage, read> old_entries: array<u32>;
@group(0) @binding(1) var<storage, read> runs: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> lists: array<u32>;
@group(0) @binding(3) var<storage, read> renumber: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read_write> new_entries: array<u32>;
@group(0) @binding(5) var<storage, read_write> offsets: array<u32>;
@group(0) @binding(6) var<storage, read> touched: array<vec2<u32>>;

// The new index of kept contact k.
fn renumbered(k: u32) -> u32 {
    // renumber[lo].x <= k < renumber[hi].x (renumber[0].x is 0)
    var lo = 0u;
    var hi = arrayLength(&renumber);
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (renumber[mid].x <= k) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return u32(i32(k) + bitcast<i32>(renumber[lo].y));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn splice_adjacency(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let p = item_index(wg, li);
    let last = arrayLength(&runs) - 1u;
    if (p >= runs[last].x) {
        return;
    }
    var lo = 0u;
    var hi = last;
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (runs[mid].x <= p) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let r = runs[lo];
    let at = (r.y & ~FROM_LISTS) + (p - r.x);
    if ((r.y & FROM_LISTS) != 0u) {
        new_entries[p] = lists[at];
        return;
    }
    let e = old_entries[at];
    new_entries[p] = make_entry(renumbered(entry_contact(e)), entry_side(e));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn shift_offsets(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = item_index(wg, li);
    let last = arrayLength(&touched) - 1u;
    if (b >= touched[last].x) {
        return;
    }
    // The touched blocks before b: touched[0 .. n) with n the first whose block is not below b.
    var lo = 0u;
    var hi = last;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (touched[mid].x < b) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    if (lo > 0u) {
        offsets[b] = u32(i32(offsets[b]) + bitcast<i32>(touched[lo - 1u].y));
    }
}

// The bandwidth yardstick of `blockdem bench` (Rust twin: `gpu::profile::stream_bandwidth`, and on
// the host `bench::host::host_copy_bandwidth`): a streaming copy of 16-byte words between two
// buffers far larger than any cache, so that every word is read from and written to the device's
// memory once. The bytes it moves over its time (read + written) is what the card's memory delivers
// to a kernel that does nothing else, the ceiling the cycle's byte model is measured against
// (the roofline of the bench; `copy_buffer_to_buffer` can go through a copy engine at a fraction of it).
//
// A grid-stride loop: consecutive invocations touch consecutive words (coalesced), and a grid of at
// most GROUPS_PER_ROW workgroups covers any length.

@group(0) @binding(0) var<storage, read> stream_src: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> stream_dst: array<vec4<u32>>;

@compute @workgroup_size(STREAM_WORKGROUP_SIZE)
fn stream_copy(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let n = arrayLength(&stream_dst);
    let stride = groups.x * STREAM_WORKGROUP_SIZE;
    for (var i = gid.x; i < n; i += stride) {
        stream_dst[i] = stream_src[i];
    }
}

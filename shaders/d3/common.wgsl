// Helpers of D3's cycle kernels: vector and quaternion arithmetic written out in glam's order of
// operations (so that the f64 kernels round as the CPU's f64 does, as far as the compiler keeps
// it), and the readings of a block's state. Rust twins: glam's DVec3, DQuat and DMat3 methods.

fn dot3(a: vec3<real>, b: vec3<real>) -> real {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn cross3(a: vec3<real>, b: vec3<real>) -> vec3<real> {
    return vec3<real>(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
}

fn length3(a: vec3<real>) -> real {
    return sqrt(dot3(a, a));
}

// v / |v| as glam's `normalize`: v times the reciprocal of its length.
fn normalize3(a: vec3<real>) -> vec3<real> {
    return a * (1.0 / length3(a));
}

// The rotation of v by the unit quaternion q (glam's `DQuat::mul_vec3`).
fn quat_rotate(q: vec4<real>, v: vec3<real>) -> vec3<real> {
    let w = q.w;
    let b = q.xyz;
    let b2 = dot3(b, b);
    return v * (w * w - b2) + b * (dot3(v, b) * 2.0) + cross3(b, v) * (w * 2.0);
}

// The product a·b (glam's `DQuat::mul_quat`): the rotation b, then a.
fn quat_mul(a: vec4<real>, b: vec4<real>) -> vec4<real> {
    return vec4<real>(
        a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
        a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
        a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
        a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
    );
}

fn quat_normalize(q: vec4<real>) -> vec4<real> {
    let len = sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
    return q * (1.0 / len);
}

// The inverse of a unit quaternion: its conjugate.
fn quat_inverse(q: vec4<real>) -> vec4<real> {
    return vec4<real>(-q.x, -q.y, -q.z, q.w);
}

// The rotation by the angle |v| about v (glam's `DQuat::from_scaled_axis`); sin and cos of the
// half angle by `sin_cos` (shaders/math.wgsl: f64 kernels have no sin/cos).
fn quat_from_scaled_axis(v: vec3<real>) -> vec4<real> {
    let len = length3(v);
    if (len == 0.0) {
        return vec4<real>(0.0, 0.0, 0.0, 1.0);
    }
    let axis = v / len;
    let cs = sin_cos(len * 0.5);
    let s = axis * cs.y;
    return vec4<real>(s.x, s.y, s.z, cs.x);
}

// A 3 × 3 matrix by its columns.
struct Mat3 {
    x: vec3<real>,
    y: vec3<real>,
    z: vec3<real>,
}

// M v, column by column as glam's `DMat3::mul_vec3`.
fn mat_mul(m: Mat3, v: vec3<real>) -> vec3<real> {
    var r = m.x * v.x;
    r = r + m.y * v.y;
    r = r + m.z * v.z;
    return r;
}

// r fᵀ by columns (`sdef::applied`: a simply-deformable block's applied stress times volume).
fn outer(r: vec3<real>, f: vec3<real>) -> Mat3 {
    return Mat3(r * f.x, r * f.y, r * f.z);
}

fn mat_add(a: Mat3, b: Mat3) -> Mat3 {
    return Mat3(a.x + b.x, a.y + b.y, a.z + b.z);
}

fn mat_sub(a: Mat3, b: Mat3) -> Mat3 {
    return Mat3(a.x - b.x, a.y - b.y, a.z - b.z);
}

// The rotation matrix of a unit quaternion (glam's `DMat3::from_quat`).
fn rotation_matrix(q: vec4<real>) -> Mat3 {
    let x2 = q.x + q.x;
    let y2 = q.y + q.y;
    let z2 = q.z + q.z;
    let xx = q.x * x2;
    let xy = q.x * y2;
    let xz = q.x * z2;
    let yy = q.y * y2;
    let yz = q.y * z2;
    let zz = q.z * z2;
    let wx = q.w * x2;
    let wy = q.w * y2;
    let wz = q.w * z2;
    return Mat3(
        vec3<real>(1.0 - (yy + zz), xy + wz, xz - wy),
        vec3<real>(xy - wz, 1.0 - (xx + zz), yz + wx),
        vec3<real>(xz + wy, yz - wx, 1.0 - (xx + yy)),
    );
}

fn centroid(i: u32) -> vec3<real> {
    return vec3<real>(blocks[i].cx, blocks[i].cy, blocks[i].cz);
}

fn orientation(i: u32) -> vec4<real> {
    return vec4<real>(blocks[i].qx, blocks[i].qy, blocks[i].qz, blocks[i].qw);
}

// Vertex i as stage 2 placed it: in f64 its position, in f32 (RELATIVE) its offset R·l from its
// block's centroid.
fn vertex(i: u32) -> vec3<real> {
    return vec3<real>(vertices[i].x, vertices[i].y, vertices[i].z);
}

// Block i's centroid less block `origin`'s, as a pair hi + lo of reals (f32, RELATIVE): the high
// parts' difference and its rounding error (`two_sum`, exact), the low parts' difference added to
// that error. Used where the f32 kernels work in a contact's frame (`centroid_from`,
// track_contact.wgsl's `block_vertex`).
struct Pair {
    hi: vec3<real>,
    lo: vec3<real>,
}

fn centroid_pair_from(i: u32, origin: u32) -> Pair {
    let one = params.one;
    let x = two_sum(blocks[i].cx, -blocks[origin].cx, one);
    let y = two_sum(blocks[i].cy, -blocks[origin].cy, one);
    let z = two_sum(blocks[i].cz, -blocks[origin].cz, one);
    let lo = vec3<real>(blocks[i].cx_lo - blocks[origin].cx_lo, blocks[i].cy_lo - blocks[origin].cy_lo, blocks[i].cz_lo - blocks[origin].cz_lo);
    return Pair(vec3<real>(x.x, y.x, z.x), vec3<real>(x.y, y.y, z.y) + lo);
}

// Block i's centroid in the frame of block `origin` (the read-back: `gpu::point_origin`). In f32
// (RELATIVE) a contact's geometry is worked in a frame of its own (track_contact.wgsl) and its
// points are kept from its block 1's centroid, so that a gap's resolution is set by the blocks'
// size rather than their distance from the origin (a normal force kn·gap quantised at
// kn·ulp(|x|) rang a settled stack at z = 1…4 m, and at 1000 m the quantum is kn·6e-5 m): the
// centroids' difference (`centroid_pair_from`) rounded once, at its own size. In f64 (absolute
// geometry): block i's centroid.
fn centroid_from(i: u32, origin: u32) -> vec3<real> {
    if (RELATIVE) {
        if (i == origin) {
            return vec3<real>(0.0, 0.0, 0.0);
        }
        let d = centroid_pair_from(i, origin);
        return d.hi + d.lo;
    }
    return centroid(i);
}

// The velocity of block i's material point at p (eq. 11; `Block::velocity_at`): v + ω × (p − c),
// with p in the frame of block `origin` (`centroid_from`; in f64 global axes); and ε̇·(p − c) of a
// simply-deformable block's strain rate (SDEF scenes, sdef.wgsl).
fn velocity_at(i: u32, p: vec3<real>, origin: u32) -> vec3<real> {
    let v = vec3<real>(blocks[i].vx, blocks[i].vy, blocks[i].vz);
    let w = vec3<real>(blocks[i].wx, blocks[i].wy, blocks[i].wz);
    if (SDEF) {
        let r = p - centroid_from(i, origin);
        return v + cross3(w, r) + strain_velocity(i, r);
    }
    return v + cross3(w, p - centroid_from(i, origin));
}

fn normal_of(c: Contact) -> vec3<real> {
    return vec3<real>(c.nx, c.ny, c.nz);
}

fn point_of(l: Logical) -> vec3<real> {
    return vec3<real>(l.px, l.py, l.pz);
}

fn shear_of(l: Logical) -> vec3<real> {
    return vec3<real>(l.sx, l.sy, l.sz);
}

// A face of block i loaded by BOUNDARY STRESS (¶35e): the lever r of its centroid from `c0` and
// the resultant t = σ·a of its uniform traction, a = ½ (p₁ − p₀) × (p₂ − p₀) its outward area
// vector (faces run counter-clockwise from outside) from its vertices as placed; its two records
// from `k` in the plane buffer (`Plane`). `c0` is the block's centroid in the frame of its
// vertices: the centroid in f64, 0 in f32 (RELATIVE: the vertices are offsets from it). Rust
// twin: `Block::face_traction`.
struct FaceLoad {
    r: vec3<real>,
    t: vec3<real>,
}

fn face_load(k: u32, c0: vec3<real>) -> FaceLoad {
    let a = planes[k];
    let b = planes[k + 1u];
    let p0 = vertex(a.vertex);
    let p1 = vertex(a.spare);
    let p2 = vertex(b.vertex);
    let area = cross3(p1 - p0, p2 - p0) * 0.5;
    let r = (p0 + p1 + p2) / 3.0 - c0;
    // σ by columns from its Voigt components (`sdef::tensor`).
    let sigma = Mat3(vec3<real>(a.nx, b.nx, b.ny), vec3<real>(b.nx, a.ny, b.nz), vec3<real>(b.ny, b.nz, a.nz));
    return FaceLoad(r, mat_mul(sigma, area));
}

// The first record of block i's loaded faces: after its face planes.
fn stress_records(i: u32) -> u32 {
    return blocks[i].plane_start + blocks[i].plane_count;
}

// The work block i's boundary stresses do over a step that moves it by dx, turns it at omega and
// strains it at its strain rate, its vertices still where the step began about c0 (`face_load`):
// each face's resultant times its centroid's travel, t·(Δx + (ω × r + ε̇ r) Δt). Rust twin:
// `Block::boundary_work`.
fn boundary_work(i: u32, c0: vec3<real>, dx: vec3<real>, omega: vec3<real>, dt: real) -> real {
    var work: real = 0.0;
    let start = stress_records(i);
    for (var k = 0u; k < blocks[i].stress_faces; k++) {
        let l = face_load(start + 2u * k, c0);
        var u = cross3(omega, l.r);
        if (SDEF) {
            u = u + strain_velocity(i, l.r);
        }
        work += dot3(l.t, dx + u * dt);
    }
    return work;
}

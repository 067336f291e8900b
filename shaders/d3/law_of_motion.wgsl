// Stages 1 and 2 for D3, one invocation per block (Rust twin: `d3::motion::law_of_motion`):
// central differences for the velocity and the angular momentum with mass-proportional damping
// (eqs. 9–10, UDEC's CON1/CON2), the orientation by the implicit midpoint rule (`rotate`), and
// the vertices placed (`Block::place_vertices`). The work of gravity, load and boundary
// stresses, the damping's dissipation and the travel (¶26) are added to the block's sums; a block
// held by BOUNDARY VELOCITY steps by `held_motion` (BOUNDARY scenes).

// Fixed-point iterations of the midpoint orientation (`motion::MIDPOINT_ITERATIONS`; the CPU
// stops early where an iteration repeats its input bit for bit, which gives the same answer).
const MIDPOINT_ITERATIONS: u32 = 4u;

// ω = R I₀⁻¹ Rᵀ L at orientation q (Rust twin: `motion::angular_velocity`).
fn angular_velocity(q: vec4<real>, inv: Mat3, l: vec3<real>) -> vec3<real> {
    return quat_rotate(q, mat_mul(inv, quat_rotate(quat_inverse(q), l)));
}

// The orientation and angular velocity after one step under the angular momentum l (Rust twin:
// `motion::rotate`).
struct Turn {
    q: vec4<real>,
    omega: vec3<real>,
}

fn rotate(q: vec4<real>, inv: Mat3, l: vec3<real>, dt: real) -> Turn {
    if (l.x == 0.0 && l.y == 0.0 && l.z == 0.0) {
        return Turn(q, vec3<real>(0.0, 0.0, 0.0));
    }
    var omega = angular_velocity(q, inv, l);
    for (var k = 0u; k < MIDPOINT_ITERATIONS; k++) {
        let mid = quat_normalize(quat_mul(quat_from_scaled_axis(omega * (0.5 * dt)), q));
        omega = angular_velocity(mid, inv, l);
    }
    return Turn(quat_normalize(quat_mul(quat_from_scaled_axis(omega * dt), q)), omega);
}

fn all_finite(v: vec3<real>) -> bool {
    return is_finite(v.x) && is_finite(v.y) && is_finite(v.z);
}

// A turn past the precision (a spin so fast that |ω|·Δt overflows f32 in the axis-angle
// quaternion: VELOCITY's 1e30 rad/s on a 5 cm block) leaves a NaN orientation, whose travel no
// too-fast check sees (a NaN compares false): the block is flagged not finite instead, as the
// CPU stops such a step.
fn turn_finite(q: vec4<real>, omega: vec3<real>, travel: real) -> bool {
    return is_finite(q.x) && is_finite(q.y) && is_finite(q.z) && is_finite(q.w) && all_finite(omega) && is_finite(travel);
}

// The centroid c of a block at the step's start in the frame of its vertices (`face_load`): c
// in f64, 0 in f32 (RELATIVE: the vertices are offsets from it).
fn vertex_frame_centroid(b: Block) -> vec3<real> {
    if (RELATIVE) {
        return vec3<real>(0.0, 0.0, 0.0);
    }
    return vec3<real>(b.cx, b.cy, b.cz);
}

// Block b's centroid moved by dx (its low parts updated). In f32 the centroid is a compensated
// pair: a step below the coordinate's ulp (a slow slide, a settling stack) is kept in the low
// part rather than lost.
fn advance_centroid(b: ptr<function, Block>, dx: vec3<real>) -> vec3<real> {
    if (COMPENSATED) {
        let one = params.one;
        let sx = two_sum((*b).cx, dx.x + (*b).cx_lo, one);
        let sy = two_sum((*b).cy, dx.y + (*b).cy_lo, one);
        let sz = two_sum((*b).cz, dx.z + (*b).cz_lo, one);
        (*b).cx_lo = sx.y;
        (*b).cy_lo = sy.y;
        (*b).cz_lo = sz.y;
        return vec3<real>(sx.x, sy.x, sz.x);
    }
    return vec3<real>((*b).cx, (*b).cy, (*b).cz) + dx;
}

// Stage 2 for a block (Rust twin: `Block::place_vertices`): its `count` vertices from `start` (a
// concave block's parts' too, in its range) placed by r, its rotation (stretched for a
// simply-deformable block), about its new centroid c; in f32 (RELATIVE) as their offsets R·l
// from the centroid, which the contact kernels add to the centroid's place in each contact's
// frame (`centroid_from`), so that no vertex is rounded at ulp(|c|).
fn place_vertices(start: u32, count: u32, r: Mat3, c: vec3<real>) {
    for (var k = 0u; k < count; k++) {
        let j = start + k;
        var p = mat_mul(r, vec3<real>(vertices[j].lx, vertices[j].ly, vertices[j].lz));
        if (!RELATIVE) {
            p = c + p;
        }
        vertices[j].x = p.x;
        vertices[j].y = p.y;
        vertices[j].z = p.z;
    }
}

// One step of block i held by BOUNDARY VELOCITY (Rust twin: `motion::held_motion`): it moves at
// its velocity and spin whatever the forces on it (its angular momentum, I(t)ω, is the CPU's to
// renew at the read-back: the kernels keep only the inverse inertia), a simply-deformable
// block's strain kept, its rate zero. The work booked is its weight's, load's and boundary
// stresses' less the boundary's holding, F·Δx + M·ωΔt.
fn held_motion(i: u32) {
    var b = blocks[i];
    if (SDEF) {
        freeze_strain(i);
    }
    let dt = params.dt;
    let g = vec3<real>(params.gx, params.gy, params.gz);
    let v = vec3<real>(b.vx, b.vy, b.vz);
    let omega = vec3<real>(b.wx, b.wy, b.wz);
    let dx = v * dt;
    let c0 = vertex_frame_centroid(b);
    let c = advance_centroid(&b, dx);
    var q = vec4<real>(b.qx, b.qy, b.qz, b.qw);
    if (!(omega.x == 0.0 && omega.y == 0.0 && omega.z == 0.0)) {
        q = quat_normalize(quat_mul(quat_from_scaled_axis(omega * dt), q));
    }
    // The boundary stresses' work, from the faces where the step began (placed below).
    var stress_work: real = 0.0;
    if (b.stress_faces > 0u) {
        stress_work = boundary_work(i, c0, dx, omega, dt);
    }
    var r = rotation_matrix(q);
    if (SDEF) {
        r = stretched_rotation(i, r);
    }
    place_vertices(b.vertex_start, b.vertex_count, r, c);
    let travel = length3(dx) + length3(omega) * dt * b.radius;
    let applied = b.mass * g + vec3<real>(b.load_x, b.load_y, b.load_z);
    var work = dot3(applied, dx);
    if (b.stress_faces > 0u) {
        work += stress_work;
    }
    let force = vec3<real>(b.fx, b.fy, b.fz);
    let moment = vec3<real>(b.mx, b.my, b.mz);
    work -= dot3(force, dx) + dot3(moment, omega) * dt;
    b.qx = q.x;
    b.qy = q.y;
    b.qz = q.z;
    b.qw = q.w;
    b.cx = c.x;
    b.cy = c.y;
    b.cz = c.z;
    b.travel += travel;
    b.peak_travel = max(b.peak_travel, travel);
    b.work += work;
    if (!(is_finite(work) && all_finite(c) && turn_finite(q, omega, travel))) {
        b.finite = 0u;
    }
    blocks[i] = b;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn law_of_motion(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = item_index(wg, li);
    if (i >= params.blocks) {
        return;
    }
    var b = blocks[i];
    if (BOUNDARY) {
        if (b.fixed == BLOCK_HELD) {
            held_motion(i);
            if (SDEF) {
                crack_screen(i);
            }
            return;
        }
    }
    if (b.fixed != 0u) {
        if (SDEF) {
            // A fixed block's strain stays, its rate zero (`motion::law_of_motion_with`); it is
            // screened all the same (the CPU checks every candidate after each cycle, and a TF
            // lowered since the last run may be below its stress now).
            freeze_strain(i);
            crack_screen(i);
        }
        blocks[i].vx = 0.0;
        blocks[i].vy = 0.0;
        blocks[i].vz = 0.0;
        blocks[i].lx = 0.0;
        blocks[i].ly = 0.0;
        blocks[i].lz = 0.0;
        blocks[i].wx = 0.0;
        blocks[i].wy = 0.0;
        blocks[i].wz = 0.0;
        return;
    }
    let alpha = params.alpha;
    let dt = params.dt;
    let g = vec3<real>(params.gx, params.gy, params.gz);
    let con1 = 1.0 - 0.5 * alpha * dt;
    let con2 = 1.0 / (1.0 + 0.5 * alpha * dt);
    let v0 = vec3<real>(b.vx, b.vy, b.vz);
    let l0 = vec3<real>(b.lx, b.ly, b.lz);
    let force = vec3<real>(b.fx, b.fy, b.fz);
    let moment = vec3<real>(b.mx, b.my, b.mz);
    let v = (v0 * con1 + force / b.mass * dt) * con2;
    let l = (l0 * con1 + moment * dt) * con2;
    let q0 = vec4<real>(b.qx, b.qy, b.qz, b.qw);
    let inv = Mat3(vec3<real>(b.inv0, b.inv1, b.inv2), vec3<real>(b.inv3, b.inv4, b.inv5), vec3<real>(b.inv6, b.inv7, b.inv8));
    // The damping's dissipation, α m v̄² Δt + α L̄·I⁻¹L̄ Δt at the step's start (module doc of
    // `d3::motion`).
    var damping: real = 0.0;
    if (alpha > 0.0) {
        let vm = 0.5 * (v0 + v);
        let lm = 0.5 * (l0 + l);
        damping = alpha * dt * (b.mass * dot3(vm, vm) + dot3(lm, angular_velocity(q0, inv, lm)));
    }
    let dx = v * dt;
    let c = advance_centroid(&b, dx);
    let turn = rotate(q0, inv, l, dt);
    // A simply-deformable block's strain steps after its rigid motion, before its vertices are
    // placed stretched (`motion::law_of_motion_with`, sdef.wgsl): its damping's work and its
    // strain's travel join the block's.
    var r = rotation_matrix(turn.q);
    var strained = vec2<real>(0.0, 0.0);
    if (SDEF) {
        strained = internal_step(i, r, dt, b.radius);
        r = stretched_rotation(i, r);
        damping += strained.x;
    }
    // The boundary stresses' work (BOUNDARY scenes), from the faces where the step began (the
    // vertices are placed below) at the step's motion and strain rate (`Block::boundary_work`).
    var stress_work: real = 0.0;
    if (BOUNDARY) {
        if (b.stress_faces > 0u) {
            stress_work = boundary_work(i, vertex_frame_centroid(b), dx, turn.omega, dt);
        }
    }
    // Stage 2: the vertices placed from the centroid and the orientation.
    place_vertices(b.vertex_start, b.vertex_count, r, c);
    var travel = length3(dx) + length3(turn.omega) * dt * b.radius;
    if (SDEF) {
        travel += strained.y;
    }
    let applied = b.mass * g + vec3<real>(b.load_x, b.load_y, b.load_z);
    var work = dot3(applied, dx);
    if (BOUNDARY) {
        if (b.stress_faces > 0u) {
            work += stress_work;
        }
    }
    b.vx = v.x;
    b.vy = v.y;
    b.vz = v.z;
    b.lx = l.x;
    b.ly = l.y;
    b.lz = l.z;
    b.wx = turn.omega.x;
    b.wy = turn.omega.y;
    b.wz = turn.omega.z;
    b.qx = turn.q.x;
    b.qy = turn.q.y;
    b.qz = turn.q.z;
    b.qw = turn.q.w;
    b.cx = c.x;
    b.cy = c.y;
    b.cz = c.z;
    b.travel += travel;
    b.peak_travel = max(b.peak_travel, travel);
    b.work += work;
    b.damping_work += damping;
    if (!(is_finite(work) && all_finite(c) && all_finite(v) && all_finite(l) && turn_finite(turn.q, turn.omega, travel))) {
        b.finite = 0u;
    }
    blocks[i] = b;
    if (SDEF) {
        // Stage 7's Griffith check on the stress this step left (sdef.wgsl).
        crack_screen(i);
    }
}

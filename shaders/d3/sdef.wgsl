// Simply-deformable blocks (Rust twin: `d3::sdef`), in the kernels of a scene that has them
// (the prelude's SDEF; a rigid scene's kernels take `rigid.wgsl`'s stand-ins, never called, and
// bind nothing more). A block's six strain degrees of freedom, Voigt order (11, 22, 33, 12, 13,
// 23); `live` 0 for a rigid block of the scene; `tf` its tensile strength where Griffith's law
// cracks it (0: never screened). Twin of `d3::gpu::layout::SdefBlock`.
struct SdefBlock {
    e0: real, e1: real, e2: real, e3: real, e4: real, e5: real,
    r0: real, r1: real, r2: real, r3: real, r4: real, r5: real,
    s0: real, s1: real, s2: real, s3: real, s4: real, s5: real,
    a0: real, a1: real, a2: real, a3: real, a4: real, a5: real, a6: real, a7: real, a8: real,
    m0: real, m1: real, m2: real, m3: real, m4: real, m5: real,
    volume: real, lambda: real, shear: real, alpha: real, tf: real,
    live: u32, spare: u32,
}

// One record per block, then the screen's record (`crack_screen`: its `spare` is the flag; it is
// no block, `live` 0).
@group(0) @binding(8) var<storage, read_write> sdef: array<SdefBlock>;

// The symmetric matrix of six Voigt components (`sdef::tensor`), by columns.
fn voigt_matrix(v0: real, v1: real, v2: real, v3: real, v4: real, v5: real) -> Mat3 {
    return Mat3(vec3<real>(v0, v3, v4), vec3<real>(v3, v1, v5), vec3<real>(v4, v5, v2));
}

// The velocity block i's strain rate gives a point r from its centroid: ε̇·r
// (`Sdef::strain_velocity`); zero for a rigid block.
fn strain_velocity(i: u32, r: vec3<real>) -> vec3<real> {
    let s = sdef[i];
    if (s.live == 0u) {
        return vec3<real>(0.0, 0.0, 0.0);
    }
    return mat_mul(voigt_matrix(s.r0, s.r1, s.r2, s.r3, s.r4, s.r5), r);
}

// The stretch I + ε of block i (identity for a rigid block).
fn stretch_of(s: SdefBlock) -> Mat3 {
    return voigt_matrix(1.0 + s.e0, 1.0 + s.e1, 1.0 + s.e2, s.e3, s.e4, s.e5);
}

// The inverse of m (glam's `DMat3::inverse`: the cross products of the columns over the
// determinant, transposed).
fn mat_inverse(m: Mat3) -> Mat3 {
    let t0 = cross3(m.y, m.z);
    let t1 = cross3(m.z, m.x);
    let t2 = cross3(m.x, m.y);
    let inv_det = 1.0 / dot3(m.z, t2);
    let c0 = t0 * inv_det;
    let c1 = t1 * inv_det;
    let c2 = t2 * inv_det;
    return Mat3(vec3<real>(c0.x, c1.x, c2.x), vec3<real>(c0.y, c1.y, c2.y), vec3<real>(c0.z, c1.z, c2.z));
}

// A face normal n (turned with the block) of block i made the strained face's: (I + ε)⁻¹ n, a
// unit vector (`Block::face_normal`: normals map by the inverse transpose of the stretch, which
// is symmetric); n as it is for a rigid block.
fn stretched_normal(i: u32, n: vec3<real>) -> vec3<real> {
    let s = sdef[i];
    if (s.live == 0u) {
        return n;
    }
    return normalize3(mat_mul(mat_inverse(stretch_of(s)), n));
}

// The placement of block i's reference vertices: (I + ε)·R (`Block::place_vertices`); R for a
// rigid block.
fn stretched_rotation(i: u32, r: Mat3) -> Mat3 {
    let s = sdef[i];
    if (s.live == 0u) {
        return r;
    }
    let st = stretch_of(s);
    return Mat3(mat_mul(st, r.x), mat_mul(st, r.y), mat_mul(st, r.z));
}

// Stores the applied stress times volume the gather summed for block i (A_ij = Σ r_i f_j, by
// columns; written row by row).
fn store_applied(i: u32, a: Mat3) {
    if (sdef[i].live == 0u) {
        return;
    }
    sdef[i].a0 = a.x.x;
    sdef[i].a1 = a.y.x;
    sdef[i].a2 = a.z.x;
    sdef[i].a3 = a.x.y;
    sdef[i].a4 = a.y.y;
    sdef[i].a5 = a.z.y;
    sdef[i].a6 = a.x.z;
    sdef[i].a7 = a.y.z;
    sdef[i].a8 = a.z.z;
}

// A fixed block's strain rate zeroed (its strain stays).
fn freeze_strain(i: u32) {
    if (sdef[i].live == 0u) {
        return;
    }
    sdef[i].r0 = 0.0;
    sdef[i].r1 = 0.0;
    sdef[i].r2 = 0.0;
    sdef[i].r3 = 0.0;
    sdef[i].r4 = 0.0;
    sdef[i].r5 = 0.0;
}

// One step of block i's strain (`sdef::internal_step`) at the rotation r of its new orientation:
// the strain rate from the applied and internal stresses over the modes' inertia (the diagonal
// of R M Rᵀ for the normal strains, the mean of two for a shear), with the internal damping in
// the CON1/CON2 form; then the strain and its stress by isotropic elasticity. Returns the
// internal damping's work and how far the step's strain moved a point within `radius` of the
// centroid (its Frobenius norm times the radius); zeros for a rigid block.
fn internal_step(i: u32, r: Mat3, dt: real, radius: real) -> vec2<real> {
    var s = sdef[i];
    if (s.live == 0u) {
        return vec2<real>(0.0, 0.0);
    }
    // R M Rᵀ's diagonal: d_k = Σ_ij R_ki M_ij R_kj, R_ki the k-th component of column i.
    let m = voigt_matrix(s.m0, s.m1, s.m2, s.m3, s.m4, s.m5);
    let row0 = vec3<real>(r.x.x, r.y.x, r.z.x);
    let row1 = vec3<real>(r.x.y, r.y.y, r.z.y);
    let row2 = vec3<real>(r.x.z, r.y.z, r.z.z);
    let d0 = dot3(row0, mat_mul(m, row0));
    let d1 = dot3(row1, mat_mul(m, row1));
    let d2 = dot3(row2, mat_mul(m, row2));
    let j = array<real, 6>(d0, d1, d2, 0.5 * (d0 + d1), 0.5 * (d0 + d2), 0.5 * (d1 + d2));
    if (!(d0 > 0.0 && d1 > 0.0 && d2 > 0.0)) {
        return vec2<real>(0.0, 0.0);
    }
    let alpha = s.alpha;
    let c1 = 1.0 - 0.5 * alpha * dt;
    let c2 = 1.0 / (1.0 + 0.5 * alpha * dt);
    let v = s.volume;
    // The generalised forces: A_ii − Vσ_ii, ½(A_ij + A_ji) − Vσ_ij.
    let q = array<real, 6>(
        s.a0 - v * s.s0,
        s.a4 - v * s.s1,
        s.a8 - v * s.s2,
        0.5 * (s.a1 + s.a3) - v * s.s3,
        0.5 * (s.a2 + s.a6) - v * s.s4,
        0.5 * (s.a5 + s.a7) - v * s.s5,
    );
    let old = array<real, 6>(s.r0, s.r1, s.r2, s.r3, s.r4, s.r5);
    var rate: array<real, 6>;
    var work: real = 0.0;
    var sq: real = 0.0;
    for (var k = 0u; k < 6u; k++) {
        rate[k] = (old[k] * c1 + q[k] / j[k] * dt) * c2;
        let mean = 0.5 * (old[k] + rate[k]);
        let twice = select(real(2.0), real(1.0), k < 3u);
        work += twice * j[k] * mean * mean;
        let step = rate[k] * dt;
        sq += twice * step * step;
    }
    if (!(alpha > 0.0)) {
        work = 0.0;
    }
    s.r0 = rate[0];
    s.r1 = rate[1];
    s.r2 = rate[2];
    s.r3 = rate[3];
    s.r4 = rate[4];
    s.r5 = rate[5];
    s.e0 += rate[0] * dt;
    s.e1 += rate[1] * dt;
    s.e2 += rate[2] * dt;
    s.e3 += rate[3] * dt;
    s.e4 += rate[4] * dt;
    s.e5 += rate[5] * dt;
    // σ = λ tr(ε) + 2Gε (`sdef::elastic_stress`).
    let volumetric = s.lambda * (s.e0 + s.e1 + s.e2);
    let g2 = 2.0 * s.shear;
    s.s0 = volumetric + g2 * s.e0;
    s.s1 = volumetric + g2 * s.e1;
    s.s2 = volumetric + g2 * s.e2;
    s.s3 = g2 * s.e3;
    s.s4 = g2 * s.e4;
    s.s5 = g2 * s.e5;
    sdef[i] = s;
    return vec2<real>(work * alpha * dt, sqrt(sq) * radius);
}

// Griffith's equivalent tensile stress of the principal stresses s1 ≥ s3, tension positive
// (SL-85-1 Appendix A ¶17; Rust twin: `sdef::griffith_stress`).
fn griffith_stress(s1: real, s3: real) -> real {
    if (3.0 * s1 + s3 >= 0.0) {
        return s1;
    }
    let d = s1 - s3;
    return -(d * d) / (8.0 * (s1 + s3));
}

// One Jacobi rotation of a symmetric matrix in the plane (p, q), zeroing a_pq (left where
// |a_pq| ≤ tiny): a_pp, a_qq, a_pq and the third row's a_rp, a_rq updated in place (Rust twin:
// `sdef::jacobi_rotation`, which returns them).
fn jacobi_rotation(pp: ptr<function, real>, qq: ptr<function, real>, pq: ptr<function, real>, rp: ptr<function, real>, rq: ptr<function, real>, tiny: real) {
    let apq = *pq;
    if (abs(apq) <= tiny) {
        return;
    }
    let theta = (*qq - *pp) / (2.0 * apq);
    let towards = select(real(-1.0), real(1.0), theta >= 0.0);
    let t = towards / (abs(theta) + sqrt(theta * theta + 1.0));
    let c = 1.0 / sqrt(t * t + 1.0);
    let s = t * c;
    let arp = *rp;
    let arq = *rq;
    *pp = *pp - t * apq;
    *qq = *qq + t * apq;
    *pq = 0.0;
    *rp = c * arp - s * arq;
    *rq = s * arp + c * arq;
}

// Griffith's screen of a block's stress s against its strength tf (Rust twin:
// `sdef::griffith_screen`, which gives the bounds' derivation): Jacobi sweeps bring the stress
// near diagonal form, the principal stresses are bounded by the diagonal's extremes widened by
// the off-diagonal part left and GRIFFITH_MARGIN·|σ| (the prelude's: the round-off of this and of
// the CPU's exact check), and Griffith's stress on the bounds, at least the exact one, is held
// against TF less the margin. True where the CPU's check may find the block cracked.
fn griffith_screen(s: SdefBlock) -> bool {
    var d0 = s.s0;
    var d1 = s.s1;
    var d2 = s.s2;
    var o01 = s.s3;
    var o02 = s.s4;
    var o12 = s.s5;
    let norm = sqrt(d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * (o01 * o01 + o02 * o02 + o12 * o12));
    let m = GRIFFITH_MARGIN * norm;
    let tiny = 1e-3 * m;
    for (var k = 0u; k < SCREEN_SWEEPS; k++) {
        // (p, q) = (0, 1), (0, 2), (1, 2), the third row r's elements rotated with them.
        jacobi_rotation(&d0, &d1, &o01, &o02, &o12, tiny);
        jacobi_rotation(&d0, &d2, &o02, &o01, &o12, tiny);
        jacobi_rotation(&d1, &d2, &o12, &o01, &o02, tiny);
    }
    let off = sqrt(2.0 * (o01 * o01 + o02 * o02 + o12 * o12));
    let hi = max(max(d0, d1), d2) + off + m;
    let lo = min(min(d0, d1), d2) - off - m;
    return griffith_stress(hi, lo) >= s.tf - m;
}

// Stage 7's Griffith check on the device, after block i's strain step (the state the CPU's
// `cracking::due` reads after the cycle: stage 4 does not change the stress): where block i is a
// Griffith candidate (tf > 0) and its screen fires, the flag in the record after the blocks is
// raised, and `end_cycle` halts the batch at the cycle's end. Every writer stores the same 1 and
// no invocation of the pass reads it, so the plain store needs no atomic.
fn crack_screen(i: u32) {
    let s = sdef[i];
    if (s.live == 0u || !(s.tf > 0.0)) {
        return;
    }
    if (griffith_screen(s)) {
        sdef[params.blocks].spare = 1u;
    }
}

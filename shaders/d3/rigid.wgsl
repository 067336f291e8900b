// The stand-ins for `sdef.wgsl`'s functions in the kernels of a scene without simply-deformable
// blocks (the prelude's SDEF false): every call sits behind `if (SDEF)`, so none runs, and no
// strain buffer is declared or bound.
fn strain_velocity(i: u32, r: vec3<real>) -> vec3<real> {
    return vec3<real>(0.0, 0.0, 0.0);
}

fn stretched_normal(i: u32, n: vec3<real>) -> vec3<real> {
    return n;
}

fn stretched_rotation(i: u32, r: Mat3) -> Mat3 {
    return r;
}

fn store_applied(i: u32, a: Mat3) {}

fn freeze_strain(i: u32) {}

fn internal_step(i: u32, r: Mat3, dt: real, radius: real) -> vec2<real> {
    return vec2<real>(0.0, 0.0);
}

fn crack_screen(i: u32) {}

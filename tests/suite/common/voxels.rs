//! Concave D3 test blocks made of unit voxels (tests/suite/d3_concave.rs, d3_concave_gpu.rs).

/// The closed surface of a set of unit voxels (each `[i, j, k]`, the cube [i, i+1] × [j, j+1] ×
/// [k, k+1], scaled by `h` and moved by `origin`), as a deck types its faces (each three vertices
/// counter-clockwise looking along the outward normal): two triangles for every voxel side not
/// shared with another voxel.
pub fn voxel_faces(voxels: &[[i32; 3]], h: f64, origin: [f64; 3]) -> Vec<[[f64; 3]; 3]> {
    let mut out = Vec::new();
    for v in voxels {
        for axis in 0..3 {
            for dir in [-1i32, 1] {
                let mut n = *v;
                n[axis] += dir;
                if voxels.contains(&n) {
                    continue;
                }
                let lo = [v[0] as f64, v[1] as f64, v[2] as f64];
                let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
                // The side's corners counter-clockwise seen from outside: (u, w, axis) is
                // right-handed, so u then w turns counter-clockwise seen from +axis.
                let corner = |a: f64, b: f64| {
                    let mut p = lo;
                    p[axis] += if dir > 0 { 1.0 } else { 0.0 };
                    p[u] += a;
                    p[w] += b;
                    [origin[0] + h * p[0], origin[1] + h * p[1], origin[2] + h * p[2]]
                };
                let mut quad = [corner(0.0, 0.0), corner(1.0, 0.0), corner(1.0, 1.0), corner(0.0, 1.0)];
                if dir < 0 {
                    quad.reverse();
                }
                // Counter-clockwise from outside (a, b, c) is typed (a, c, b).
                out.push([quad[0], quad[2], quad[1]]);
                out.push([quad[0], quad[3], quad[2]]);
            }
        }
    }
    out
}

/// A BLOCK command of the typed faces.
pub fn block_command(faces: &[[[f64; 3]; 3]], material: u32) -> String {
    let mut s = format!("BLOCK MAT={material}");
    for f in faces {
        s.push_str("\n+");
        for v in f {
            s.push_str(&format!(" ({},{},{})", v[0], v[1], v[2]));
        }
    }
    s.push('\n');
    s
}

/// An L of three unit voxels in the xy plane (one high).
pub const L: [[i32; 3]; 3] = [[0, 0, 0], [1, 0, 0], [0, 1, 0]];
/// A U in the xz plane: three voxels along x at the bottom, one on each end above: the notch is
/// the voxel [1, 0, 1].
pub const U: [[i32; 3]; 5] = [[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 0, 1], [2, 0, 1]];

//! The kernel precision as a Rust type, and the macro that defines a GPU struct in it: the
//! dimension-free half of every engine's GPU layout (DESIGN.md §2). An engine's structs
//! (`udec::gpu::layout`) are written with [`gpu_struct!`](crate::gpu_struct) and checked
//! against its WGSL through naga ([`StructLayout`]).
//!
//! Each struct is generic over the kernel precision `R` (f32 or f64, the WGSL `real` alias) and is
//! laid out as all `real` fields first, then an even number of `u32` words. That rule gives the
//! same layout in WGSL and Rust with no implicit padding in either precision (no vectors in
//! storage, so no vec2/vec3 alignment surprises).

mod sealed {
    /// Only f32 and f64 are kernel precisions: the structs' Pod impls below hold for those two
    /// alone (an 8-bit `real` would leave padding before the u32 words).
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// The kernel precision: the Rust twin of the WGSL `alias real = …;`. Sealed: f32 or f64.
pub trait Real: sealed::Sealed + bytemuck::Pod + Default + PartialEq + std::fmt::Debug + Send + Sync + 'static {
    /// The WGSL type name.
    const WGSL: &'static str;
    /// The precision it is.
    const PRECISION: super::Precision;
    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
}

impl Real for f32 {
    const WGSL: &'static str = "f32";
    const PRECISION: super::Precision = super::Precision::F32;
    fn from_f64(x: f64) -> Self {
        x as f32
    }
    fn to_f64(self) -> f64 {
        self as f64
    }
}

impl Real for f64 {
    const WGSL: &'static str = "f64";
    const PRECISION: super::Precision = super::Precision::F64;
    fn from_f64(x: f64) -> Self {
        x
    }
    fn to_f64(self) -> f64 {
        self
    }
}

/// Defines a GPU struct generic over `R` (written `R` here, `real` in WGSL), its Pod impl for every precision, and the list of its
/// fields with their offsets (for the naga layout test).
#[macro_export]
macro_rules! gpu_struct {
    ($(#[doc = $d:literal])* $name:ident { $($(#[doc = $fd:literal])* $f:ident : $t:ty),* $(,)? }) => {
        $(#[doc = $d])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq)]
        pub struct $name<R> {
            $($(#[doc = $fd])* pub $f: $t,)*
        }
        // SAFETY: `repr(C)`, every field is a `Real` (f32 or f64: the trait is sealed) or u32,
        // reals first and an even number of u32 words after them, so there is no padding in
        // either precision (checked by a test). One generic impl, so code generic over the
        // precision needs no Pod bounds of its own.
        unsafe impl<R: $crate::gpu::real::Real> bytemuck::Zeroable for $name<R> {}
        unsafe impl<R: $crate::gpu::real::Real> bytemuck::Pod for $name<R> {}
        impl<R> $name<R> {
            /// The WGSL struct name and each field with its byte offset.
            pub fn layout() -> $crate::gpu::real::StructLayout {
                $crate::gpu::real::StructLayout {
                    name: stringify!($name),
                    size: std::mem::size_of::<Self>(),
                    fields: vec![$((stringify!($f), std::mem::offset_of!(Self, $f))),*],
                }
            }
        }
    };
}

/// A struct's name, size and field offsets, as Rust lays it out.
#[derive(Clone, Debug, PartialEq)]
pub struct StructLayout {
    pub name: &'static str,
    pub size: usize,
    pub fields: Vec<(&'static str, usize)>,
}

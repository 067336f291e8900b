//! Lines → logical commands → tokens (stub; filled by the parser work).

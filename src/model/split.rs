//! SPLIT (stub; filled by the geometry work).

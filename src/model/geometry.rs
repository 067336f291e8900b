//! Polygon geometry (stub; filled by the geometry work).

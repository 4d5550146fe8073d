//! Spatial indexes over the crate's geometry: one bounding-volume hierarchy,
//! [`Bvh`] (`tree.rs`), whose queries hand each leaf's primitives to a
//! closure that makes the exact test, and its clients:
//!
//! - [`SurfaceIndex`] (`surface.rs`): the closest point of a triangle mesh,
//!   the remesher's projection and the statistics' surface distances;
//! - [`SegmentIndex`] (`segment.rs`): the closest point of a segment set,
//!   one per feature line and for the statistics' edge distances;
//! - [`PointIndex`] (`point.rs`): whether a vertex lies within a radius.
//!
//! The exact primitive routines live beside them:
//! [`closest_point_on_triangle`] (`triangle.rs`),
//! [`closest_point_on_segment`] and [`lerp_exact`] (`segment.rs`).
//!
//! A new client builds a [`Bvh`] from its primitives' vertices, keeps its
//! per-primitive data in the tree's slot order, and passes its exact test
//! as a closure to [`Bvh::closest`] or [`Bvh::any_within`]; the closure is
//! a generic parameter, so each client's walk is compiled with its test
//! inlined.

mod point;
mod segment;
mod surface;
mod tree;
mod triangle;

pub use point::PointIndex;
pub use segment::{closest_point_on_segment, lerp_exact, SegmentIndex, SegmentPoint};
pub use surface::{ClosestPoint, SurfaceIndex};
pub use tree::{Bvh, LeafShape};
pub use triangle::closest_point_on_triangle;

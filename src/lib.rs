//! isoremesh: isotropic surface remeshing after Botsch & Kobbelt (2004), with
//! exact feature preservation, adaptive sizing, measured quality statistics,
//! a CLI and an HTTP service.
//!
//! # Layout
//!
//! | module | owns |
//! |---|---|
//! | [`geometry`] | triangle area, normal, angles, shape quality |
//! | [`topology`] | shared adjacency: compressed rows (CSR) for per-vertex lists, the undirected edge table of a triangle list, union-find, grouping corners into smooth fans |
//! | [`trimesh`] | [`TriMesh`], the indexed triangle mesh exchanged between layers |
//! | [`mesh`] | the half-edge [`mesh::Mesh`]: building with repair, split/collapse/flip with guards, compaction, validation |
//! | [`features`] | sharp-feature detection on a [`TriMesh`]: feature edges, corners, the crease filters, feature lines with per-line closest-point queries, and which vertices the remesher keeps fixed |
//! | [`io`] | bytes ⇄ [`TriMesh`] for OBJ, glTF/GLB, STL, PLY, OFF; format detection; split normals |
//! | [`bvh`] | the one bounding-volume hierarchy (obvhs-built, our closest-point and radius queries) and its clients for triangles (the surface), segments and points |
//! | [`stats`] | quality statistics: edge lengths, valence, angles, distances, feature and boundary fidelity, attributes |
//! | [`curvature`] | per-vertex principal curvatures (Rusinkiewicz 2004), feature-aware, and feature-polyline curvature |
//! | [`remesh`] | the Botsch–Kobbelt remesher: options, driver, one pass per file, progress and cancellation |
//! | [`appearance`] | per-vertex texture coordinates and colours, and the textures and images a mesh's materials use |
//! | [`scene`] | the parts a mesh came from (glTF meshes, OBJ groups), their transforms, and the glTF node hierarchy, for writing a result back in the same structure |
//! | [`transfer`] | attribute transfer onto the remeshed surface: seams, wedges, chart-bound walks |
//! | [`reference`] | the per-job [`reference::Reference`]: the input as read, repaired, indexed, welded and feature-detected once for the remesher and the statistics |
//! | [`params`] | the remesh parameters as callers give them, declared once for the CLI flags, the service and the job record; they convert into [`remesh::RemeshOptions`] |
//! | [`pipeline`] | a whole job on bytes: detect, read, repair, remesh, measure, encode |
//! | [`shapes`] | icosphere, torus, cylinder, cube and other shapes generated in code |
//! | [`sizing`] | the adaptive sizing field: target edge lengths from a tolerance, clamped and gradation-limited |
//! | `service` | (feature `service`) the HTTP service: upload validation, durable job queue on blocking workers, results, metrics |
//!
//! The geometry core above is pure and synchronous: no async runtime and no
//! filesystem access. The `service` feature adds the HTTP layer on top.

pub mod appearance;
pub mod bvh;
pub mod curvature;
pub mod features;
pub mod geometry;
pub mod io;
pub mod mesh;
pub mod params;
pub mod pipeline;
pub mod reference;
pub mod remesh;
pub mod scene;
#[cfg(feature = "service")]
pub mod service;
pub mod shapes;
pub mod sizing;
pub mod stats;
pub mod topology;
pub mod transfer;
pub mod trimesh;

pub use trimesh::{Label, Material, TriMesh};

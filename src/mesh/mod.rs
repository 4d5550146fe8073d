//! The half-edge mesh (placeholder while the core is written).

mod build;
pub use build::RepairReport;

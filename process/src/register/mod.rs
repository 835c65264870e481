//! Registration (thesis ch. 2.2): robust point-to-plane ICP between two views ([`icp`]), all views
//! refined together from their turntable poses ([`multiview`]), and a processed scan's range grids
//! through both and merged again ([`register_scan`]); a laser scan's lasers aligned with each
//! other ([`lasers`]); two clouds in any poses aligned by their local shape ([`global`], over the
//! descriptors of [`features`]).

pub mod features;
pub mod global;
pub mod icp;
pub mod lasers;
pub mod multiview;
pub mod register_scan;

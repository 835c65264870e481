//! Registration (thesis ch. 2.2): robust point-to-plane ICP between two views ([`icp`]), all views
//! refined together from their turntable poses ([`multiview`]), and a processed scan's range grids
//! through both and merged again ([`register_scan`]).

pub mod icp;
pub mod multiview;
pub mod register_scan;

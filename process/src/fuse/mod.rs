//! Fusion (thesis ch. 3): anisotropic mean shift with adaptive neighbourhoods, clustering and outlier
//! removal ([`mean_shift`], in the cache-friendly [`spatial_order`]), and consistent orientation of
//! normals without a sensor ([`orient`]).

pub mod mean_shift;
pub mod orient;
pub mod spatial_order;

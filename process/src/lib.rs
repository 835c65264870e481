//! # process — the geometry pipeline
//!
//! Each stage is a plain function over plain data from [`rig`] (a range grid, a point cloud, a mesh),
//! usable without the command line. The catalogue, with the thesis chapter each algorithm implements:
//!
//! - decode Gray code and phase shift, triangulate camera–projector and camera–laser-plane rays (ch. 2,
//!   eq. 2.3);
//! - per-scan non-local denoising of range grids, static and time-varying (ch. 4, eqs. 4.3–4.6);
//! - robust point-to-plane ICP from the turntable poses (ch. 2.2);
//! - mean-shift fusion with anisotropic kernels and outlier removal (ch. 3, eqs. 3.2–3.10);
//! - watertight reconstruction by the global FFT method and AdFFT (ch. 5), marching cubes;
//! - quad remeshing from harmonic and quasi-harmonic fields (ch. 6).
//!
//! The stages arrive one issue at a time; until the first lands the crate holds no code.
#![deny(missing_docs)]

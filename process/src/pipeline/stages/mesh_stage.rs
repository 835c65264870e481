//! The mesh: reconstruction (ch. 5), its finish (base, trim), the support check, its colours.

use super::StageError;
use super::apart::{Apart, MAX_WIDENING, apart};
use crate::kd_tree::PointTree;
use crate::pipeline::records::{Fingerprint, StageCode};
use crate::reconstruct::adfft::{AdFftParams, AdFftReport, reconstruct_adfft_counting};
pub use crate::reconstruct::base::{Base, BaseReport};
use crate::reconstruct::closing::{CloseParams, CloseReport, close_openings};
use crate::reconstruct::global_fft::{FftParams, FftReport, reconstruct_fft_in};
pub use crate::reconstruct::trim::TrimReport;
use rayon::prelude::*;
use rig::math::{Point3, Real};
use rig::{PointCloud, PolyMesh, TriMesh};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::collections::HashMap;
use std::sync::atomic::AtomicUsize;

/// The reconstruction method and its parameters (ch. 5).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "method")]
pub enum ReconstructParams {
    /// The global FFT method (Kazhdan 2005): one N³ grid.
    Fft(FftParams),
    /// AdFFT: local FFT solutions over an octree, blended by a partition of unity (thesis 5.3).
    Adfft(AdFftParams),
}

impl ReconstructParams {
    /// The octree depth (the global grid's, 2^depth a side).
    pub fn depth(&self) -> u32 {
        match self {
            ReconstructParams::Fft(p) => p.depth,
            ReconstructParams::Adfft(p) => p.depth,
        }
    }

    /// The steps [`mesh_counting`] counts: AdFFT's sweep, plane by plane (2^depth); the global
    /// method, seconds long at its largest grid, counts none (1: done when it returns).
    pub fn counted_steps(&self) -> usize {
        match self {
            ReconstructParams::Fft(_) => 1,
            ReconstructParams::Adfft(p) => 1usize << p.depth.min(16),
        }
    }
}

impl Default for ReconstructParams {
    fn default() -> Self {
        ReconstructParams::Fft(FftParams::default())
    }
}

/// What reconstruction did, by method.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "method")]
pub enum ReconstructReport {
    /// The global method's report.
    Fft(FftReport),
    /// AdFFT's report.
    Adfft(AdFftReport),
}

impl ReconstructReport {
    /// Grid points per axis (AdFFT: of the equivalent global grid).
    pub fn n(&self) -> usize {
        match self {
            ReconstructReport::Fft(r) => r.n,
            ReconstructReport::Adfft(r) => r.n,
        }
    }
    /// Grid spacing, in the cloud's units.
    pub fn cell(&self) -> Real {
        match self {
            ReconstructReport::Fft(r) => r.cell,
            ReconstructReport::Adfft(r) => r.cell,
        }
    }
    /// Triangles written.
    pub fn triangles(&self) -> usize {
        match self {
            ReconstructReport::Fft(r) => r.triangles,
            ReconstructReport::Adfft(r) => r.triangles,
        }
    }
    /// Seconds spent.
    pub fn seconds(&self) -> Real {
        match self {
            ReconstructReport::Fft(r) => r.seconds_splat + r.seconds_fft + r.seconds_extract,
            ReconstructReport::Adfft(r) => r.seconds_octree + r.seconds_extract,
        }
    }
}

/// A watertight mesh of an oriented cloud.
pub fn reconstruct<'a>(
    cloud: impl Into<rig::CloudRef<'a>>,
    params: &ReconstructParams,
) -> Result<(TriMesh, ReconstructReport), StageError> {
    reconstruct_in(cloud, params, None, &AtomicUsize::new(0))
}

/// [`reconstruct`] with a k-d tree over the cloud's positions the caller already has (`None`: built
/// where needed): the pipeline builds one and asks it for the area weights, the mesh's support
/// ([`check_support`]) and its colours ([`mesh_colours`]).
pub fn reconstruct_in<'a>(
    cloud: impl Into<rig::CloudRef<'a>>,
    params: &ReconstructParams,
    tree: Option<&PointTree>,
    steps: &AtomicUsize,
) -> Result<(TriMesh, ReconstructReport), StageError> {
    reconstruct_of(cloud.into(), params, tree, steps)
}

/// [`reconstruct_in`]'s body, compiled once here rather than into every caller's crate.
fn reconstruct_of(
    cloud: rig::CloudRef<'_>,
    params: &ReconstructParams,
    tree: Option<&PointTree>,
    steps: &AtomicUsize,
) -> Result<(TriMesh, ReconstructReport), StageError> {
    check_cloud(cloud)?;
    params.validate_for(rig::Aabb::of(cloud.positions).map_or(0.0, |b| b.diagonal()))?;
    let (mesh, report) = match params {
        ReconstructParams::Fft(p) => {
            let (m, r) = reconstruct_fft_in(cloud, p, tree)?;
            (m, ReconstructReport::Fft(r))
        }
        ReconstructParams::Adfft(p) => {
            let (m, r) = reconstruct_adfft_counting(cloud, p, steps)?;
            (m, ReconstructReport::Adfft(r))
        }
    };
    check_surface(&mesh, &report, cloud.len())?;
    Ok((mesh, report))
}

/// Refuses a reconstruction that made no surface at all, saying why it may have.
fn check_surface(mesh: &TriMesh, report: &ReconstructReport, points: usize) -> Result<(), StageError> {
    if !mesh.faces.is_empty() {
        return Ok(());
    }
    let mut why = "the normals may point inward, or the cloud is spread over a far larger box than the object (a \
                   stray point far away)"
        .to_string();
    // A grid finer than the samples (kept by --samples-per-cell, or at the shallowest depth AdFFT
    // builds) leaves most cells without a sample, and the blend without a surface: said first,
    // naming the options.
    if let ReconstructReport::Adfft(r) = report
        && r.samples_per_cell < AdFftParams::default().samples_per_cell
    {
        why = format!(
            "the {}³ grid has {:.2e} samples per surface cell, too few to show one (leave --samples-per-cell at \
             its default, or lower --depth); or {why}",
            r.n, r.samples_per_cell
        );
    }
    Err(StageError::NoSurface { points, why })
}

/// What a reconstruction's own report says is wrong with its mesh: AdFFT's self-intersections left
/// after repair, and a fit that held many vertices at its limit.
fn report_warnings(report: &ReconstructReport) -> Vec<String> {
    let ReconstructReport::Adfft(a) = report else { return Vec::new() };
    let mut warnings = Vec::new();
    if a.self_intersections.remaining > 0 {
        warnings.push(format!(
            "the mesh still intersects itself in {} triangle pairs after repair; slicers may refuse it",
            a.self_intersections.remaining
        ));
    }
    warnings.extend(a.far_from_samples());
    warnings
}

/// The checks [`mesh`] makes of a bare reconstruction, for a mesh reconstructed elsewhere (AdFFT's
/// slabs on Ray workers, joined by [`crate::reconstruct::adfft::reconstruct_adfft_slabs`]): a mesh
/// with no surface is refused, one inside out, facing against its samples, leaving them out, far
/// from them or coarsened by points apart is refused unless `force` ([`check_support`]), and what
/// the report says is wrong comes back as warnings, as the single process gives them.
pub fn checked_reconstruction(
    mesh: &TriMesh,
    report: &ReconstructReport,
    cloud: rig::CloudRef<'_>,
    force: bool,
) -> Result<Vec<String>, StageError> {
    check_surface(mesh, report, cloud.len())?;
    let mut warnings = check_support(mesh, cloud, &PointTree::new(cloud.positions), report.cell(), force)?;
    warnings.extend(report_warnings(report));
    Ok(warnings)
}

/// What becomes of the reconstructed surface before it is written: its never-seen base, and surface
/// far from the data.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FinishParams {
    /// The base of an object on the platter (only where the platter plane is known: a turntable scan).
    pub base: Base,
    /// Remove surface farther than this from every sample (the cloud's units); `None` keeps it all.
    pub trim: Option<Real>,
    /// Close the holes trimming leaves, each by a fan from its centre.
    pub trim_fill: bool,
}

impl Default for FinishParams {
    fn default() -> Self {
        FinishParams { base: Base::Flat, trim: None, trim_fill: false }
    }
}

/// What finishing did.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct FinishReport {
    /// The base cut, where one was made.
    #[serde(default)]
    pub base: Option<BaseReport>,
    /// The trim, where asked.
    #[serde(default)]
    pub trim: Option<TrimReport>,
    /// The cut at the working volume's top, where the mesh rose above it
    /// ([`crate::reconstruct::top_cut`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub top: Option<BaseReport>,
    /// How high the reconstruction rose before that cut (the mesh's units).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rose_to: Option<Real>,
    /// What was not done and why.
    #[serde(default)]
    pub skipped: Vec<String>,
}

/// A reconstruction's record: the method's report, and what finishing did.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MeshReport {
    /// The reconstruction.
    #[serde(flatten)]
    pub reconstruct: ReconstructReport,
    /// Base and trim.
    #[serde(default)]
    pub finish: FinishReport,
    /// How the mesh sits on its cloud ([`check_support`]: far from it, inside out, facing against
    /// its normals, leaving samples out, points apart), judged again when the mesh is reused.
    #[serde(default)]
    pub support: Option<Support>,
}

/// How far above the platter the base is cut, in reconstruction cells: above the low-pass's rounding
/// of the bottom edge (a cell or two), so the skirt below it is the object's wall.
pub const SKIRT_CELLS: Real = 2.0;

/// Refuses a `trim` past half the size of the cloud (`samples`), before the reconstruction: it
/// would remove nothing, being a figure in another unit (2 for 2 mm, given for a cloud in metres,
/// had trimmed nothing with exit 0).
fn check_trim(trim: Option<Real>, samples: &[Point3]) -> Result<(), StageError> {
    let size = rig::Aabb::of(samples).map_or(Real::INFINITY, |b| b.diagonal());
    match trim.filter(|&t| t > 0.5 * size) {
        Some(t) => Err(StageError::Implausible {
            what: format!("--trim {t} is more than half the cloud's size ({size:.4} across, in its units)"),
            hint: "it would remove nothing; give the distance in the cloud's units (a PLY saying `comment units m` \
                   is in metres: 2 mm is 0.002)"
                .into(),
        }),
        None => Ok(()),
    }
}

/// Finishes a reconstructed mesh: cuts its base at the platter plane `platter_z` (when known) as
/// `params.base` says — at [`SKIRT_CELLS`] of `cell` above it, carried straight down —, then trims
/// surface farther than `params.trim` from `samples` (never the flat base, which no sample need cover).
pub fn finish(
    mesh: TriMesh,
    samples: &[Point3],
    params: &FinishParams,
    platter_z: Option<Real>,
    cell: Real,
) -> Result<(TriMesh, FinishReport), StageError> {
    params.validate()?;
    let mut report = FinishReport::default();
    let mut mesh = mesh;
    match (params.base, platter_z) {
        (Base::Closed, _) => {}
        (_, None) => report
            .skipped
            .push("base: the platter plane is not known (no turntable), so the base is kept as reconstructed".into()),
        (base, Some(z)) => {
            let (cut, r) = crate::reconstruct::base::cut_base(&mesh, base, z, SKIRT_CELLS * cell)?;
            mesh = cut;
            report.base = Some(r);
        }
    }
    if let Some(t) = params.trim {
        // The base (cap and skirt) is where the object stood: kept by definition, not by samples.
        let base = report.base.filter(|r| r.outline_edges > 0).map(|r| r.z + r.skirt);
        let faces_before = mesh.faces.len();
        let (trimmed, r) = crate::reconstruct::trim::trim(&mesh, samples, t, params.trim_fill, base);
        // A trim that takes (nearly) the whole surface is a distance below the data's spacing, not a
        // result.
        if trimmed.faces.len() * 10 < faces_before {
            return Err(StageError::Implausible {
                what: format!(
                    "--trim {t} removed {} of the mesh's {faces_before} faces",
                    faces_before - trimmed.faces.len()
                ),
                hint: format!(
                    "the distance is below the samples' spacing; give a larger --trim (the grid cell is {cell:.4})"
                ),
            });
        }
        mesh = trimmed;
        report.trim = Some(r);
    }
    Ok((mesh, report))
}

/// The largest median distance from a mesh's vertices to its cloud, as a fraction of the cloud's
/// bounding-box diagonal, that a reconstruction of the cloud can have. A mesh the data supports lies
/// on its points (median 0.1–0.2 % of the diagonal on the simulated scans, where closing the holes a
/// scan leaves puts a tenth or more of the vertices far from any point); a median of several per cent
/// means most of the surface is made up — inconsistent normals (a laser scan's, 6.9 %) or a stray
/// cluster.
pub const MAX_MEDIAN_GAP: Real = 0.02;

/// The largest share of a mesh's vertices on its samples' sheet that may face against the normal of
/// the sample nearest them ([`Support::against`]). A mesh the data supports agrees with its samples
/// almost everywhere: 0.00 % on the simulated scans, 0.02 % on the ten aligned Stanford bunny scans,
/// 0.07–0.12 % on the coarsest zippered bunny fused (8,171 points) at depths 7 and 9, FFT and AdFFT.
/// A cloud whose normals are not oriented consistently makes a mesh of handles and pockets: a sphere
/// with a twentieth of its normals turned at random 4.7–5.5 % (FFT genus 161), a tenth 9.5–10 %, one
/// of eight overlapping views turned 3.3–9.4 %. (Half the sphere turned, meeting the rest along one
/// seam, gives 0.6 % and passes.)
pub const MAX_AGAINST: Real = 0.01;

/// Vertices within this many of the samples' spacings of a sample count for [`Support::against`]: a
/// surface closing a hole the scan left is farther, and faces where the data does not say.
pub const NEAR_SPACINGS: Real = 4.0;

/// The largest share of a cloud's samples a reconstruction may leave out ([`LeftOut`]). A
/// reconstruction runs through its samples: none of the simulated scans' or the spheres' samples is
/// left out, 0.2–0.3 % of the ten aligned bunny scans' (their noise), of the coarsest zippered bunny
/// fused 0.1 % by AdFFT; the global FFT of that cloud at depths 7 and 9 lost an ear's tip, leaving
/// out 1.9–2.6 % of the samples, up to 45 mm from the mesh; a cup fused without normals, whose inner
/// wall the spanning tree turned to face into the wall, 34 %.
pub const MAX_LEFT_OUT: Real = 0.01;

/// A sample farther than this many of the larger of the grid's cell and the samples' spacing from
/// every vertex of the bare reconstruction is left out by it ([`LeftOut`]): a surface through the
/// samples has a vertex within a cell of each.
pub const LEFT_OUT_CELLS: Real = 2.0;

/// The samples a reconstruction leaves out: what [`left_out`] measures on the bare reconstruction,
/// before its finish cuts the base or trims.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LeftOut {
    /// Their share of the samples (up to 20,000, spread over the cloud).
    pub share: Real,
    /// The distance from every vertex beyond which a sample is left out ([`LEFT_OUT_CELLS`]).
    pub reach: Real,
    /// The farthest of those samples' distance from the mesh's vertices.
    pub farthest: Real,
}

/// How a mesh sits on its cloud: what [`check_support`] judges, kept in the mesh's record so that a
/// mesh `process` reuses is judged again (a forced run's far mesh is not passed on in silence).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Support {
    /// The median distance from the mesh's vertices (sampled, up to 20,000) to the nearest sample.
    pub median_gap: Real,
    /// The cloud's bounding-box diagonal.
    pub diagonal: Real,
    /// The share of those vertices on the sheet of the sample nearest them (within [`NEAR_SPACINGS`]
    /// of the samples' spacing of it, and off its tangent plane by at most half that distance or half
    /// a spacing) whose normal faces against that sample's; `None` for a cloud without normals, or a
    /// record from before it was measured.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub against: Option<Real>,
    /// The reconstruction's enclosed volume before its finish cut or trimmed it
    /// ([`TriMesh::signed_volume`]): negative when its faces are turned inward.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volume: Option<Real>,
    /// The samples the reconstruction left out, before its finish ([`left_out`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub left_out: Option<LeftOut>,
    /// The cloud's points apart from the object, which widen the grid ([`apart()`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub apart: Option<Apart>,
}

/// The plausibility check of a bare reconstruction on a grid of `cell` against its `cloud` (`tree`
/// is over its positions): inside out ([`Support::volume`]), facing against the samples' normals
/// ([`MAX_AGAINST`]), far from the samples ([`MAX_MEDIAN_GAP`] of the diagonal), leaving samples
/// out ([`MAX_LEFT_OUT`]) or its cloud holding points apart that widen the grid more than
/// [`MAX_WIDENING`]-fold ([`Apart`]): an error unless `force`, else the warnings to give.
pub fn check_support(
    mesh: &TriMesh,
    cloud: rig::CloudRef<'_>,
    tree: &PointTree,
    cell: Real,
    force: bool,
) -> Result<Vec<String>, StageError> {
    let measured = support(mesh, cloud, tree).map(|s| Support {
        volume: Some(mesh.signed_volume()),
        left_out: left_out(mesh, cloud.positions, tree, cell),
        apart: apart(cloud.positions),
        ..s
    });
    measured.map_or(Ok(Vec::new()), |s| judge_support(&s, force))
}

impl Support {
    /// A support with nothing measured: judging it finds nothing.
    fn unmeasured() -> Support {
        Support { median_gap: 0.0, diagonal: 0.0, against: None, volume: None, left_out: None, apart: None }
    }
}

/// [`check_support`]'s measurement, all but the volume and the samples left out (the caller
/// measures those on the mesh before its finish opens it) and the points apart (the cloud's alone,
/// which the caller may have measured before reconstructing); `None` for an empty cloud or mesh.
pub fn support(mesh: &TriMesh, cloud: rig::CloudRef<'_>, tree: &PointTree) -> Option<Support> {
    let positions = cloud.positions;
    let bounds = rig::Aabb::of(positions)?;
    let diagonal = (bounds.max - bounds.min).norm();
    let step = mesh.vertices.len().div_ceil(20_000).max(1);
    let sampled: Vec<usize> = (0..mesh.vertices.len()).step_by(step).collect();
    let nearest: Vec<(usize, Real)> =
        sampled.par_iter().map(|&v| tree.nearest(&mesh.vertices[v])).map(|(j, d2)| (j, d2.sqrt())).collect();
    let mut gaps: Vec<Real> = nearest.iter().map(|n| n.1).collect();
    if gaps.is_empty() {
        return None;
    }
    let mid = gaps.len() / 2;
    let median_gap = *gaps.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    let against = cloud.normals.and_then(|normals| {
        let spacing = spacing(positions, tree);
        let vertex_normals = mesh.vertex_normals();
        let (mut counted, mut turned) = (0usize, 0usize);
        for (&v, &(j, gap)) in sampled.iter().zip(&nearest) {
            let n = normals[j].normalize();
            // Across a wall a few spacings thin (the coarse bunny's ears) a vertex's nearest sample can
            // be on the other side, facing the other way: off that sample's tangent plane by most of
            // the distance to it, such a vertex is not on its sheet and is not counted.
            let off = (mesh.vertices[v] - positions[j]).dot(&n).abs();
            if gap <= NEAR_SPACINGS * spacing && off <= 0.5 * gap.max(spacing) {
                counted += 1;
                turned += usize::from(vertex_normals[v].dot(&n) < 0.0);
            }
        }
        // No vertex on the samples' surface (a spacing of 0: every point five times over) says nothing.
        (counted > 0).then(|| turned as Real / counted as Real)
    });
    Some(Support { median_gap, diagonal, against, volume: None, left_out: None, apart: None })
}

/// The samples of `positions` (`tree` is over them) that a reconstruction on a grid of `cell`
/// leaves out: farther than [`LEFT_OUT_CELLS`] of the larger of the cell and the samples' spacing
/// from every vertex of `mesh`. `None` for an empty cloud or mesh.
pub fn left_out(mesh: &TriMesh, positions: &[Point3], tree: &PointTree, cell: Real) -> Option<LeftOut> {
    if mesh.vertices.is_empty() || positions.is_empty() {
        return None;
    }
    let vertices = PointTree::new(&mesh.vertices);
    let reach = LEFT_OUT_CELLS * cell.max(spacing(positions, tree));
    let step = positions.len().div_ceil(20_000).max(1);
    let gaps: Vec<Real> = positions.par_iter().step_by(step).map(|p| vertices.nearest(p).1.sqrt()).collect();
    let out = gaps.iter().filter(|&&g| g > reach).count();
    Some(LeftOut {
        share: out as Real / gaps.len() as Real,
        reach,
        farthest: gaps.iter().copied().fold(0.0, Real::max),
    })
}

/// The samples' spacing: half the median distance from a sample (up to 5,000, spread over the cloud)
/// to its fourth nearest other one. The fourth, not the first: a cloud with every point twice has
/// its nearest other at 0.
fn spacing(positions: &[Point3], tree: &PointTree) -> Real {
    let step = positions.len().div_ceil(5_000).max(1);
    let mut reach: Vec<Real> =
        positions.par_iter().step_by(step).map(|p| tree.nearest_k_unsorted(p, 5).1.sqrt()).collect();
    if reach.is_empty() {
        return 0.0;
    }
    let mid = reach.len() / 2;
    0.5 * *reach.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1
}

/// What [`judge_support`] finds wrong with a mesh on its cloud.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Finding {
    /// The cloud holds points apart from the object that widen the grid ([`Apart`]): a few strays,
    /// or another part holding 1 % of them or more.
    Apart,
    /// The mesh's faces turn inward ([`Support::volume`]).
    InsideOut,
    /// It faces against its samples' normals ([`MAX_AGAINST`]).
    FacingAgainst,
    /// It lies far from its samples ([`MAX_MEDIAN_GAP`]).
    Far,
    /// It leaves samples out ([`MAX_LEFT_OUT`]).
    LeftOut,
}

/// [`check_support`]'s judgement of a measured (or recorded) [`Support`]: each finding an error
/// unless `force`, the first found refused ([`StageError::Unsupported`]), all of them warned of
/// when forced.
pub fn judge_support(support: &Support, force: bool) -> Result<Vec<String>, StageError> {
    let Support { median_gap: median, diagonal, against, volume, left_out, apart } = *support;
    let mut found: Vec<(Finding, String, &str)> = Vec::new();
    // First: points apart widen the grid, and the rest of what is found follows from it.
    if let Some(a) = apart.filter(|a| a.widening > MAX_WIDENING) {
        found.push((
            Finding::Apart,
            a.describe(
                "the cloud's points",
                "the grid's cells, and the mesh, are that much coarser than the object alone would get",
            ),
            a.hint(),
        ));
    }
    // A surface without volume (a flat cloud's, closed on itself) has a sign of rounding only.
    if let Some(v) = volume.filter(|&v| v < -1e-9 * diagonal.powi(3)) {
        found.push((
            Finding::InsideOut,
            format!(
                "the mesh is inside out: its faces turn inward (it encloses {} in the cloud's units, cubed, counted \
                 negative)",
                three_digits(-v)
            ),
            "the cloud's normals point into the object; turn them around, or drop them (fusion then estimates and \
             orients them); --force keeps it",
        ));
    }
    if let Some(a) = against.filter(|&a| a > MAX_AGAINST) {
        found.push((
            Finding::FacingAgainst,
            format!(
                "the mesh faces against the normal of the sample nearest it at {:.1} % of its vertices on the \
                 samples' surface (over {} %)",
                100.0 * a,
                100.0 * MAX_AGAINST
            ),
            "the cloud's normals are not oriented consistently (some point out, some in), or a wall is thinner than \
             a few grid cells, and the surface there is made up — handles and pockets; orient the normals, or drop \
             them (fusion then estimates and orients them), or raise --depth for a thin wall; --force keeps it",
        ));
    }
    if median > MAX_MEDIAN_GAP * diagonal {
        // In the cloud's own units: a scan's are millimetres, but a file given to `reconstruct` may be
        // in metres (the Stanford scans), where "0.00 mm" would say nothing.
        found.push((
            Finding::Far,
            format!(
                "the mesh lies far from its cloud: half its vertices are more than {} from any point ({:.1} % of \
                 the cloud's {} diagonal, over {} %; in the cloud's units)",
                three_digits(median),
                100.0 * median / diagonal,
                three_digits(diagonal),
                100.0 * MAX_MEDIAN_GAP
            ),
            "most of the surface is not in the data — normals that disagree or point inward, or a cluster of stray \
             points; --force keeps it",
        ));
    }
    if let Some(l) = left_out.filter(|l| l.share > MAX_LEFT_OUT) {
        found.push((
            Finding::LeftOut,
            format!(
                "the mesh leaves out {:.1} % of the cloud's samples (over {} %): they lie more than {} from every \
                 vertex, the farthest {} (in the cloud's units)",
                100.0 * l.share,
                100.0 * MAX_LEFT_OUT,
                three_digits(l.reach),
                three_digits(l.farthest)
            ),
            "the surface lost a part of the object (a thin part whose normals disagree, or too coarse a --depth), or \
             the cloud holds stray points (fusion removes them); --force keeps it",
        ));
    }
    if force {
        return Ok(found.into_iter().map(|(_, what, _)| format!("{what} (--force)")).collect());
    }
    match found.into_iter().next() {
        Some((finding, what, hint)) => Err(StageError::Unsupported { finding, what, hint: hint.into() }),
        None => Ok(Vec::new()),
    }
}

/// `x` to three significant digits, whatever its scale (1234 → "1234", 0.0123456 → "0.0123"),
/// in powers of ten past a million (an exporter's stray vertex at 1e30: "1.73e30").
pub(super) fn three_digits(x: Real) -> String {
    if x.abs() >= 1e6 && x.is_finite() {
        return format!("{x:.2e}");
    }
    let decimals = if x > 0.0 && x.is_finite() { (2 - x.log10().floor() as i32).clamp(0, 12) } else { 2 };
    format!("{x:.*}", decimals as usize)
}

/// Refuses a cloud no stage can use: a NaN or infinite position or normal (every later distance
/// would be NaN), a zero normal, or a pile of points at one place ([`PILE_SHARE`]).
pub(super) fn check_cloud(cloud: rig::CloudRef<'_>) -> Result<(), StageError> {
    let bad_point = cloud.positions.iter().position(|p| !p.coords.iter().all(|x| x.is_finite()));
    let bad_normal = cloud.normals.and_then(|n| n.iter().position(|v| !v.iter().all(|x| x.is_finite())));
    if let Some(index) = bad_point.into_iter().chain(bad_normal).min() {
        return Err(StageError::NonFinite { index });
    }
    if let Some(n) = cloud.normals {
        let zero: Vec<usize> = (0..n.len()).filter(|&i| n[i].norm_squared() <= 1e-24).collect();
        if let Some(&index) = zero.first() {
            return Err(StageError::ZeroNormal { index, count: zero.len() });
        }
    }
    // Every point at one place (a file of one point repeated), however few: no extent, so no
    // surface to find, whatever the normals say.
    if let Some(b) = rig::Aabb::of(cloud.positions).filter(|b| b.min == b.max) {
        return Err(StageError::Pile { count: cloud.len(), points: cloud.len(), at: [b.min.x, b.min.y, b.min.z] });
    }
    if let Some((at, count)) = pile(cloud.positions) {
        return Err(StageError::Pile { count, points: cloud.len(), at: [at.x, at.y, at.z] });
    }
    Ok(())
}

/// The largest share of a cloud's points that may lie at exactly one place (a pile is refused only
/// when it also holds over [`PILE_POINTS`]): a scan's points are measured apart; a pile is what an exporter writes
/// for the pixels it measured nothing at. 8,000 such points at the origin beside a sphere were
/// reconstructed into a blob there (refused only as samples left out, 28.6 %).
pub const PILE_SHARE: Real = 0.01;

/// A pile of this many points or fewer is let be, however small the cloud.
pub const PILE_POINTS: usize = 20;

/// The place holding the most of `positions` exactly, with how many, when that is over
/// [`PILE_SHARE`] of them and over [`PILE_POINTS`]. A pile that large is in a sample of 2,000
/// points spread over the cloud about 20 times, so only places seen there three times or more are
/// counted, in one pass. The sample takes one point from each run of the cloud at a place in it
/// drawn at random (seeded: the same every time): a fixed stride would never see a pile laid out in
/// step with it, as a grid export's invalid border columns are.
fn pile(positions: &[Point3]) -> Option<(Point3, usize)> {
    // The same place, bit for bit (+0 and −0 alike).
    let bits = |p: &Point3| -> [u64; 3] { p.coords.map(|x| if x == 0.0 { 0 } else { x.to_bits() }).into() };
    let step = positions.len().div_ceil(2_000).max(1);
    let mut draw = rig::split_mix::SplitMix(0x5ca1ab1e);
    let mut sample: Vec<[u64; 3]> = (0..positions.len())
        .step_by(step)
        .map(|start| bits(&positions[start + draw.below(step.min(positions.len() - start))]))
        .collect();
    sample.sort_unstable();
    let mut counts: HashMap<[u64; 3], usize> = sample.windows(3).filter(|w| w[0] == w[2]).map(|w| (w[0], 0)).collect();
    if counts.is_empty() {
        return None;
    }
    for p in positions {
        if let Some(c) = counts.get_mut(&bits(p)) {
            *c += 1;
        }
    }
    let limit = ((PILE_SHARE * positions.len() as Real) as usize).max(PILE_POINTS);
    let (key, count) = counts.into_iter().max_by_key(|&(key, count)| (count, key))?;
    (count > limit).then(|| (Point3::from(key.map(|b| if b == 0 { 0.0 } else { Real::from_bits(b) })), count))
}

/// A reconstructed mesh as it is written: with its vertex normals, which viewers shade by, and the
/// colours of `colours` where given.
pub fn mesh_for_output(mesh: &TriMesh, colours: Option<Vec<[u8; 3]>>) -> PolyMesh {
    PolyMesh { normals: Some(mesh.vertex_normals()), colors: colours, ..mesh.to_poly() }
}

/// Each mesh vertex's colour from the cloud it was made from: the inverse-distance mean of its four
/// nearest coloured samples (a vertex lies between samples, and one sample's noise should not be its
/// colour). `None` when the cloud has no colour.
pub fn mesh_colours(mesh: &TriMesh, cloud: rig::CloudRef<'_>, tree: &PointTree) -> Option<Vec<[u8; 3]>> {
    use rayon::prelude::*;
    let colors = cloud.colors.filter(|c| !c.is_empty())?;
    Some(
        mesh.vertices
            .par_iter()
            .map(|v| {
                let (mut sum, mut den) = ([0.0; 3], 0.0);
                for j in tree.nearest_k(v, 4) {
                    let w = 1.0 / ((cloud.positions[j] - v).norm() + 1e-6);
                    for c in 0..3 {
                        sum[c] += w * colors[j][c] as Real;
                    }
                    den += w;
                }
                sum.map(|s| (s / den).round().clamp(0.0, 255.0) as u8)
            })
            .collect(),
    )
}

/// The close stage's code version.
pub const CLOSE: StageCode = StageCode { stage: "close", version: 1 };
/// The mesh stage's code version (reconstruction, finish, support check, colours; 2: `--trim-fill`
/// closes holes by whether the mesh had them before trimming, not by where they lie; 3: the low-pass
/// and AdFFT's coarse χ computed separably, which moves vertices by rounding; 4: AdFFT's level
/// evaluated along rows, the same rounding kind, and its grid no finer than the samples carry; 5: the
/// record keeps the support check's measurement, which a reused mesh is judged by again; 6: and how
/// high the reconstruction rose above the working volume's top, for the same; 7: and whether it is inside
/// out, faces against its samples' normals or leaves samples out, which are refused unless forced;
/// 8: and the cloud's points apart from the object, which widen the grid, refused the same way; 9: the
/// object is the widest piece with every piece within its size chained to it, so a second object far
/// away is apart too, where a mesh kept from before had taken it for the object's own).
pub const MESH: StageCode = StageCode { stage: "mesh", version: 9 };

/// What the closed cloud is made from besides the fused cloud: the closing parameters.
pub fn close_fingerprint(params: &CloseParams) -> Fingerprint {
    Fingerprint::new(CLOSE, json!({ "close": params }))
}

/// Closing a turntable scan's openings: flat caps of samples over its open base and top (object
/// frame), so reconstruction closes them flat ([`crate::reconstruct::closing`]).
pub fn close(cloud: &PointCloud, params: &CloseParams) -> Result<(PointCloud, CloseReport), StageError> {
    check_cloud(cloud.borrowed())?;
    Ok(close_openings(cloud, params))
}

/// The mesh stage as `process` runs it: reconstruction, its finish, and where the mesh may go.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MeshParams {
    /// The reconstruction method and its parameters.
    pub reconstruct: ReconstructParams,
    /// Base and trim.
    pub finish: FinishParams,
    /// The platter plane, where the base is cut (object z = 0 on a turntable); `None`: not known.
    pub platter_z: Option<Real>,
    /// The working volume's top (the object's, as the merge found it): no surface above it.
    pub top_z: Option<Real>,
    /// Keep a mesh the data does not support ([`check_support`]), warned of.
    #[serde(skip)]
    pub force: bool,
}

/// What the mesh stage made: the mesh, the same mesh as it is written (vertex normals, colours), its
/// record and what it warns of (each about the mesh, for the caller to name its file).
#[derive(Debug, Clone)]
pub struct MeshMade {
    /// The finished triangle mesh.
    pub mesh: TriMesh,
    /// The mesh as written ([`mesh_for_output`]): with vertex normals and the cloud's colours.
    pub output: PolyMesh,
    /// The reconstruction's and the finish's reports.
    pub report: MeshReport,
    /// What the caller should say (the top cut, a base not cut or not closed, a forced support
    /// check, self-intersections left).
    pub warnings: Vec<String>,
}

/// What a mesh is made from besides its cloud.
pub fn mesh_fingerprint(params: &MeshParams) -> Fingerprint {
    Fingerprint::new(
        MESH,
        json!({
            "reconstruct": params.reconstruct,
            "finish": params.finish,
            "platter_z": params.platter_z,
            "top_z": params.top_z,
        }),
    )
}

/// The mesh stage: reconstructs `input` (ch. 5), finishes it (base, trim), cuts it at the working
/// volume's top, checks that the data supports it (an error unless forced) and colours it from the
/// cloud. One k-d tree over the samples serves the area weights, the support check and the colours.
/// `scanrig process`, `scanrig reconstruct` and the Python bindings all mesh through this function.
/// The cloud is borrowed (a caller's arrays are meshed where they lie).
pub fn mesh<'a>(input: impl Into<rig::CloudRef<'a>>, params: &MeshParams) -> Result<MeshMade, StageError> {
    mesh_counting(input, params, &AtomicUsize::new(0))
}

/// [`mesh`], counting in `steps` the reconstruction's steps done (up to
/// [`ReconstructParams::counted_steps`]), for a progress display ([`crate::pipeline::watch`]).
pub fn mesh_counting<'a>(
    input: impl Into<rig::CloudRef<'a>>,
    params: &MeshParams,
    steps: &AtomicUsize,
) -> Result<MeshMade, StageError> {
    mesh_of(input.into(), params, steps)
}

/// [`mesh_counting`]'s body, compiled once here rather than into every caller's crate.
fn mesh_of(input: rig::CloudRef<'_>, params: &MeshParams, steps: &AtomicUsize) -> Result<MeshMade, StageError> {
    params.validate()?;
    // Points apart from the object depend on the cloud alone: refused before a reconstruction that
    // may take minutes (and kept with the mesh's support, judged again as a reused mesh is). A cloud
    // no stage can use is refused first, by what is wrong with it (the reconstruction checks it
    // again: a pass over the points, a millisecond on the ten bunny scans).
    check_cloud(input)?;
    check_trim(params.finish.trim, input.positions)?;
    let apart = apart(input.positions);
    if !params.force {
        judge_support(&Support { apart, ..Support::unmeasured() }, false)?;
    }
    let tree = PointTree::new(input.positions);
    let (mesh, reconstructed) = reconstruct_in(input, &params.reconstruct, Some(&tree), steps)?;
    // Measured before the finish cuts the base or trims: the bare reconstruction is closed, and
    // runs through every sample it keeps.
    let (volume, left) = (mesh.signed_volume(), left_out(&mesh, input.positions, &tree, reconstructed.cell()));
    let (mut mesh, mut finish) = finish(mesh, input.positions, &params.finish, params.platter_z, reconstructed.cell())?;
    if let Some(z) = params.top_z {
        let high = mesh.vertices.iter().map(|p| p.z).fold(Real::NEG_INFINITY, Real::max);
        if let Some((cut, r)) = crate::reconstruct::top_cut::cut_top(&mesh, z)? {
            (mesh, finish.top, finish.rose_to) = (cut, Some(r), Some(high));
        }
    }
    let support = support(&mesh, input, &tree).map(|s| Support { volume: Some(volume), left_out: left, apart, ..s });
    let report = MeshReport { reconstruct: reconstructed, finish, support };
    // Checked before anything is written: unforced, an unsupported mesh leaves no mesh file.
    let warnings = judge_mesh(&report, params.force)?;
    let colours = mesh_colours(&mesh, input, &tree);
    drop(tree);
    let output = mesh_for_output(&mesh, colours);
    Ok(MeshMade { mesh, output, report, warnings })
}

/// What is wrong with a mesh, from its record alone, so a reused mesh is judged as the run that made
/// it was: inside out, facing against its samples' normals, far from them, leaving samples out or
/// coarsened by points apart from the object
/// (each an error unless `force`, [`judge_support`]), cut at the working volume's top, a base not
/// cut or not closed, and what the reconstruction's report says.
pub fn judge_mesh(report: &MeshReport, force: bool) -> Result<Vec<String>, StageError> {
    let finish = &report.finish;
    let mut warnings = Vec::new();
    if let (Some(r), Some(high)) = (&finish.top, finish.rose_to) {
        // A millimetre of the low-pass's rounding is the reconstruction's own: recorded, not warned of.
        if high > r.z + 1.0 {
            warnings.push(format!(
                "the reconstruction rose to {high:.1} mm, above the working volume's top at {:.1} mm (the object's \
                 top as the merge found it): cut flat there ({} triangles removed)",
                r.z, r.removed
            ));
        }
    }
    if let Some(b) = finish.base.filter(|b| b.outline_edges == 0) {
        warnings.push(format!(
            "the mesh does not reach {} mm above the platter, so its base was not cut ({:?}): the object seems not \
             to stand on the platter (check the rig's [turntable])",
            b.z + b.skirt,
            b.base
        ));
    }
    if let Some(b) = finish.base.filter(|b| b.base == Base::Flat && !b.closed) {
        warnings.push(format!(
            "the flat base at z = {} did not close the mesh ({} outline edges capped by {} triangles); slicers may \
             refuse it (--base open or closed to choose otherwise)",
            b.z, b.outline_edges, b.cap_triangles
        ));
    }
    if let Some(s) = &report.support {
        warnings.extend(judge_support(s, force)?);
    }
    warnings.extend(report_warnings(&report.reconstruct));
    Ok(warnings)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The far-mesh check speaks in the cloud's own units: a cloud in metres (the Stanford scans')
    /// is told its gap in metres, not as "0.00 mm".
    #[test]
    fn a_far_mesh_is_told_in_the_clouds_units() {
        // Points on a 3 cm (0.03 m) circle; a mesh 0.02 m beside them (a third of the diagonal).
        let positions: Vec<Point3> = (0..200)
            .map(|k| {
                let a = k as Real * std::f64::consts::TAU / 200.0;
                Point3::new(0.03 * a.cos(), 0.03 * a.sin(), 0.0)
            })
            .collect();
        let mesh = TriMesh {
            vertices: vec![Point3::new(0.0, 0.0, 0.02), Point3::new(0.001, 0.0, 0.02), Point3::new(0.0, 0.001, 0.02)],
            faces: vec![[0, 1, 2]],
            ..Default::default()
        };
        let tree = PointTree::new(&positions);
        let cloud = rig::CloudRef::positions(&positions);
        let e = check_support(&mesh, cloud, &tree, 0.001, false).unwrap_err().to_string();
        assert!(e.contains("more than 0.0352 from any point") && e.contains("0.0849 diagonal"), "{e}");
        assert!(!e.contains(" mm"), "{e}");
        // Forced, it is said, and so is every point it leaves out.
        let forced = check_support(&mesh, cloud, &tree, 0.001, true).unwrap();
        assert!(forced.len() == 2 && forced[0].ends_with("(--force)"), "{forced:?}");
        assert!(forced[1].starts_with("the mesh leaves out 100.0 % of the cloud's samples"), "{forced:?}");
    }

    /// A sphere's samples and its reconstruction agree: outward, facing its samples, through all of
    /// them. Samples off it are left out; faces turned inward are an inside-out mesh; a quarter of the
    /// normals turned, a mesh facing against them. Each is refused, the inside-out first; forced, all
    /// are warned of.
    #[test]
    fn an_inside_out_mesh_and_one_facing_against_its_samples_are_refused() {
        let mut cloud = crate::reconstruct::global_fft::tests::sphere(4000, 30.0);
        let params = ReconstructParams::Fft(FftParams { depth: 6, ..Default::default() });
        let (mesh, report) = reconstruct(&cloud, &params).unwrap();
        let (tree, cell) = (PointTree::new(&cloud.positions), report.cell());
        let s = support(&mesh, cloud.borrowed(), &tree).unwrap();
        assert!(s.against == Some(0.0) && s.median_gap < 1.0, "{s:?}");
        assert!((mesh.signed_volume() / (4.0 / 3.0 * std::f64::consts::PI * 27e3) - 1.0).abs() < 0.05);
        assert_eq!(check_support(&mesh, cloud.borrowed(), &tree, cell, false).unwrap(), Vec::<String>::new());
        // A patch of samples 15 mm off the sphere, which no surface runs through: left out.
        let mut patched = cloud.clone();
        for k in 0..150 {
            patched.positions.push(Point3::new(45.0 + (k % 10) as Real * 0.5, (k / 10) as Real * 0.5, 0.0));
            patched.normals.as_mut().unwrap().push(rig::math::Vector3::x());
        }
        let patched_tree = PointTree::new(&patched.positions);
        let e = check_support(&mesh, patched.borrowed(), &patched_tree, cell, false).unwrap_err().to_string();
        assert!(e.starts_with("the mesh leaves out 3.6 % of the cloud's samples") && e.contains("stray"), "{e}");
        // The same mesh, faces turned: inside out (and facing against every sample).
        let turned = TriMesh { faces: mesh.faces.iter().map(|&[a, b, c]| [a, c, b]).collect(), ..mesh.clone() };
        let e = check_support(&turned, cloud.borrowed(), &tree, cell, false).unwrap_err().to_string();
        assert!(e.starts_with("the mesh is inside out") && e.contains("point into the object"), "{e}");
        let w = check_support(&turned, cloud.borrowed(), &tree, cell, true).unwrap();
        assert!(w.len() == 2 && w[1].contains("faces against") && w[1].ends_with("(--force)"), "{w:?}");
        // A quarter of the normals turned: the mesh made of them faces against its samples.
        let normals = cloud.normals.as_mut().unwrap();
        normals.iter_mut().step_by(4).for_each(|n| *n = -*n);
        let (mixed, _) = reconstruct(&cloud, &params).unwrap();
        let s = support(&mixed, cloud.borrowed(), &tree).unwrap();
        assert!(s.against.unwrap() > 0.1, "{s:?}");
        let e = check_support(&mixed, cloud.borrowed(), &tree, cell, false).unwrap_err().to_string();
        assert!(e.contains("faces against") && e.contains("not oriented consistently"), "{e}");
    }

    /// Every warning a mesh's run gave comes from its record, so a reused mesh gives them again.
    #[test]
    fn a_mesh_is_judged_from_its_record_alone() {
        let mut r = MeshReport {
            reconstruct: ReconstructReport::Fft(FftReport::default()),
            finish: FinishReport::default(),
            support: Some(Support {
                median_gap: 0.1,
                diagonal: 100.0,
                against: Some(0.0),
                volume: Some(1e4),
                left_out: None,
                apart: None,
            }),
        };
        assert_eq!(judge_mesh(&r, false).unwrap(), Vec::<String>::new());
        // Cut at the working volume's top: warned of beyond the low-pass's millimetre of rounding.
        r.finish.top = Some(BaseReport { z: 80.0, removed: 12, ..Default::default() });
        r.finish.rose_to = Some(80.8);
        assert_eq!(judge_mesh(&r, false).unwrap(), Vec::<String>::new());
        r.finish.rose_to = Some(86.5);
        let w = judge_mesh(&r, false).unwrap();
        assert!(w.len() == 1 && w[0].contains("rose to 86.5 mm") && w[0].contains("12 triangles removed"), "{w:?}");
        // A base that was not cut, and a flat one that did not close.
        r.finish.top = None;
        r.finish.base = Some(BaseReport { base: Base::Flat, z: 0.0, skirt: 1.5, ..Default::default() });
        let w = judge_mesh(&r, false).unwrap();
        assert!(w.iter().any(|w| w.contains("does not reach 1.5 mm above the platter")), "{w:?}");
        r.finish.base =
            Some(BaseReport { base: Base::Flat, outline_edges: 40, cap_triangles: 30, ..Default::default() });
        let w = judge_mesh(&r, false).unwrap();
        assert!(w.len() == 1 && w[0].contains("did not close the mesh (40 outline edges"), "{w:?}");
        // Inside out, and samples left out: refused from the record alone, both said when forced.
        let left_out = Some(LeftOut { share: 0.03, reach: 1.0, farthest: 12.0 });
        r.support = Some(Support {
            median_gap: 0.1,
            diagonal: 100.0,
            against: Some(0.0),
            volume: Some(-5e4),
            left_out,
            apart: None,
        });
        let e = judge_mesh(&r, false).unwrap_err().to_string();
        assert!(e.starts_with("the mesh is inside out"), "{e}");
        let w = judge_mesh(&r, true).unwrap();
        assert!(w.iter().any(|w| w.starts_with("the mesh is inside out") && w.ends_with("(--force)")), "{w:?}");
        assert!(
            w.iter().any(|w| w.starts_with("the mesh leaves out 3.0 %") && w.contains("the farthest 12.0")),
            "{w:?}"
        );
        // Far from its cloud: refused unless forced, and then said.
        r.support = Some(Support {
            median_gap: 30.0,
            diagonal: 100.0,
            against: None,
            volume: None,
            left_out: None,
            apart: None,
        });
        assert!(judge_mesh(&r, false).is_err());
        assert!(judge_mesh(&r, true).unwrap().iter().any(|w| w.ends_with("(--force)")));
    }

    /// A pile of points at one place is found wherever in the file it is; a cloud of points each
    /// given five times, or a pile of under 1 %, is not one.
    #[test]
    fn a_pile_of_points_at_one_place_is_found() {
        let spread: Vec<Point3> = (0..20_000).map(|i| Point3::new(i as Real * 0.01, (i % 7) as Real, 1.0)).collect();
        assert_eq!(pile(&spread), None);
        let fivefold: Vec<Point3> = spread.iter().flat_map(|p| [*p; 5]).collect();
        assert_eq!(pile(&fivefold), None);
        // 1.2 % at the origin: in a block, and every 83rd point (as a sample's stride might miss).
        let mut block = spread.clone();
        block.splice(5_000..5_000, [Point3::new(0.0, -0.0, 0.0); 243]);
        assert_eq!(pile(&block), Some((Point3::origin(), 243)));
        let every: Vec<Point3> =
            spread.iter().enumerate().map(|(i, p)| if i % 83 == 0 { Point3::origin() } else { *p }).collect();
        assert_eq!(pile(&every).map(|(_, n)| n), Some(20_000usize.div_ceil(83)));
        // In step with the sample's runs (10 points each here): every 10th point, and the last two
        // of every run of 100 (a grid's right border).
        let in_step: Vec<Point3> =
            spread.iter().enumerate().map(|(i, p)| if i % 10 == 7 { Point3::origin() } else { *p }).collect();
        assert_eq!(pile(&in_step).map(|(_, n)| n), Some(2_000));
        let border: Vec<Point3> =
            spread.iter().enumerate().map(|(i, p)| if i % 100 >= 98 { Point3::origin() } else { *p }).collect();
        assert_eq!(pile(&border).map(|(_, n)| n), Some(400));
        // Under 1 %: let be.
        let mut few = spread.clone();
        few.extend([Point3::origin(); 150]);
        assert_eq!(pile(&few), None);
    }

    #[test]
    fn three_digits_keep_three_significant_digits_at_any_scale() {
        assert_eq!(three_digits(1234.4), "1234");
        assert_eq!(three_digits(12.345), "12.3");
        assert_eq!(three_digits(0.0123456), "0.0123");
        assert_eq!(three_digits(0.0), "0.00");
        assert_eq!(three_digits(1.732e30), "1.73e30");
    }
}

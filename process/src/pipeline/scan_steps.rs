//! The scan's steps: merge → register → fuse → close → mesh → remesh, each through [`Out::step`]
//! with the fingerprint its stage declares ([`super::stages`]), each handing its output on in memory
//! where it made it (else the next step reads the file).

use super::layout;
use super::out::{Out, Scope};
use super::records::{Fingerprint, Hash};
use super::report::ProcessReport;
use super::stages::{self, StageError};
use super::view_steps::{Measured, ViewOutput};
use super::{ProcessParams, Progress, Stage};
use crate::Error;
use crate::merge::CropParams;
use crate::merge::object_top::TopParams;
use crate::merge::views::{ViewData, ViewGrid};
use rayon::prelude::*;
use rig::math::Real;
use rig::scan_folder::Method;
use rig::{PointCloud, PolyMesh, Rig, TriMesh};

/// What every scan step shares.
pub(super) struct ScanCx<'a> {
    pub o: &'a Out,
    pub rig: &'a Rig,
    pub method: Method,
    pub params: &'a ProcessParams,
    /// Each view's pass (from 1), by view number: a scan of several passes is aligned pass to pass.
    pub pass_of: Vec<u32>,
    /// Whether the views processed belong to several passes.
    pub several: bool,
}

impl ScanCx<'_> {
    /// Whether the views processed belong to several passes.
    pub fn passes(&self) -> bool {
        self.several
    }
}

/// An output handed to the next step: its name and content hash, and what it holds where it was
/// made in this run.
pub(super) struct Handed<T> {
    pub name: &'static str,
    pub hash: Hash,
    pub held: Option<T>,
}

impl Handed<PointCloud> {
    /// The cloud, from memory or read from its file.
    fn take(&mut self, o: &Out) -> Result<PointCloud, Error> {
        match self.held.take() {
            Some(c) => Ok(c),
            None => Ok(rig::read_cloud(&o.path(self.name))?),
        }
    }
}

/// Loads the views' measurements a scan stage needs that are not in memory.
fn load_grids(o: &Out, outputs: &mut [ViewOutput]) -> Result<(), Error> {
    let loaded: Vec<Option<Measured>> = outputs
        .par_iter()
        .map(|vo| match (&vo.data, vo.laser) {
            (Some(_), _) => Ok(None),
            (None, None) => o.read_grid(&vo.name).map(|g| Some(Measured::Grid(g))),
            (None, Some(_)) => Ok(Some(Measured::Sparse(rig::ply::read_sparse_view(&o.path(&vo.name))?))),
        })
        .collect::<Result<_, Error>>()?;
    for (vo, g) in outputs.iter_mut().zip(loaded) {
        if g.is_some() {
            vo.data = g;
        }
    }
    Ok(())
}

fn view_grids(outputs: &[ViewOutput]) -> Vec<ViewGrid<'_>> {
    outputs
        .iter()
        .map(|vo| {
            let data = match vo.data.as_ref().expect("loaded") {
                Measured::Grid(g) => ViewData::Grid(g),
                Measured::Sparse(s) => ViewData::Sparse(s),
            };
            ViewGrid { view: vo.view, angle_deg: vo.angle_deg, laser: vo.laser, data }
        })
        .collect()
}

/// The views' measurements as inputs, with the turntable angle each is placed at: an angle
/// corrected in scan.json (a wrong step given at import) moves its view, so nothing placed at the old
/// angle may be reused.
fn grid_inputs(mut fp: Fingerprint, outputs: &[ViewOutput]) -> Fingerprint {
    let angles: std::collections::BTreeMap<usize, Real> = outputs.iter().map(|vo| (vo.view, vo.angle_deg)).collect();
    fp.params["angles_deg"] = serde_json::json!(angles);
    outputs.iter().fold(fp, |fp, vo| fp.input(&vo.name, vo.hash))
}

/// Merge, within the working volume: a laser scan's capped at the object's top its lines show.
pub(super) fn merge_step(
    cx: &ScanCx,
    report: &mut ProcessReport,
    outputs: &mut [ViewOutput],
    crop: &CropParams,
) -> Result<Handed<PointCloud>, Error> {
    let (o, rig, method) = (cx.o, cx.rig, cx.method);
    let top = (method == Method::Laser).then(TopParams::default);
    let fp = grid_inputs(stages::merge_fingerprint(crop, top.as_ref(), rig.turntable.as_ref()), outputs);
    let step = o.step(&[layout::MERGED], fp, Scope::Scan, |fp| {
        load_grids(o, outputs)?;
        let volume = super::volume::working_volume(&view_grids(outputs), rig.turntable.as_ref(), crop, top.as_ref());
        let (merged, mut mr) = stages::merge(&view_grids(outputs), rig.turntable.as_ref(), &volume.crop(crop));
        mr.volume = Some(volume);
        let measured: usize = outputs
            .iter()
            .map(|vo| match vo.data.as_ref() {
                Some(Measured::Grid(g)) => g.valid.iter().filter(|&&v| v).count(),
                Some(Measured::Sparse(s)) => s.points.len(),
                None => 0,
            })
            .sum();
        if measured == 0 {
            return Err(Error::LeftNothing {
                stage: Stage::Triangulate,
                why: format!(
                    "none of the {} view(s) gave a point: check that the scan's method ({method:?} in scan.json) is \
                     how its frames were captured, and that its frames show the object lit",
                    outputs.len()
                ),
            });
        }
        if merged.positions.is_empty() {
            return Err(Error::LeftNothing {
                stage: Stage::Merge,
                why: format!(
                    "no point of the {} view(s) lies inside the object cylinder (radius {}, at least {} mm above the \
                     platter): check --crop-radius and --crop-min-height, and the rig's turntable axis",
                    outputs.len(),
                    crop.radius_mm.map_or("the platter's".to_string(), |r| format!("{r} mm")),
                    crop.min_height_mm
                ),
            });
        }
        let (merged, hash) = o.put_cloud(layout::MERGED, &merged, fp, &mr, false)?;
        Ok((merged, hash, mr))
    })?;
    report.merge = step.section;
    report.outputs.push(layout::MERGED.into());
    o.save()?;
    Ok(Handed { name: layout::MERGED, hash: step.hash, held: step.held })
}

/// Register: the views placed again by multi-view ICP from their turntable poses (a laser scan's
/// lasers aligned with each other), or a word in `skipped` where that cannot be done.
pub(super) fn register_step(
    cx: &ScanCx,
    report: &mut ProcessReport,
    outputs: &mut [ViewOutput],
    crop: &CropParams,
    cloud: &mut Handed<PointCloud>,
) -> Result<bool, Error> {
    let (o, rig, method, params) = (cx.o, cx.rig, cx.method, cx.params);
    // A laser scan registers laser against laser: it needs two lasers' lines. Passes are aligned
    // whatever each holds.
    let enough = cx.passes()
        || match method {
            Method::Laser => outputs.iter().filter_map(|o| o.laser).max().is_some_and(|k| k >= 1),
            _ => outputs.len() >= 2,
        };
    let axis = match (method, rig.turntable.as_ref()) {
        (_, Some(axis)) if enough => axis,
        (Method::StructuredLight, Some(_)) => {
            report.skipped.push("register: needs at least two views".into());
            return Ok(false);
        }
        (_, None) if cx.passes() => {
            // Fused unaligned, the passes would make two objects of one.
            return Err(Error::Stage {
                stage: Stage::Register,
                source: StageError::Implausible {
                    what: "this scan has several passes, but the rig has no [turntable] to place each pass's views by"
                        .into(),
                    hint: "calibrate the turntable (`scanrig calibrate turntable`), or process each pass alone \
                           (--views) and align their clouds with `scanrig align`"
                        .into(),
                },
            });
        }
        (_, None) => {
            report.skipped.push("register: the rig has no [turntable] to start from".into());
            return Ok(false);
        }
        _ => {
            report.skipped.push(
                "register: one laser's lines only: a line alone fixes no pose, and there is no second laser to check \
                 it against"
                    .into(),
            );
            return Ok(false);
        }
    };
    let mut fp = stages::register_fingerprint(crop, &params.register, rig.turntable.as_ref());
    if cx.passes() {
        // Each registered view's pass: the same grids split into other passes register otherwise.
        let passes: Vec<(usize, u32)> = outputs.iter().map(|vo| (vo.view, cx.pass_of[vo.view])).collect();
        fp.params["passes"] = serde_json::json!(passes);
    }
    let fp = grid_inputs(fp, outputs);
    let check = |rr: &stages::RegisterReport| {
        rr.check(&params.register.tolerance, params.force)
            .map_err(|source| Error::Stage { stage: Stage::Register, source })
    };
    let mut warnings = Vec::new();
    let step = o.step(&[layout::REGISTERED, layout::POSES], fp, Scope::Scan, |fp| {
        // Registration starts from the grids; the merged cloud is on disk.
        drop(cloud.held.take());
        load_grids(o, outputs)?;
        let grids = view_grids(outputs);
        let pass_of = |v: usize| cx.pass_of.get(v).copied().unwrap_or(1);
        let (registered, poses, rr) = match cx.passes() {
            true => stages::register_passes(&grids, &pass_of, axis, crop, &params.register),
            false => stages::register(&grids, axis, crop, &params.register),
        }
        .map_err(|source| Error::Stage { stage: Stage::Register, source })?;
        // Checked before anything is written: an unforced implausible registration leaves the
        // folder as the merge left it.
        warnings = check(&rr)?;
        let (registered, hash) = o.put_cloud(layout::REGISTERED, &registered, fp.clone(), &rr, true)?;
        o.put(layout::POSES, &stages::poses_json(&poses), fp, &rr)?;
        Ok((registered, hash, rr))
    })?;
    if let (true, Some(s)) = (step.reused(), &step.section) {
        warnings = check(&s.report)?;
    }
    report.warnings.extend(warnings);
    report.register = step.section;
    *cloud = Handed { name: layout::REGISTERED, hash: step.hash, held: step.held };
    report.outputs.push(layout::REGISTERED.into());
    report.outputs.push(layout::POSES.into());
    o.save()?;
    Ok(true)
}

/// Fuse: mean shift (ch. 3), with progress from inside.
pub(super) fn fuse_step(
    cx: &ScanCx,
    report: &mut ProcessReport,
    mut cloud: Handed<PointCloud>,
    progress: &mut impl Progress,
) -> Result<Handed<PointCloud>, Error> {
    let (o, params) = (cx.o, cx.params);
    let fp = stages::fuse_fingerprint(&params.fuse).input(cloud.name, cloud.hash);
    let step = o.step(&[layout::FUSED], fp, Scope::Scan, |fp| {
        let input = cloud.take(o)?;
        // Progress from inside: the samples whose shift has begun, out of all of them.
        let (total, fp_params) = (input.len(), &params.fuse);
        let (result, fr) = super::watch::watched(
            total,
            |moved| stages::fuse_counting(input, fp_params, moved),
            |done, total| progress(Stage::Fuse, done, total),
        )
        .map_err(|source| Error::Stage { stage: Stage::Fuse, source })?;
        let (fused, hash) = o.put_cloud(layout::FUSED, &result.cloud, fp, &fr, true)?;
        Ok((fused, hash, fr))
    })?;
    report.fuse = step.section;
    report.outputs.push(layout::FUSED.into());
    o.save()?;
    Ok(Handed { name: layout::FUSED, hash: step.hash, held: step.held })
}

/// Close: flat caps over the open base and top, in the object frame a turntable gives (without
/// one, or not asked, the fused cloud goes on as it is).
pub(super) fn close_step(
    cx: &ScanCx,
    report: &mut ProcessReport,
    mut fused: Handed<PointCloud>,
) -> Result<Handed<PointCloud>, Error> {
    let o = cx.o;
    let cp = match (&cx.params.close, cx.rig.turntable.is_some()) {
        (Some(cp), true) => cp,
        (Some(_), false) => {
            report.skipped.push("close: the rig has no [turntable], so no platter and no up to cap by".into());
            return Ok(fused);
        }
        (None, _) => return Ok(fused),
    };
    if cx.passes() {
        report.skipped.push("close: the passes together measured the base and top; nothing is capped".into());
        return Ok(fused);
    }
    let fp = stages::close_fingerprint(cp).input(fused.name, fused.hash);
    let step = o.step(&[layout::CLOSED], fp, Scope::Scan, |fp| {
        let input = fused.take(o)?;
        let (closed, cr) =
            stages::close(&input, cp).map_err(|source| Error::Stage { stage: Stage::Reconstruct, source })?;
        let (closed, hash) = o.put_cloud(layout::CLOSED, &closed, fp, &cr, true)?;
        Ok((closed, hash, cr))
    })?;
    report.close = step.section;
    report.outputs.push(layout::CLOSED.into());
    o.save()?;
    Ok(Handed { name: layout::CLOSED, hash: step.hash, held: step.held })
}

/// Mesh: [`stages::mesh`] with the platter plane and the working volume's top a turntable gives;
/// written as PLY, then as STL and GLB.
pub(super) fn mesh_step(
    cx: &ScanCx,
    report: &mut ProcessReport,
    mut input: Handed<PointCloud>,
    crop: &CropParams,
    progress: &mut impl Progress,
) -> Result<Handed<TriMesh>, Error> {
    let (o, rig, method, params) = (cx.o, cx.rig, cx.method, cx.params);
    let on_turntable = rig.turntable.is_some();
    let mp = stages::MeshParams {
        reconstruct: params.reconstruct,
        finish: params.finish,
        // The platter plane, where the base is cut: object z = 0 on a turntable — unless another pass
        // measured the base (the object turned over).
        platter_z: (on_turntable && !cx.passes()).then_some(0.0),
        // The working volume's top (the object's, as the merge found it): no surface above it.
        top_z: crop.max_height_mm.filter(|_| on_turntable && !cx.passes()),
        force: params.force,
    };
    let fp = stages::mesh_fingerprint(&mp).input(input.name, input.hash);
    let views = report.views.len();
    // The mesh as written (normals, colours), for its copies in other formats.
    let mut written: Option<PolyMesh> = None;
    let mut warnings = Vec::new();
    let step = o.step(&[layout::MESH], fp, Scope::Scan, |fp| {
        let cloud = input.take(o)?;
        // Progress from inside: AdFFT's sweep, plane by plane (minutes at depth 10).
        let made = super::watch::watched(
            mp.reconstruct.counted_steps(),
            |steps| stages::mesh_counting(&cloud, &mp, steps),
            |done, total| progress(Stage::Reconstruct, done, total),
        )
        .map_err(|source| Error::Stage { stage: Stage::Reconstruct, source: laser_hint(source, method, views) })?;
        drop(cloud);
        warnings = made.warnings.iter().map(|w| format!("{}: {w}", layout::MESH)).collect();
        let bytes = rig::ply::mesh_to_bytes(&made.output, &o.object_opts());
        let hash = o.put(layout::MESH, &bytes, fp, &made.report)?;
        // Handed on as the file says (the remesher's input when run alone is the file).
        let back = rig::ply::parse(&bytes).and_then(|p| rig::ply::mesh_from_ply(&p));
        let back = back.map_err(|e| e.with_path(&o.path(layout::MESH)))?.triangulate();
        written = Some(made.output);
        Ok((back, hash, made.report))
    })?;
    // Reused, it is judged again from its record: a far mesh a forced run kept fails the next run
    // without --force instead of passing on in silence, and its top cut or open base is warned of
    // again.
    if let (true, Some(s)) = (step.reused(), &step.section) {
        let judged = stages::judge_mesh(&s.report, params.force);
        let judged = judged
            .map_err(|source| Error::Stage { stage: Stage::Reconstruct, source: laser_hint(source, method, views) })?;
        warnings = judged.into_iter().map(|w| format!("{}: {w}", layout::MESH)).collect();
    }
    report.warnings.extend(warnings);
    report.reconstruct = step.section;
    report.outputs.push(layout::MESH.into());
    // The same surface for printing (binary STL) and for web viewers (GLB).
    let source = (layout::MESH, step.hash);
    o.export(layout::MESH_STL, source, written.as_ref(), rig::stl::mesh_to_binary)?;
    o.export(layout::MESH_GLB, source, written.as_ref(), rig::glb::mesh_to_bytes)?;
    report.outputs.extend([layout::MESH_STL.into(), layout::MESH_GLB.into()]);
    Ok(Handed { name: layout::MESH, hash: step.hash, held: step.held })
}

/// A laser scan's surface between its lines is only what reconstruction makes up: too few views is
/// the usual cause of an unsupported mesh (made up between the lines: far from them, facing against
/// them, or losing some), and the fix — not of an inside-out one, whose normals point inward however
/// many views there are, nor of stray points apart from the object.
fn laser_hint(source: StageError, method: Method, views: usize) -> StageError {
    use stages::Finding::{FacingAgainst, Far, LeftOut};
    match (source, method) {
        (StageError::Unsupported { finding: finding @ (FacingAgainst | Far | LeftOut), what, hint }, Method::Laser) => {
            StageError::Unsupported {
                finding,
                what,
                hint: format!(
                    "this laser scan's {views} views put its lines {:.1}° apart: take more views (`scan --views`, \
                     `sim --views`); or {hint}",
                    360.0 / views.max(1) as Real
                ),
            }
        }
        (other, _) => other,
    }
}

/// Remesh: quads from harmonic fields (ch. 6), with progress from inside; written as OBJ and PLY.
pub(super) fn remesh_step(
    cx: &ScanCx,
    report: &mut ProcessReport,
    mut mesh: Handed<TriMesh>,
    progress: &mut impl Progress,
) -> Result<(), Error> {
    let (o, params) = (cx.o, cx.params);
    let fp = stages::remesh_fingerprint(&params.remesh).input(mesh.name, mesh.hash);
    let check = |rr: &crate::remesh::RemeshReport| {
        let warnings = stages::check_remesh(rr, params.force);
        let warnings = warnings.map_err(|source| Error::Stage { stage: Stage::Remesh, source })?;
        Ok::<_, Error>(warnings.into_iter().map(|w| format!("{}: {w}", layout::QUADS)).collect::<Vec<_>>())
    };
    let mut warnings = Vec::new();
    let step = o.step(&[layout::QUADS], fp, Scope::Scan, |fp| {
        let input = match mesh.held.take() {
            Some(m) => m,
            None => rig::read_mesh(&o.path(mesh.name))?.triangulate(),
        };
        // Progress from inside: the remesh's phases (fields and streamlines, quads, quality).
        let rp = &params.remesh;
        let (quads, rr) = super::watch::watched(
            crate::remesh::quad_remesh::REMESH_PHASES,
            |phases| stages::remesh_counting(&input, rp, phases),
            |done, total| progress(Stage::Remesh, done, total),
        )
        .map_err(|source| Error::Stage { stage: Stage::Remesh, source })?;
        // Checked before it is written: an unforced implausible remesh leaves no quads.
        warnings = check(&rr)?;
        // In millimetres, said as `scanrig remesh` says its input's unit: the same bytes.
        let hash = o.put(layout::QUADS, &rig::obj::mesh_to_bytes(&quads, o.opts.units()), fp, &rr)?;
        Ok((quads, hash, rr))
    })?;
    // Reused, it is checked again from its record: quads a forced run kept are not passed on in
    // silence by the next run without --force.
    if let (true, Some(s)) = (step.reused(), &step.section) {
        warnings = check(&s.report)?;
    }
    report.warnings.extend(warnings);
    report.remesh = step.section;
    // PLY as well: Open3D's OBJ reader skips polygons unless asked to triangulate; its PLY reader keeps them.
    let opts = o.opts.clone();
    let quads = step.held.as_ref();
    o.export(layout::QUADS_PLY, (layout::QUADS, step.hash), quads, |m| rig::ply::mesh_to_bytes(m, &opts))?;
    report.outputs.extend([layout::QUADS.into(), layout::QUADS_PLY.into()]);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use stages::Finding;

    /// Too few views are blamed only for what sparse lines cause: a surface made up between them.
    #[test]
    fn a_laser_scan_is_told_to_take_more_views_only_where_views_are_the_cause() {
        let unsupported =
            |finding| StageError::Unsupported { finding, what: "what".into(), hint: "remove them".into() };
        for finding in [Finding::FacingAgainst, Finding::Far, Finding::LeftOut] {
            let e = laser_hint(unsupported(finding), Method::Laser, 6).to_string();
            assert!(e.contains("6 views put its lines 60.0° apart") && e.ends_with("or remove them"), "{e}");
            let e = laser_hint(unsupported(finding), Method::StructuredLight, 6).to_string();
            assert_eq!(e, "what; remove them");
        }
        for finding in [Finding::Apart, Finding::InsideOut] {
            assert_eq!(laser_hint(unsupported(finding), Method::Laser, 6).to_string(), "what; remove them");
        }
    }
}

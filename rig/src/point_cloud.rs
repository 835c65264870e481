//! Point clouds: positions with optional per-point attributes.

use crate::math::{Point3, Real, Vector3};

/// N points with optional normals, colours, confidences and view ids; every present attribute has
/// exactly N entries.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PointCloud {
    /// Positions (mm unless the source file says otherwise).
    pub positions: Vec<Point3>,
    /// Unit normals, oriented toward the sensor where one is known.
    pub normals: Option<Vec<Vector3>>,
    /// 8-bit RGB colours.
    pub colors: Option<Vec<[u8; 3]>>,
    /// Per-point confidence (larger is more trusted; the scale is the producer's).
    pub confidence: Option<Vec<f32>>,
    /// The view (scan) each point came from.
    pub view_id: Option<Vec<u32>>,
}

/// A cloud borrowed from arrays that live elsewhere (a caller's buffers, NumPy's): what the stages
/// that only read a cloud take, so such a caller's points are used where they lie, not copied.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CloudRef<'a> {
    /// Positions.
    pub positions: &'a [Point3],
    /// Normals, one per position.
    pub normals: Option<&'a [Vector3]>,
    /// Colours, one per position.
    pub colors: Option<&'a [[u8; 3]]>,
    /// Confidences, one per position.
    pub confidence: Option<&'a [f32]>,
    /// View ids, one per position.
    pub view_id: Option<&'a [u32]>,
}

impl<'a> CloudRef<'a> {
    /// Bare positions.
    pub fn positions(positions: &'a [Point3]) -> Self {
        CloudRef { positions, ..Default::default() }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True for a cloud without points.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// The points at `indices`, in that order, with all their attributes, as an owned cloud.
    ///
    /// # Panics
    /// If an index is out of range.
    pub fn select(&self, indices: &[usize]) -> PointCloud {
        fn pick<T: Copy>(v: Option<&[T]>, indices: &[usize]) -> Option<Vec<T>> {
            v.map(|v| indices.iter().map(|&i| v[i]).collect())
        }
        PointCloud {
            positions: indices.iter().map(|&i| self.positions[i]).collect(),
            normals: pick(self.normals, indices),
            colors: pick(self.colors, indices),
            confidence: pick(self.confidence, indices),
            view_id: pick(self.view_id, indices),
        }
    }
}

impl<'a> From<&'a PointCloud> for CloudRef<'a> {
    fn from(cloud: &'a PointCloud) -> Self {
        cloud.borrowed()
    }
}

impl PointCloud {
    /// A cloud of bare positions.
    pub fn from_positions(positions: Vec<Point3>) -> Self {
        PointCloud { positions, ..Default::default() }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True for a cloud without points.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// The axis-aligned bounding box, `None` for an empty cloud.
    pub fn bounding_box(&self) -> Option<Aabb> {
        Aabb::of(&self.positions)
    }

    /// The points at `indices`, in that order, with all their attributes.
    ///
    /// # Panics
    /// If an index is out of range.
    pub fn select(&self, indices: &[usize]) -> PointCloud {
        self.borrowed().select(indices)
    }

    /// The cloud borrowed, attribute by attribute.
    pub fn borrowed(&self) -> CloudRef<'_> {
        CloudRef {
            positions: &self.positions,
            normals: self.normals.as_deref(),
            colors: self.colors.as_deref(),
            confidence: self.confidence.as_deref(),
            view_id: self.view_id.as_deref(),
        }
    }

    /// Checks every attribute has one entry per point; returns the first that does not.
    pub fn check_lengths(&self) -> Result<(), String> {
        let n = self.positions.len();
        let lens = [
            ("normals", self.normals.as_ref().map(Vec::len)),
            ("colors", self.colors.as_ref().map(Vec::len)),
            ("confidence", self.confidence.as_ref().map(Vec::len)),
            ("view_id", self.view_id.as_ref().map(Vec::len)),
        ];
        for (name, len) in lens {
            if let Some(len) = len.filter(|&l| l != n) {
                return Err(format!("{name} has {len} entries for {n} points"));
            }
        }
        Ok(())
    }
}

/// An axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// The smallest coordinates.
    pub min: Point3,
    /// The largest coordinates.
    pub max: Point3,
}

impl Aabb {
    /// The box of some points, `None` when there are none.
    pub fn of<'a>(points: impl IntoIterator<Item = &'a Point3>) -> Option<Aabb> {
        let mut it = points.into_iter();
        let first = *it.next()?;
        Some(it.fold(Aabb { min: first, max: first }, |b, p| Aabb { min: b.min.inf(p), max: b.max.sup(p) }))
    }

    /// The length of the diagonal.
    pub fn diagonal(&self) -> Real {
        (self.max - self.min).norm()
    }
}

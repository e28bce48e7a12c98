//! An orbit's cameras (`raycast render --orbit N`, docs/datasets.md#orbits): a turntable about
//! the scene camera's up direction through the centre of the scene's bounded objects (spheres
//! and triangles), far enough for their box to fit the image, restricted to the arc where the
//! eye stays on the objects' side of every plane, so that no view films the back of a wall.

use std::f64::consts::{FRAC_PI_2, TAU};

use glam::DVec3;

use super::camera::{default_depth_white, default_near};
use super::{Camera, CameraOverrides, Lens, MAX_MAGNITUDE, Object, Projection, Scene, Triangle};
use crate::error::{Error, Result};

/// A box, by its lowest and highest corners.
type Bounds = (DVec3, DVec3);

/// N views around each scene, as `raycast render --orbit N` renders them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// How many views, at least 1 (`orbit-000`, `orbit-001`, ...).
    pub views: u32,
    /// The eye's distance from the centre (`--orbit-radius`); by default far enough for the
    /// objects' box to fit the image. Nearer where the scene's planes leave less room.
    pub radius: Option<f64>,
    /// The views' elevation above the turntable's plane, in degrees within (-90, 90)
    /// (`--orbit-elevation`); by default the scene camera's, within 80.
    pub elevation: Option<f64>,
    /// The scene camera's settings the orbit starts from instead: `eye` the direction of the
    /// first view, `look_at` the centre, `up` the turntable's axis, `fov` the lens.
    pub camera: CameraOverrides,
}

/// The highest and lowest an orbit's views look from by default, radians (80 degrees): beyond,
/// the view direction would near the up direction.
const DEFAULT_ELEVATION_LIMIT: f64 = 80.0 * std::f64::consts::PI / 180.0;

/// How near a flat scene's plane (every bounded object in one plane) an eye may look from: the
/// sine of 30 degrees. Nearer, the objects thin to a line.
const FLAT_VIEW_SINE: f64 = 0.5;

/// Where the azimuths of the views may lie, in radians from the first view's direction.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Arc {
    /// The whole turn.
    Full,
    /// From the first (at most 0) to the second (at least 0).
    Between(f64, f64),
}

impl Arc {
    fn width(self) -> f64 {
        match self {
            Arc::Full => TAU,
            Arc::Between(lo, hi) => hi - lo,
        }
    }

    /// View `k` of `n`: evenly around the whole turn from the start, or across the arc from
    /// end to end.
    fn azimuth(self, k: u32, n: u32) -> f64 {
        match self {
            Arc::Full => TAU * f64::from(k) / f64::from(n),
            Arc::Between(..) if n == 1 => 0.0,
            Arc::Between(lo, hi) => lo + (hi - lo) * f64::from(k) / f64::from(n - 1),
        }
    }
}

/// A condition on the azimuth `t`: `a cos t + b sin t + c >= 0`.
#[derive(Clone, Copy, Debug)]
struct Condition([f64; 3]);

impl Condition {
    fn holds_at_start(&self) -> bool {
        let [a, _, c] = self.0;
        a + c >= 0.0
    }

    /// The interval of azimuths around 0 where it holds (it holds at 0), or none where it
    /// holds all the way round.
    fn interval(&self) -> Option<(f64, f64)> {
        let [a, b, c] = self.0;
        let r = a.hypot(b);
        if c >= r {
            return None;
        }
        let half = (-c / r).clamp(-1.0, 1.0).acos();
        let middle = b.atan2(a);
        Some(((middle - half).min(0.0), (middle + half).max(0.0)))
    }
}

/// The turntable: its axis and the directions of azimuth 0 and a quarter turn on, all unit.
struct Turntable {
    up: DVec3,
    level: DVec3,
    side: DVec3,
    elevation: f64,
}

impl Turntable {
    /// The direction from the centre to the eye at azimuth `t`.
    fn direction(&self, t: f64) -> DVec3 {
        let around = self.level * t.cos() + self.side * t.sin();
        around * self.elevation.cos() + self.up * self.elevation.sin()
    }

    /// `[a, b, c]` with `direction(t) . n = a cos t + b sin t + c`.
    fn along(&self, n: DVec3) -> [f64; 3] {
        let flat = self.elevation.cos();
        [
            flat * n.dot(self.level),
            flat * n.dot(self.side),
            self.elevation.sin() * n.dot(self.up),
        ]
    }
}

/// Where an orbit's views stand: on `turntable` at `distance` from `centre`, within `arc`;
/// `corners` are those of the objects' box, from the centre.
struct Ring {
    centre: DVec3,
    corners: [DVec3; 8],
    turntable: Turntable,
    distance: f64,
    arc: Arc,
}

/// A plane as an orbit keeps to its side: the eye at least `margin` from it on the side of
/// `normal`, where `height` is the orbit centre's distance from it.
struct Wall {
    normal: DVec3,
    height: f64,
    margin: f64,
}

/// One view with every setting its default: `Orbit { views: n, ..Orbit::default() }` is an
/// orbit of `n` views.
impl Default for Orbit {
    fn default() -> Orbit {
        Orbit {
            views: 1,
            radius: None,
            elevation: None,
            camera: CameraOverrides::default(),
        }
    }
}

impl Orbit {
    /// Refuses settings out of range, naming them.
    fn check(&self) -> Result<()> {
        let refuse = |option: &str, message: String| {
            Err(Error::Argument {
                option: option.into(),
                message,
            })
        };
        if self.views == 0 {
            return refuse("orbit", "needs at least 1 view, got 0".into());
        }
        if let Some(r) = self.radius
            && !(r.is_finite() && r > 0.0 && r <= MAX_MAGNITUDE)
        {
            return refuse(
                "orbit_radius",
                format!("must be a positive distance of at most {MAX_MAGNITUDE:e} (got {r})"),
            );
        }
        if let Some(e) = self.elevation
            && !(e > -90.0 && e < 90.0)
        {
            return refuse(
                "orbit_elevation",
                format!("must be between -90 and 90 degrees, both excluded (got {e})"),
            );
        }
        self.camera.check()
    }

    /// The views' names, `orbit-000`, ... (more digits past 1000), once the settings are
    /// checked: an error names one out of range.
    pub fn names(&self) -> Result<Vec<String>> {
        self.check()?;
        let width = (self.views - 1).to_string().len().max(3);
        Ok((0..self.views)
            .map(|k| format!("orbit-{k:0width$}"))
            .collect())
    }

    /// Every view's camera for `scene`, whose own camera is the orbit's start
    /// (docs/datasets.md#orbits). The ring is found once for all the views.
    pub fn cameras(&self, scene: &Scene) -> Result<Vec<Camera>> {
        let objects = &scene.objects;
        // The box of the spheres and triangles (the orbit's sphere), and of every object (a
        // camera's default `near`).
        let bounded = super::bounds(
            objects
                .iter()
                .filter(|o| !matches!(o, Object::Plane { .. })),
        );
        let all = super::bounds(objects);
        let start = self.start(&scene.camera)?;
        let ring = self.ring(&start, objects, bounded, all);
        (0..self.views)
            .map(|k| self.view(&start, &ring, all, k))
            .collect()
    }

    /// View `k`'s camera on `ring`, from `start` (`all` the box of every object).
    fn view(&self, start: &Camera, ring: &Ring, all: Option<Bounds>, k: u32) -> Result<Camera> {
        let direction = ring.turntable.direction(ring.arc.azimuth(k, self.views));
        let eye = ring.centre + direction * ring.distance;
        let mut camera = Camera {
            eye,
            look: ring.centre - eye,
            up: start.up,
            ..start.clone()
        };
        match camera.lens {
            Lens::Size { .. } => {
                let toward =
                    (ring.corners.iter().map(|c| c.dot(direction))).fold(f64::MIN, f64::max);
                bring_near(&mut camera, ring.distance - toward, ring.distance);
            }
            _ => {
                camera.focal_length = default_near(eye, all);
                camera.depth_white = default_depth_white(eye, all).max(camera.focal_length);
            }
        }
        match camera.oversized_plane() {
            None => Ok(camera),
            Some(x) => Err(Error::Argument {
                option: if self.camera.fov.is_some() {
                    "fov"
                } else {
                    "orbit"
                }
                .into(),
                message: format!(
                    "gives an image plane of size {x:e}, beyond the supported {MAX_MAGNITUDE:e}"
                ),
            }),
        }
    }

    /// Where the views of a scene stand around its objects, seen from `start`.
    fn ring(
        &self,
        start: &Camera,
        objects: &[Object],
        bounded: Option<Bounds>,
        all: Option<Bounds>,
    ) -> Ring {
        let (lo, hi) = bounded
            .or(all)
            .unwrap_or((DVec3::splat(-1.0), DVec3::splat(1.0)));
        let middle = (lo + hi) / 2.0;
        let centre = self.camera.look_at.unwrap_or(middle);
        let corners = corners(lo, hi).map(|c| c - centre);
        let size = (corners.iter().map(|c| c.length())).fold(f64::MIN_POSITIVE, f64::max);
        let turntable = self.turntable(start, centre);
        let (walls, flat) = match bounded {
            Some((lo, hi)) => (
                walls(objects, middle, centre, size),
                flat_normal(objects, (hi - lo).length()),
            ),
            None => (Vec::new(), None),
        };
        let conditions = |distance: f64| conditions(&turntable, distance, &walls, flat);
        let framed = (self.radius).unwrap_or_else(|| framing(start, &turntable, &corners));
        let (distance, arc) = match arc(&conditions(framed)) {
            Some(arc) => (framed, arc),
            None => nearer(framed, &conditions),
        };
        Ring {
            centre,
            corners,
            turntable,
            distance,
            arc,
        }
    }

    /// `base` with the eye, up direction and field of view this orbit sets.
    fn start(&self, base: &Camera) -> Result<Camera> {
        let fov = CameraOverrides {
            fov: self.camera.fov,
            ..CameraOverrides::default()
        };
        let mut start = fov.apply(base)?;
        start.eye = self.camera.eye.unwrap_or(start.eye);
        start.up = self.camera.up.unwrap_or(start.up);
        Ok(start)
    }

    /// The turntable about `start`'s up through `centre`, azimuth 0 where `start`'s eye is,
    /// at this orbit's elevation or the eye's.
    fn turntable(&self, start: &Camera, centre: DVec3) -> Turntable {
        let up = start.up.normalize();
        let look = start.look.normalize();
        let from = (start.eye - centre).try_normalize().unwrap_or(-look);
        let level = (from - up * from.dot(up))
            .try_normalize()
            .or_else(|| (-look - up * -look.dot(up)).try_normalize())
            .unwrap_or_else(|| up.any_orthonormal_vector());
        let elevation = match self.elevation {
            Some(degrees) => degrees.to_radians(),
            None => (from.dot(up).clamp(-1.0, 1.0).asin())
                .clamp(-DEFAULT_ELEVATION_LIMIT, DEFAULT_ELEVATION_LIMIT),
        };
        Turntable {
            up,
            level,
            side: up.cross(level),
            elevation,
        }
    }
}

/// The corners of the box from `lo` to `hi`.
fn corners(lo: DVec3, hi: DVec3) -> [DVec3; 8] {
    std::array::from_fn(|k| {
        DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// How many azimuths [`framing`] tries: every half degree.
const FRAMING_AZIMUTHS: u32 = 720;

/// The least distance from the centre at which, from every azimuth of the turntable, the box
/// of `corners` (from the centre) fits `start`'s image and lies beyond its image plane.
fn framing(start: &Camera, turntable: &Turntable, corners: &[DVec3; 8]) -> f64 {
    let plane = start.image_plane();
    let d = start.focal_length;
    // Tangents of the half fields of view; an orthographic image does not grow with distance.
    let (tx, ty) = match start.projection {
        Projection::Perspective => (plane.width / 2.0 / d, plane.height / 2.0 / d),
        Projection::Orthographic => (f64::INFINITY, f64::INFINITY),
    };
    let mut distance = f64::MIN_POSITIVE;
    for j in 0..FRAMING_AZIMUTHS {
        let direction = turntable.direction(TAU * f64::from(j) / f64::from(FRAMING_AZIMUTHS));
        let view = Camera {
            look: -direction,
            up: turntable.up,
            ..start.clone()
        };
        let [u, v, _] = view.basis();
        for c in corners {
            // The corner at depth distance - c.direction: within the image and the near plane.
            let reach = (c.dot(u).abs() / tx).max(c.dot(v).abs() / ty).max(d);
            distance = distance.max(reach + c.dot(direction));
        }
    }
    distance
}

/// The planes of `objects`, each as a wall on the side of `middle` (the bounded objects'
/// centre): planes through `middle`, or with `centre` (the orbit's) on their other side, are
/// left out, as no eye can keep to them. The margin is a tenth of `size` (the orbit's sphere),
/// at most half the centre's height above the plane.
fn walls(objects: &[Object], middle: DVec3, centre: DVec3, size: f64) -> Vec<Wall> {
    let planes = objects.iter().filter_map(|o| match o {
        Object::Plane { point, normal } => Some((
            DVec3::from(point.to_array()),
            DVec3::from(normal.to_array()),
        )),
        _ => None,
    });
    planes
        .filter_map(|(point, normal)| {
            let side = normal.dot(middle - point);
            let normal = normal * side.signum();
            let height = normal.dot(centre - point);
            (side.abs() > 1e-12 * size && height > 0.0).then_some(Wall {
                normal,
                height,
                margin: (size / 10.0).min(height / 2.0),
            })
        })
        .collect()
}

/// The normal of the plane every bounded object of `objects` lies in (triangles only, within
/// a millionth of `extent`, the diagonal of their box), if there is one.
fn flat_normal(objects: &[Object], extent: f64) -> Option<DVec3> {
    let mut triangles: Vec<&[Triangle]> = Vec::new();
    for object in objects {
        match object {
            Object::Sphere { .. } => return None,
            Object::Plane { .. } => {}
            Object::Triangle { corners } => triangles.push(std::slice::from_ref(corners)),
            Object::Soup { triangles: t, .. } => triangles.push(t),
        }
    }
    let corners = || triangles.iter().flat_map(|t| t.iter());
    let (origin, normal) = corners().find_map(|[a, b, c]| {
        let (a, b, c) = (*a, *b, *c);
        let n = (b - a).cross(c - a);
        (n.length() > 1e-9 * extent * extent).then(|| (a, n.normalize()))
    })?;
    corners()
        .flatten()
        .all(|&p| normal.dot(p - origin).abs() <= 1e-6 * extent)
        .then_some(normal)
}

/// What the eye at `distance` from the centre must meet, as conditions on the azimuth: on the
/// objects' side of every wall by its margin, and, for flat objects, away from their plane on
/// the side the first view looks from (unless the first view is nearer their plane already).
fn conditions(
    turntable: &Turntable,
    distance: f64,
    walls: &[Wall],
    flat: Option<DVec3>,
) -> Vec<Condition> {
    let mut conditions: Vec<Condition> = walls
        .iter()
        .map(|w| {
            let [a, b, c] = turntable.along(w.normal);
            Condition([
                distance * a,
                distance * b,
                w.height - w.margin + distance * c,
            ])
        })
        .collect();
    if let Some(n) = flat {
        let [a, b, c] = turntable.along(n);
        let sign = (a + c).signum();
        let away = Condition([sign * a, sign * b, sign * c - FLAT_VIEW_SINE]);
        if away.holds_at_start() {
            conditions.push(away);
        }
    }
    conditions
}

/// The arc of azimuths around the first view's where every condition holds, or none where the
/// first view's fails one.
fn arc(conditions: &[Condition]) -> Option<Arc> {
    if !conditions.iter().all(Condition::holds_at_start) {
        return None;
    }
    let intervals = conditions.iter().filter_map(Condition::interval);
    let (lo, hi) = intervals.fold((-TAU, TAU), |(lo, hi), (a, b)| (lo.max(a), hi.min(b)));
    Some(if hi - lo >= TAU {
        Arc::Full
    } else {
        Arc::Between(lo, hi)
    })
}

/// Where the eye cannot stand at `framed` even for the first view: the farthest distance at
/// which the arc spans a quarter turn (or all it can, if less), and that arc.
fn nearer(framed: f64, conditions: &dyn Fn(f64) -> Vec<Condition>) -> (f64, Arc) {
    let widest = arc(&conditions(0.0)).map_or(0.0, Arc::width);
    let wanted = FRAC_PI_2.min(widest);
    let enough = |distance: f64| arc(&conditions(distance)).filter(|a| a.width() >= wanted);
    let (mut near, mut far) = (0.0, framed);
    for _ in 0..64 {
        let middle = (near + far) / 2.0;
        match enough(middle) {
            Some(_) => near = middle,
            None => far = middle,
        }
    }
    let distance = if near > 0.0 { near } else { framed * 1e-6 };
    (distance, enough(distance).unwrap_or(Arc::Full))
}

/// Brings a course camera's image plane (the focal length, with its size, so the field of
/// view stays) to at most `nearest`, the depth of the box's nearest corner, where rays would
/// otherwise start past the objects; a thousandth of `distance` where the eye is in the box.
fn bring_near(camera: &mut Camera, nearest: f64, distance: f64) {
    let limit = if nearest > 0.0 {
        nearest
    } else {
        distance / 1000.0
    };
    let scale = limit / camera.focal_length;
    if scale >= 1.0 {
        return;
    }
    camera.focal_length *= scale;
    camera.depth_white *= scale;
    if let (Projection::Perspective, Lens::Size { width, height }) =
        (camera.projection, camera.lens)
    {
        camera.lens = Lens::Size {
            width: width * scale,
            height: height * scale,
        };
    }
}
